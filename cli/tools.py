"""``depixel render`` and ``depixel inspect`` (``depixel diff`` is :mod:`depixel_cli.diff.command`)."""
from __future__ import annotations

import argparse
import io
import sys
from pathlib import Path

from depixel import api
from depixel.errors import InputError, OutputError, display_name
from depixel.files import convert as files
from depixel.files.output import write_atomic
from depixel.limits import DEFAULT_MAX_OUTPUT_PIXELS, DEFAULT_MAX_PIXELS
from depixel.pipeline import STAGES
from depixel.prepare.image import read_source

from .options import (
    Exit,
    add_input_options,
    add_tuning,
    check_input_options,
    colour,
    from_args,
    int_range,
    params_from_args,
    positive_float,
    positive_int,
)
from .streams import stdin_closed, write_stdout

RENDER_DESCRIPTION = """\
examples:
  depixel render sprite.svg -o sprite.png --scale 4     4x the SVG's width/height
  depixel render sprite.svg -o sprite.png --width 512   512 pixels wide, height to match
  depixel render sprite.svg -o sprite.pdf --background white

Render an SVG (any SVG, not only depixel's) to PNG or PDF through cairosvg.
"""

INSPECT_DESCRIPTION = """\
examples:
  depixel inspect sprite.png -o stages.png             every stage in one picture
  depixel inspect sprite.png --out-dir stages/ --zoom 16    one PNG per stage
  depixel inspect ghost_x4.jpg -o stages.png           the input beside the 1x art found in it

Draw every stage of the pipeline, like the paper's Figure 3: the input, the similarity
graph (blue: diagonals in flat blocks, red: ambiguous crossings), the graph after the
crossings are resolved (green: kept diagonal, dashed red: removed), the reshaped cells, the
splines with their control points, the optimized splines and the final render. When the
input is prepared first (upscaled, JPEG, --transparent), the input as given comes first and
the 1x image the pipeline converted second.
"""


def add_parser(sub, name: str, help: str) -> None:
    """Define the subcommand ``name`` (render or inspect) with its arguments."""
    {"render": _add_render, "inspect": _add_inspect}[name](sub, help)


def _add_render(sub, help: str) -> None:
    render = sub.add_parser("render", help=help, description=RENDER_DESCRIPTION,
                            formatter_class=argparse.RawDescriptionHelpFormatter)
    render.set_defaults(run=run_render, parser=render)
    render.add_argument("input", metavar="IN.svg", help="SVG file; - reads stdin")
    render.add_argument("-o", "--output", required=True, metavar="OUT", help="PNG or PDF file; - writes to stdout")
    render.add_argument("--format", choices=("png", "pdf"),
                        help="output format (default: from the extension; must agree with a .png/.pdf name)")
    size = render.add_mutually_exclusive_group()
    size.add_argument("--scale", type=positive_float, help="multiple of the SVG's width/height (default 1)")
    size.add_argument("--width", type=positive_int, metavar="W", help="width in pixels, height to match")
    size.add_argument("--height", type=positive_int, metavar="H", help="height in pixels, width to match")
    render.add_argument("--max-output-pixels", type=positive_int, default=DEFAULT_MAX_OUTPUT_PIXELS, metavar="N",
                        help=f"refuse larger PNG renders (default {DEFAULT_MAX_OUTPUT_PIXELS})")
    render.add_argument("--background", type=colour, metavar="COLOR", help="opaque background (default transparent)")
    _debug(render)


def _add_inspect(sub, help: str) -> None:
    inspect = sub.add_parser("inspect", help=help, description=INSPECT_DESCRIPTION,
                             formatter_class=argparse.RawDescriptionHelpFormatter)
    inspect.set_defaults(run=run_inspect, parser=inspect)
    inspect.add_argument("input", metavar="IN", help="pixel-art image")
    inspect.add_argument("-o", "--output", metavar="PNG", help="one PNG with every stage")
    inspect.add_argument("--out-dir", type=Path, metavar="DIR", help="also write each stage as its own PNG")
    inspect.add_argument("--zoom", type=int_range(1, 64), metavar="N",
                         help="magnification (default: panels about 400 pixels wide)")
    inspect.add_argument("--stage", choices=STAGES, default="optimized", help="last stage to run (default optimized)")
    inspect.add_argument("--frame", type=int_range(0), default=0, metavar="N", help="frame of an animated image")
    inspect.add_argument("--background", type=colour, metavar="COLOR", help="flatten the image onto this colour first")
    inspect.add_argument("--max-pixels", type=positive_int, default=DEFAULT_MAX_PIXELS, metavar="N",
                         help=f"refuse larger images (default {DEFAULT_MAX_PIXELS})")
    inspect.add_argument("--max-output-pixels", type=positive_int, default=DEFAULT_MAX_OUTPUT_PIXELS, metavar="N",
                         help=f"refuse figures of more pixels (default {DEFAULT_MAX_OUTPUT_PIXELS})")
    add_input_options(inspect)
    add_tuning(inspect)
    _debug(inspect)


def _debug(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--debug", action="store_true", default=argparse.SUPPRESS,
                        help="show the full traceback on errors")


def _write(target: str, data: bytes, protect: tuple[Path, ...] = ()) -> None:
    """Write to a file atomically, or to stdout for "-" (never binary onto a terminal)."""
    if target != "-":
        write_atomic(target, data, protect=protect)
        return
    if sys.stdout is not None and sys.stdout.isatty() and not data.lstrip().startswith(b"<"):
        raise OutputError("refusing to write binary data to a terminal")
    write_stdout(data)


def run_render(args: argparse.Namespace) -> int:
    from depixel.render.raster import render  # noqa: PLC0415

    try:
        fmt = args.format or "png" if args.output == "-" else files.output_format(args.output, args.format)
    except OutputError:
        fmt = None
    if fmt not in ("png", "pdf"):
        args.parser.error(f"{display_name(args.output)}: render writes PNG or PDF; name OUT .png or .pdf "
                          "(or use --format with a name without those extensions)")
    protect: tuple[Path, ...]
    if args.input == "-" and stdin_closed():
        args.parser.error("- reads the SVG from standard input, which is closed")
    if args.input == "-":
        svg, name, protect = read_source(sys.stdin.buffer), "<stdin>", ()
    else:
        svg, name, protect = files.read_input(args.input), display_name(args.input), (Path(args.input),)
    _not_an_image(svg, name, args.input)
    data = render(svg, str(fmt), scale=args.scale, size=(args.width, args.height), background=args.background,
                  name=name, max_output_pixels=args.max_output_pixels)
    _write(args.output, data, protect)
    return Exit.OK


def _not_an_image(data: bytes, name: str, path: str) -> None:
    """Refuse a raster image given to ``render`` (it draws SVG), saying what to run instead."""
    head = data[:512].lstrip(b"\xef\xbb\xbf \t\r\n")
    if head.startswith((b"<", b"\x1f\x8b")):  # XML, or a compressed SVG
        return
    from PIL import Image, UnidentifiedImageError  # noqa: PLC0415

    try:
        with Image.open(io.BytesIO(data)) as img:
            kind = img.format or "an image"
    except (UnidentifiedImageError, OSError, ValueError, Image.DecompressionBombError):
        return
    stem = Path(path).stem if path != "-" else "sprite"
    raise InputError(f"{name}: is an image ({kind}), not an SVG: render draws SVG files; to turn pixel art "
                     f"into smooth shapes use depixel convert (depixel convert {display_name(path)} -o {stem}.svg, "
                     f"or -o {stem}-smooth.png)")


def run_inspect(args: argparse.Namespace) -> int:
    from depixel.pipeline import depixelize  # noqa: PLC0415
    from depixel.render.figure import check_figure_size, compose, panel_count, stage_panels  # noqa: PLC0415

    if args.output is None and args.out_dir is None:
        args.parser.error("say where to write: -o PNG and/or --out-dir DIR")
    check_input_options(args)
    if args.output not in (None, "-"):
        try:  # PNG bytes in a file named .svg or .pdf help nobody, as convert refuses them
            files.output_format(args.output, "png")
        except OutputError:
            args.parser.error(f"{display_name(args.output)}: inspect writes PNG; name it .png")
    from depixel.prepare.inputs import PrepareOptions, lossy_format  # noqa: PLC0415

    rgba = api.load(args.input, frame=args.frame, background=args.background, max_pixels=args.max_pixels)
    # flattened over the background as loaded: the original panel shows it so
    prepared = api.prepared_input(rgba, from_args(PrepareOptions, args, background=None),
                                  lossy=lossy_format(files.read_input(args.input)))
    check_figure_size(prepared.rgba.shape[:2], args.zoom, panel_count(args.stage) + prepared.changed,
                      args.max_output_pixels)
    result = depixelize(prepared.rgba, params_from_args(args), stage=args.stage)
    panels = stage_panels(result, args.zoom, prepared, rgba, max_output_pixels=args.max_output_pixels)
    protect = (Path(args.input),)
    if args.out_dir is not None:
        try:
            args.out_dir.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise OutputError(f"{args.out_dir}: cannot create folder ({exc.strerror or exc})") from None
        for i, (title, panel) in enumerate(panels, start=1):
            slug = title.replace(" ", "-")
            write_atomic(args.out_dir / f"{i:02d}-{slug}.png", _png(panel), protect=protect)
    if args.output is not None:
        _write(args.output, _png(compose(panels)), protect=protect)
    return Exit.OK


def _png(image) -> bytes:
    """PNG bytes of a PIL image or an ``(H, W, 4) uint8`` array."""
    from PIL import Image  # noqa: PLC0415

    if not hasattr(image, "save"):
        image = Image.fromarray(image, "RGBA")
    buffer = io.BytesIO()
    image.save(buffer, "PNG")
    return buffer.getvalue()
