"""What every command shares: exit codes, argument types, the tuning flags and messages."""
from __future__ import annotations

import argparse
import enum
import sys
from dataclasses import fields

from depixel.options import ConvertOptions, Limits, OutputOptions, PrepareOptions
from depixel.params import Params


class Exit(enum.IntEnum):
    """Exit codes of the ``depixel`` command, all in one place."""

    OK = 0
    FAILED = 1  # a file could not be converted/rendered; for diff: the images differ
    USAGE = 2  # bad command line; for diff: the files could not be compared
    INTERRUPTED = 130  # Ctrl-C


def error_exit(command: str) -> Exit:
    """Exit code of a library error (a DepixelError) in ``command``: diff keeps 1 for "differ"."""
    return Exit.USAGE if command == "diff" else Exit.FAILED


def say(message: str) -> None:
    """One line on stderr, prefixed like every depixel message."""
    print(f"depixel: {message}", file=sys.stderr, flush=True)


# --- argument types -------------------------------------------------------------------------

def _number(text: str, kind=float):
    try:
        value = kind(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a{'n integer' if kind is int else ' number'}: {text!r}") from None
    if value != value or value in (float("inf"), float("-inf")):
        raise argparse.ArgumentTypeError(f"not a finite number: {text!r}")
    return value


def positive_float(text: str) -> float:
    value = _number(text)
    if value <= 0:
        raise argparse.ArgumentTypeError(f"must be a positive number: {text!r}")
    return value


def non_negative_float(text: str) -> float:
    value = _number(text)
    if value < 0:
        raise argparse.ArgumentTypeError(f"must be zero or more: {text!r}")
    return value


def tolerance(text: str) -> float:
    """A simplification tolerance in pixels: 0 (none) up to MAX_SIMPLIFY."""
    from depixel.svg.writer import MAX_SIMPLIFY  # noqa: PLC0415

    value = non_negative_float(text)
    if value > MAX_SIMPLIFY:
        raise argparse.ArgumentTypeError(f"must be at most {MAX_SIMPLIFY:g} pixels: {text!r}")
    return value


def int_range(low: int, high: int | None = None):
    """Argument type: an integer in [low, high]."""
    def parse(text: str) -> int:
        value = _number(text, int)
        if value < low or (high is not None and value > high):
            bounds = f"at least {low}" if high is None else f"between {low} and {high}"
            raise argparse.ArgumentTypeError(f"must be an integer {bounds}: {text!r}")
        return value

    parse.__name__ = "integer"
    return parse


positive_int = int_range(1)
non_negative_int = int_range(0)


def unit_float(text: str) -> float:
    value = _number(text)
    if not 0 <= value <= 1:
        raise argparse.ArgumentTypeError(f"must be between 0 and 1: {text!r}")
    return value


def colour(text: str) -> tuple[int, int, int]:
    from depixel.colour import parse_colour  # noqa: PLC0415

    try:
        return parse_colour(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def pixel_size(text: str) -> str | tuple[int, int]:
    """``--pixel-size``: auto, N or NxM."""
    from depixel.errors import ParameterError  # noqa: PLC0415
    from depixel.prepare.inputs import parse_pixel_size  # noqa: PLC0415

    try:
        return parse_pixel_size(text)
    except ParameterError as exc:
        raise argparse.ArgumentTypeError(str(exc).replace("pixel_size ", "", 1)) from None


def transparent_colour(text: str) -> str | tuple[int, int, int]:
    """``--transparent``: auto or a colour."""
    return "auto" if text.strip().lower() == "auto" else colour(text)


#: --dask-timeout's default and largest value, seconds (docs/scale.md).
DASK_TIMEOUT, MAX_DASK_TIMEOUT = 60.0, 86400.0


def dask_timeout(text: str) -> float:
    value = positive_float(text)
    if value > MAX_DASK_TIMEOUT:
        raise argparse.ArgumentTypeError(f"at most {MAX_DASK_TIMEOUT:g} seconds (a day): {text!r}")
    return value


def add_dask_options(group) -> None:
    """``--dask ADDRESS`` and ``--dask-timeout SECONDS`` (docs/scale.md)."""
    group.add_argument("--dask", metavar="ADDRESS",
                       help="run the conversions on a Dask cluster (scheduler address, e.g. tcp://host:8786); "
                            "inputs and outputs must be on a filesystem the workers share; needs the dask extra: "
                            "pip install '/path/to/depixel[dask]'")
    group.add_argument("--dask-timeout", type=dask_timeout, default=DASK_TIMEOUT, metavar="SECONDS",
                       help=f"--dask: how long to wait for a worker, before the batch and while none is left "
                            f"(default {DASK_TIMEOUT:g})")


def add_input_options(parser: argparse.ArgumentParser) -> None:
    """The options that prepare pixel art as people have it (depixel/prepare/inputs.py)."""
    group = parser.add_argument_group("input (pixel art saved upscaled, as JPEG or on a backdrop; docs/inputs.md)")
    group.add_argument("--pixel-size", type=pixel_size, default="auto", metavar="auto|N|NxM",
                       help="input pixels per art pixel: auto detects nearest-neighbour upscaling (default), "
                            "1 takes the pixels as they are, N or NxM (width x height) forces a grid")
    group.add_argument("--denoise", action=argparse.BooleanOptionalAction, default=None,
                       help="snap near-identical colours to a small palette (default: on for JPEG and "
                            "lossy WebP files, off otherwise)")
    group.add_argument("--transparent", type=transparent_colour, metavar="COLOR|auto",
                       help="make the backdrop transparent: this colour where it reaches the image's border "
                            "(a flood fill; the same colour inside the art stays); auto: the colour of the four "
                            "corners when they agree")
    group.add_argument("--transparent-everywhere", action="store_true",
                       help="with --transparent: every pixel of that colour, inside the art too (a colour key)")


def check_input_options(args: argparse.Namespace) -> None:
    """Refuse input options that need another (a usage error, exit 2)."""
    if args.transparent_everywhere and args.transparent is None:
        args.parser.error("--transparent-everywhere says how --transparent COLOR|auto removes its colour: "
                          "give --transparent too")


# --- tuning flags: one per Params field a user may want to change -------------------------------

_DEFAULTS = {f.name: f.default for f in fields(Params)}
#: (flag, Params field, type, help) — the help shows the default from Params itself.
TUNING = [
    ("--threshold-y", "threshold_y", non_negative_float,
     "luma difference (0-255) above which neighbours are dissimilar"),
    ("--threshold-u", "threshold_u", non_negative_float, "U chroma difference above which neighbours are dissimilar"),
    ("--threshold-v", "threshold_v", non_negative_float, "V chroma difference above which neighbours are dissimilar"),
    ("--threshold-alpha", "threshold_alpha", non_negative_float,
     "alpha difference above which neighbours are dissimilar"),
    ("--curve-weight", "curve_weight", non_negative_float, "weight of the 'curves' heuristic for crossing diagonals"),
    ("--sparse-weight", "sparse_weight", non_negative_float, "weight of the 'sparse pixels' heuristic"),
    ("--sparse-window", "sparse_window", int_range(2), "side of the window the 'sparse pixels' heuristic looks at"),
    ("--island-weight", "island_weight", non_negative_float, "vote of the 'islands' heuristic"),
    ("--shading-distance", "shading_distance", non_negative_float,
     "YUV distance up to which an edge is a shading edge"),
    ("--iterations", "iterations", non_negative_int, "rounds of the spline optimization"),
]
#: what ``--seed`` (removed in issue 31) now says instead of seeding anything
SEED_NOTE = "--seed does nothing any more: the curve optimization has no random draws; leave it out"


def add_tuning(parser: argparse.ArgumentParser) -> None:
    group = parser.add_argument_group("tuning (the paper's parameters; see depixel/params.py)")
    for flag, name, kind, text in TUNING:
        group.add_argument(flag, dest=name, type=kind, default=None, metavar="N",
                           help=f"{text} (default {_DEFAULTS[name]:g})")
    group.add_argument("--no-optimize", dest="stage", action="store_const", const="splines",
                       help="skip the spline optimization (the same as --stage splines)")
    group.add_argument("--seed", dest="removed_seed", metavar="N", help=argparse.SUPPRESS)  # SEED_NOTE


def from_args(kind, args: argparse.Namespace, **given):
    """An options dataclass (``kind``: :class:`depixel.options.OutputOptions`, ``PrepareOptions``,
    ``Limits``) of the arguments of the same names, ``given`` overriding some: a field is its
    flag's ``dest``, so a new field without its flag fails here, at once."""
    return kind(**{item.name: given[item.name] if item.name in given else getattr(args, item.name)
                   for item in fields(kind)})


def convert_options(args: argparse.Namespace) -> ConvertOptions:
    """The :class:`depixel.options.ConvertOptions` of a conversion's arguments."""
    output = from_args(OutputOptions, args, tag=args.tag if args.animate else None)  # (a still's tag picks frames)
    return ConvertOptions(params_from_args(args), from_args(PrepareOptions, args), output, from_args(Limits, args))


def params_from_args(args: argparse.Namespace) -> Params:
    """A Params with the flags the user gave; every other field keeps its default. A ``--seed``
    (gone with the random trials) is noted on stderr and ignored, so old scripts still run."""
    if getattr(args, "removed_seed", None) is not None and not getattr(args, "quiet", False):
        print(f"depixel: note: {SEED_NOTE}", file=sys.stderr)
    given = {name: getattr(args, name) for _, name, _, _ in TUNING if getattr(args, name) is not None}
    return Params().replace(**given)


#: The CLI's name of each library parameter that error messages may name.
FLAG_OF_PARAMETER = {
    "max_pixels": "--max-pixels",
    "max_output_pixels": "--max-output-pixels",
    "max_frames": "--max-frames",
    "width": "--width",
    "height": "--height",
    "scale": "--scale",
    "fmt": "--format",
    "background": "--background",
    "precision": "--precision",
    "layout": "--layout",
    "simplify": "--simplify",
    "pixel_size": "--pixel-size",
    "transparent": "--transparent",
    "allow_size_mismatch": "--allow-size-mismatch",
    "animate": "--animate",
    "frame": "--frames",
    **{name: flag for flag, name, _, _ in TUNING},
}


def error_message(exc: BaseException) -> str:
    """A library error's one-line message, with library parameter names given as CLI flags."""
    from depixel.errors import DepixelError  # noqa: PLC0415

    return exc.message_for(FLAG_OF_PARAMETER) if isinstance(exc, DepixelError) else str(exc)
