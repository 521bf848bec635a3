"""The options of a conversion as typed objects, checked once, where they are made.

:class:`ConvertOptions` holds the paper's :class:`~depixel.params.Params`, how the input is
prepared (:class:`~depixel.prepare.inputs.PrepareOptions`), what is written
(:class:`OutputOptions`) and the resource :class:`Limits`. The edges build it once — the keyword
functions of the API (:func:`depixel.convert`, :func:`depixel.convert_file`, …, through
:meth:`ConvertOptions.build`) and the command line from its arguments — and pass it inward
whole. Each object checks its fields when it is made, raising
:class:`~depixel.errors.ParameterError` named after the field, and keeps them normalized (a
colour name as its ``(r, g, b)``, a scale as a float): an object that exists is valid.

A file's stamp digests every field of the prepare and output options
(:func:`depixel.files.convert.options_digest`); docs/design.md, "Options", says how to add one.
"""
from __future__ import annotations

from dataclasses import dataclass, fields
from typing import TYPE_CHECKING

from . import validate
from .errors import ParameterError
from .frozen import added
from .limits import DEFAULT_MAX_FRAMES, DEFAULT_MAX_OUTPUT_PIXELS, DEFAULT_MAX_PIXELS
from .params import Params
from .pipeline import STAGES
from .prepare.inputs import PrepareOptions
from .svg.outlines import LAYOUTS
from .svg.writer import DEFAULT_PRECISION, DEFAULT_SIMPLIFY, MAX_SIMPLIFY, SHADINGS

if TYPE_CHECKING:
    from .prepare.sheet_json import SheetJson

__all__ = ["ConvertOptions", "Limits", "OutputOptions", "PrepareOptions"]


@dataclass(frozen=True)
class OutputOptions:
    """What a conversion writes (docs/svg.md): up to which stage, at which size, and how."""

    stage: str = "optimized"  # stop the pipeline early: "cells", "splines" (no §3.4), "optimized"
    scale: float = 1.0  # the output's width/height as a multiple of the input's size
    width: int | None = None  # or its width in pixels (the height follows)
    height: int | None = None  # or its height in pixels (the width follows)
    precision: int = DEFAULT_PRECISION  # decimals of the SVG's coordinates
    layout: str = "stacked"  # SVG shapes stacked (each continues under those above) or "cutout"
    simplify: float = DEFAULT_SIMPLIFY  # tolerance in pixels of the curves that replace the spline (0: exact)
    shading: str = "smooth"  # the paper's smooth shading (SVG filter, PNG renderer), or "flat" bands
    animate: bool = added(False)  # every frame of an animation in one file: an animated SVG or PNG (APNG)
    #: a sprite sheet, each sprite converted alone: "auto" (found), or a grid "WxH[+GAP[,GAPY]][@X,Y]"
    sheet: str | None = added(None)
    #: or the sprites an Aseprite/TexturePacker JSON file places (a path, its bytes or decoded
    #: object: a SheetJson once made)
    sheet_json: SheetJson | str | None = added(None)
    #: with animate: the Aseprite tag whose frames play, in its direction and repeat count (None: every frame)
    tag: str | None = added(None)

    def __post_init__(self) -> None:
        normal: dict[str, object] = {"stage": validate.choice("stage", self.stage, STAGES),
                                     "scale": float(validate.positive("scale", self.scale))}
        if self.width is not None and self.height is not None:
            raise ParameterError("give width or height, not both (the other follows the aspect ratio)",
                                 parameter="width")
        for key in ("width", "height"):
            value = getattr(self, key)
            normal[key] = None if value is None else int(validate.number(key, value, low=1, integer=True))
        normal |= {"precision": int(validate.number("precision", self.precision, low=0, high=12, integer=True)),
                   "layout": validate.choice("layout", self.layout, LAYOUTS),
                   "simplify": float(validate.number("simplify", self.simplify, low=0, high=MAX_SIMPLIFY)),
                   "shading": validate.choice("shading", self.shading, SHADINGS),
                   "animate": validate.flag("animate", self.animate)}
        if self.is_sheet:  # (the sheet's modules are imported only then: ~10 ms of every start otherwise)
            from .prepare.sheet import sheet_spec  # noqa: PLC0415
            from .prepare.sheet_json import sheet_json_of  # noqa: PLC0415

            normal |= {"sheet": None if self.sheet is None else sheet_spec(self.sheet),
                       "sheet_json": sheet_json_of(self.sheet_json)}
            if normal["sheet"] is not None and normal["sheet_json"] is not None:
                raise ParameterError("give sheet or sheet_json, not both (the JSON places the sprites itself)",
                                     parameter="sheet")
            if normal["animate"]:
                raise ParameterError("animate plays the frames of an animated file; a sheet's sprites are written "
                                     "as layers or files (give animate or a sheet, not both)", parameter="animate")
        if self.tag is not None and not isinstance(self.tag, str):
            raise ParameterError(f"tag must be the name of a tag (a str), not {self.tag!r}", parameter="tag")
        if self.tag is not None and not normal["animate"]:
            raise ParameterError("tag plays an Aseprite tag's frames as one animation: give animate=True too (one "
                                 "frame of it: frame=N, depixel.tag_frames lists them)", parameter="tag")
        for name, value in normal.items():
            object.__setattr__(self, name, value)

    def scale_for(self, width: int, height: int) -> float:
        """The scale of an input of ``width`` × ``height`` pixels: the one that gives
        :attr:`width` (or :attr:`height`) pixels, else :attr:`scale`."""
        if self.width is not None:
            return self.width / width
        if self.height is not None:
            return self.height / height
        return self.scale

    @property
    def is_sheet(self) -> bool:
        """Whether the input is a sprite sheet, converted sprite by sprite."""
        return self.sheet is not None or self.sheet_json is not None

    @property
    def size_parameter(self) -> str:
        """The option that sets the output's size, for messages: width, height or scale."""
        return "width" if self.width is not None else "height" if self.height is not None else "scale"


@dataclass(frozen=True)
class Limits:
    """The resource limits of a conversion, each a positive integer or None for none
    (docs/limits.md); they refuse work, never change an output, so no stamp holds them."""

    max_pixels: int | None = DEFAULT_MAX_PIXELS  # pixels of an input image (of all frames, for every frame)
    max_output_pixels: int | None = DEFAULT_MAX_OUTPUT_PIXELS  # pixels of a PNG output (of all, for frames)
    max_frames: int | None = DEFAULT_MAX_FRAMES  # frames of an animation converted whole

    def __post_init__(self) -> None:
        for item in fields(self):
            object.__setattr__(self, item.name, validate.limit(item.name, getattr(self, item.name)))


#: The parts of :class:`ConvertOptions` that :meth:`ConvertOptions.build` fills from keywords.
_PARTS = {"output": OutputOptions, "prepare": PrepareOptions, "limits": Limits}


@dataclass(frozen=True)
class ConvertOptions:
    """Everything that decides a conversion: the paper's parameters, the input's
    preparation, the output and the limits."""

    params: Params = Params()
    prepare: PrepareOptions = PrepareOptions()
    output: OutputOptions = OutputOptions()
    limits: Limits = Limits()

    def __post_init__(self) -> None:
        _check_params(self.params)
        for name, kind in _PARTS.items():
            if not isinstance(getattr(self, name), kind):
                raise ParameterError(f"{name} must be a {kind.__name__}, not {type(getattr(self, name)).__name__}",
                                     parameter=name)

    @classmethod
    def build(cls, params: Params = Params(), **keywords) -> ConvertOptions:
        """The options from keyword arguments, each named after a field of
        :class:`OutputOptions`, :class:`PrepareOptions` or :class:`Limits` (the public
        functions' keywords); an unknown name is a ``TypeError``, as for any function."""
        _check_params(params)  # before the other checks, as the keyword functions always did
        parts = {}
        for name, kind in _PARTS.items():
            names = {item.name for item in fields(kind)}
            parts[name] = kind(**{key: keywords.pop(key) for key in list(keywords) if key in names})
        if keywords:
            raise TypeError(f"unknown option {sorted(keywords)[0]!r}")
        return cls(params, **parts)


def _check_params(params: object) -> None:
    if not isinstance(params, Params):
        raise ParameterError(f"params must be a depixel.Params, not {type(params).__name__}", parameter="params")
