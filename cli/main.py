"""``depixel`` command: subcommands, exit codes and one-line error messages.

Every command builds its options, calls the library and maps a library error
(:class:`depixel.DepixelError`) to a one-line message and an exit code (:class:`Exit`);
``--debug`` shows the traceback instead.
"""
from __future__ import annotations

import argparse
import sys
from importlib import metadata
from typing import NoReturn

import depixel
from depixel.errors import DepixelError

from . import convert, inkscape, tools
from .options import Exit, error_exit, error_message, say


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> NoReturn:  # one line, exit code 2
        self.exit(Exit.USAGE, f"{self.prog}: error: {message}\n")


class _Version(argparse.Action):
    """``--version``: depixel's version and its key dependencies' (cairo is not loaded)."""

    def __init__(self, option_strings, dest=argparse.SUPPRESS, default=argparse.SUPPRESS, help=None):
        super().__init__(option_strings, dest=dest, default=default, nargs=0, help=help)

    def __call__(self, parser, namespace, values, option_string=None):
        lines = [f"depixel {depixel.__version__}"]
        for name in ("numpy", "pillow", "cairosvg", "tqdm"):
            try:
                lines.append(f"  {name} {metadata.version(name)}")
            except metadata.PackageNotFoundError:
                lines.append(f"  {name} not installed")
        lines.append(f"  python {sys.version.split()[0]}")
        print("\n".join(lines))
        parser.exit(Exit.OK)


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="depixel", description="Turn pixel art into smooth, resolution-independent SVG "
                     "(Kopf & Lischinski, Depixelizing Pixel Art, 2011).",
                     epilog="exit codes: 0 success, 1 a file failed (diff: images differ), 2 usage error "
                     "(diff: could not compare). 'depixel COMMAND --help' shows examples.")
    parser.add_argument("--version", action=_Version, help="show the versions of depixel and its dependencies")
    parser.add_argument("--debug", action="store_true", help="show the full traceback on errors")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    convert.add_parser(sub)
    tools.add_parsers(sub)
    inkscape.add_parser(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help(sys.stderr)
        return Exit.USAGE
    try:
        return int(args.run(args))
    except DepixelError as exc:
        if args.debug:
            raise
        say(f"error: {error_message(exc)}")
        return error_exit(args.command)
    except KeyboardInterrupt:
        say("interrupted")
        return Exit.INTERRUPTED
    except BrokenPipeError:  # e.g. `depixel convert - -o - | head`
        return Exit.FAILED
    except Exception as exc:  # a bug: one line unless --debug
        if args.debug:
            raise
        say(f"internal error: {type(exc).__name__}: {exc} (--debug shows the traceback)")
        return error_exit(args.command)


if __name__ == "__main__":
    sys.exit(main())
