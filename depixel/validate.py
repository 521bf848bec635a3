"""Checks of the arguments the library's entry points take, with one-line messages.

Every check raises :class:`depixel.errors.ParameterError` naming the parameter (in the
message and in ``parameter=``), so a front end can rewrite it as its own option name.
"""
from __future__ import annotations

import math
import numbers
from collections.abc import Iterable
from typing import TYPE_CHECKING, Protocol, cast

if TYPE_CHECKING:
    import numpy as np


class Swap(Protocol):
    """What recolours pixels (:class:`depixel.prepare.gpl.PaletteMap`)."""

    def apply(self, rgba: np.ndarray) -> np.ndarray: ...


def number(name: str, value: object, *, low: float | None = None, high: float | None = None,
           low_open: bool = False, integer: bool = False, kind: str = "") -> float:
    """``value`` as a finite real number within [low, high] (``low_open``: above ``low``);
    ``integer`` also refuses fractions. Booleans are refused (``True`` is not a scale)."""
    from .errors import ParameterError  # noqa: PLC0415

    what = kind or ("an integer" if integer else "a number")
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ParameterError(f"{name} must be {what}, not {value!r}", parameter=name)
    # an int stays an int (a seed may exceed a float's precision); float for the type checker
    value = cast(float, value)
    if not math.isfinite(value):
        raise ParameterError(f"{name} must be a finite number, not {value!r}", parameter=name)
    if integer and not isinstance(value, numbers.Integral) and value != int(value):
        raise ParameterError(f"{name} must be an integer, not {value!r}", parameter=name)
    given = shown(value) if isinstance(value, numbers.Integral) else repr(value)
    too_low = low is not None and (value <= low if low_open else value < low)
    if too_low or (high is not None and value > high):
        if low == 0 and low_open and high is None:
            bounds = "a positive number"
        elif low is not None and high is not None:
            bounds = f"between {_text(low)} and {_text(high)}"
        elif low is not None:
            bounds = f"above {_text(low)}" if low_open else f"at least {_text(low)}"
        else:
            bounds = f"at most {_text(cast(float, high))}"
        raise ParameterError(f"{name} must be {bounds}, not {given}", parameter=name)
    return value


def positive(name: str, value: object) -> float:
    """A finite number above 0 (scales, sizes in output units)."""
    return number(name, value, low=0, low_open=True, kind="a positive number")


def limit(name: str, value: object) -> int | None:
    """A pixel or byte limit: a positive integer, or None for none."""
    return None if value is None else int(number(name, value, low=1, integer=True))


def flag(name: str, value: object) -> bool:
    """True or False (``1`` or ``"yes"`` are refused: they hide a mistaken argument)."""
    from .errors import ParameterError  # noqa: PLC0415

    if not isinstance(value, bool):
        raise ParameterError(f"{name} must be True or False, not {value!r}", parameter=name)
    return value


def choice(name: str, value: object, options: Iterable[str]) -> str:
    """One of ``options`` (a misspelt choice gets a suggestion)."""
    from .errors import ParameterError  # noqa: PLC0415

    options = tuple(options)
    if value not in options:
        import difflib  # noqa: PLC0415

        close = difflib.get_close_matches(str(value), options, n=1)
        hint = f" (did you mean {close[0]!r}?)" if close else ""
        raise ParameterError(f"unknown {name} {value!r}{hint}; choose one of {', '.join(options)}",
                             parameter=name)
    return value


def _text(bound: float) -> str:
    return str(int(bound)) if float(bound).is_integer() else f"{bound:g}"


def shown(value: float) -> str:
    """A number as a message shows it: whole numbers up to 15 digits as they are, other
    numbers in four significant digits (``1e+300``, not 301 digits of a scale's overflow)."""
    if isinstance(value, numbers.Integral) and abs(value) >= 10**15:  # maybe too large for a float
        from decimal import Decimal  # noqa: PLC0415

        mantissa, _, exponent = format(Decimal(int(value)), ".4g").partition("e")
        return f"{mantissa.rstrip('0').rstrip('.') if '.' in mantissa else mantissa}e{exponent}"
    if float(value).is_integer() and abs(value) < 1e15:
        return str(int(value))
    return f"{value:.4g}"


def page_size(fmt: str, width: float, height: float, name: str, parameter: str = "scale",
              error: type | None = None) -> None:
    """Refuse an SVG, PDF or EPS whose page (``width`` × ``height`` CSS pixels) readers cannot
    show: a PDF page outside the 3-14400 pt a side the PDF format allows (an EPS's bounding
    box too, as Illustrator's artboard), an SVG side beyond
    the coordinates cairo can place (renderers built on it drop path operators there) or so
    small that it is written as 0. The error (a :class:`ParameterError` unless ``error``
    says otherwise) names ``parameter``: the scale, or the width or height that set the size."""
    from .errors import ParameterError  # noqa: PLC0415
    from .limits import PDF_PAGE_POINTS, SVG_SIDE_PIXELS  # noqa: PLC0415

    if fmt in ("pdf", "eps"):
        low, high = PDF_PAGE_POINTS
        w, h = width * 0.75, height * 0.75  # 96 CSS pixels an inch, 72 points
        unit, what = " pt", f"a{'n' if fmt == 'eps' else ''} {fmt.upper()} page"
    elif fmt == "svg":
        (low, high), w, h, unit, what = SVG_SIDE_PIXELS, width, height, " px", "an SVG"
    else:
        return
    if low <= w <= high and low <= h <= high:
        return
    raise (error or ParameterError)(f"{name}: a {shown(w)}x{shown(h)}{unit} page is outside the {shown(low)} to "
                                    f"{shown(high)}{unit} a side {what} can have; choose another {parameter}",
                                    parameter=parameter)


def opaque(name: str, rgba: np.ndarray, palette_map: Swap | None = None) -> None:
    """Refuse an EPS of semi-transparent colours (``rgba``, swapped by ``palette_map``: the
    colours it paints): PostScript has no transparency, so cairo would draw them as raster
    images, which stock sites refuse (a :class:`~depixel.errors.RenderError` naming ``background``)."""
    from .errors import RenderError  # noqa: PLC0415

    alpha = (rgba if palette_map is None else palette_map.apply(rgba))[..., 3]
    translucent = int(((alpha > 0) & (alpha < 255)).sum())
    if translucent:
        raise RenderError(f"{name}: EPS cannot hold the {translucent} semi-transparent pixels without raster images; "
                          "flatten them over a colour with background (e.g. white)", parameter="background")


def png_size(size: tuple[int, int], scale: float, max_output_pixels: int | None, name: str) -> None:
    """Refuse a PNG of more than ``max_output_pixels`` pixels (an input of ``size``, ``scale``
    times) before it is rendered (a :class:`~depixel.errors.RenderError`)."""
    from .errors import RenderError  # noqa: PLC0415

    width, height = (max(1, round(side * scale)) for side in size)
    if max_output_pixels is not None and width * height > max_output_pixels:
        raise RenderError(f"{name}: a {shown(width)}x{shown(height)} PNG is {shown(width * height)} pixels, over "
                          f"the limit of {max_output_pixels} (raise it with max_output_pixels)",
                          parameter="max_output_pixels")
