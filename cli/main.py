"""``depixel`` command: argument parsing, exit codes and one-line error messages."""
from __future__ import annotations

import argparse
import enum
import sys
from pathlib import Path

import depixel
from depixel.errors import DepixelError
from depixel.params import Params


class Exit(enum.IntEnum):
    OK = 0
    FAILED = 1  # a file could not be converted (or, for diff, the images differ)
    USAGE = 2  # bad command line


CONVERT_EXAMPLES = """examples:
  depixel convert sprite.png -o sprite.svg            smooth vector art (the paper's result)
  depixel convert sprite.png -o big.svg --scale 8     width/height 8x the pixel size
  depixel convert sprite.png -o cells.svg --stage cells   the reshaped pixel cells only
"""


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> None:  # one line, exit code 2
        self.exit(Exit.USAGE, f"depixel: error: {message}\n")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="depixel", description="Turn pixel art into smooth, resolution-independent SVG "
                     "(Kopf & Lischinski, Depixelizing Pixel Art, 2011).")
    parser.add_argument("--version", action="version", version=f"depixel {depixel.__version__}")
    parser.add_argument("--debug", action="store_true", help="show the full traceback on errors")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    convert = sub.add_parser("convert", help="convert an image to SVG", epilog=CONVERT_EXAMPLES,
                             formatter_class=argparse.RawDescriptionHelpFormatter,
                             description="Convert a pixel-art image to SVG.")
    convert.add_argument("input", help="input image (PNG, GIF, BMP, ...)")
    convert.add_argument("-o", "--output", required=True, help="output SVG file")
    convert.add_argument("--scale", type=_positive_float, default=1.0,
                         help="SVG width/height as a multiple of the pixel size (default 1)")
    convert.add_argument("--stage", choices=depixel.STAGES, default="optimized",
                         help="stop at this pipeline stage (default: optimized, the final result)")
    convert.add_argument("--max-pixels", type=int, default=1_048_576,
                         help="refuse larger images (default 1048576; pixel art is small)")
    convert.add_argument("--debug", action="store_true", default=argparse.SUPPRESS, help=argparse.SUPPRESS)
    return parser


def _positive_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not value > 0 or value == float("inf"):
        raise argparse.ArgumentTypeError(f"must be a positive number: {text!r}")
    return value


def run_convert(args: argparse.Namespace) -> int:
    from depixel.output import write_atomic

    rgba = depixel.load_image(args.input, max_pixels=args.max_pixels)
    result = depixel.depixelize(rgba, Params(), stage=args.stage)
    svg = depixel.to_svg(result.vector, scale=args.scale, title=Path(args.input).name)
    write_atomic(args.output, svg, protect=(Path(args.input),))
    return Exit.OK


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help(sys.stderr)
        return Exit.USAGE
    try:
        return int(run_convert(args))
    except DepixelError as exc:
        if args.debug:
            raise
        print(f"depixel: error: {exc}", file=sys.stderr)
        return Exit.FAILED
    except KeyboardInterrupt:
        print("depixel: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
