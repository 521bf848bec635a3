"""``depixel`` command: subcommands, exit codes and one-line error messages.

Every command builds its options, calls the library and maps a library error
(:class:`depixel.DepixelError`) to a one-line message and an exit code (:class:`Exit`);
``--debug`` shows the traceback instead.
"""
from __future__ import annotations

import argparse
import importlib
import os
import re
import sys
import warnings
from typing import NoReturn, cast

import depixel
from depixel.errors import DepixelError, ParameterError

from .options import Exit, error_exit, error_message, say
from .pool import Interrupted, Signals
from .streams import closed_pipe, flush_stdout, print_stdout, reserve_closed_descriptors


def _help_width() -> int:
    """The width argparse gives help text, as ``shutil.get_terminal_size`` finds it (the
    ``COLUMNS`` variable, else the terminal of stdout, else 80) minus 2: argparse imports
    ``shutil`` for it, with the compression modules shutil loads (~4 ms of every start)."""
    try:
        columns = int(os.environ["COLUMNS"])
    except (KeyError, ValueError):
        columns = 0
    if columns <= 0:
        try:
            columns = os.get_terminal_size(sys.__stdout__.fileno()).columns  # type: ignore[union-attr]
        except (AttributeError, ValueError, OSError):
            columns = 0
    return (columns or 80) - 2


class _Parser(argparse.ArgumentParser):
    def _get_formatter(self) -> argparse.HelpFormatter:
        return self.formatter_class(prog=self.prog, width=_help_width())  # type: ignore[call-arg]

    def error(self, message: str) -> NoReturn:  # one line naming the (sub)command, exit code 2
        choice = re.search(r"invalid choice: '([^']*)' \(choose from (.*)\)", message)
        if choice:
            import difflib  # noqa: PLC0415 (only a mistyped command needs it: ~5 ms of every start)

            close = difflib.get_close_matches(choice.group(1), re.findall(r"'([^']*)'", choice.group(2)), n=1)
            if close:
                message += f"; did you mean {close[0]}?"
        self.exit(Exit.USAGE, f"{self.prog}: error: {message}\n")

    def unrecognized(self, extras: list[str]) -> None:
        """Unknown arguments, with the closest option of this (sub)command for each flag."""
        options = [o for action in self._actions for o in action.option_strings if o.startswith("--")]
        import difflib  # noqa: PLC0415 (as in error)

        hints = []
        for arg in extras:
            if arg.startswith("-"):
                close = difflib.get_close_matches(arg.split("=")[0], options, n=1, cutoff=0.6)
                if close:
                    hints.append(f"{arg.split('=')[0]}: did you mean {close[0]}?")
        self.error(f"unrecognized arguments: {' '.join(extras)}" + (f" ({'; '.join(hints)})" if hints else ""))


class _Version(argparse.Action):
    """``--version``: depixel's version and its key dependencies' (cairo is not loaded)."""

    def __init__(self, option_strings, dest=argparse.SUPPRESS, default=argparse.SUPPRESS, help=None):
        super().__init__(option_strings, dest=dest, default=default, nargs=0, help=help)

    def __call__(self, parser, namespace, values, option_string=None):
        from importlib import metadata  # noqa: PLC0415 (~40 ms of email parsing: only for --version)

        lines = [f"depixel {depixel.__version__}"]
        for name in ("numpy", "pillow", "cairosvg", "tqdm"):
            try:
                lines.append(f"  {name} {metadata.version(name)}")
            except metadata.PackageNotFoundError:
                lines.append(f"  {name} not installed")
        lines.append(f"  python {sys.version.split()[0]}")
        print_stdout("\n".join(lines))
        parser.exit(Exit.OK)


#: The subcommands in ``--help`` order: name, help line, and the module of this package
#: whose ``add_parser(sub, name, help)`` defines the command's arguments.
COMMANDS = (
    ("convert", "convert pixel art to SVG, PNG, PDF or EPS", "convert.command"),
    ("render", "render an SVG to PNG, PDF or EPS", "tools"),
    ("diff", "compare two images, or two folders of renders (for CI)", "diff.command"),
    ("inspect", "draw every pipeline stage (like the paper's Figure 3)", "tools"),
    ("inkscape", "install or remove the Inkscape extension", "inkscape.command"),
)


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The ``depixel`` parser. With ``command``, only that subcommand's arguments are
    defined (and only its module imported): the others are listed with their help line
    alone, which is all ``depixel --help`` and a mistyped command show. Defining every
    command and importing their modules cost ~3 ms of parsers and ~5 ms of imports
    (``shutil`` for Inkscape's) in every start."""
    parser = _Parser(prog="depixel", description="Turn pixel art into smooth, resolution-independent SVG "
                     "(Kopf & Lischinski, Depixelizing Pixel Art, 2011).",
                     epilog="exit codes: 0 success, 1 a file failed (diff: images differ), 2 usage error "
                     "(diff: could not compare). 'depixel COMMAND --help' shows examples.")
    parser.add_argument("--version", action=_Version, help="show the versions of depixel and its dependencies")
    parser.add_argument("--debug", action="store_true", help="show the full traceback on errors")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    for name, help_line, module in COMMANDS:
        if command is None or name == command:
            importlib.import_module(f".{module}", __package__).add_parser(sub, name, help_line)
        else:
            sub.add_parser(name, help=help_line)
    return parser


def command_of(argv: list[str]) -> str:
    """The subcommand ``argv`` asks for: its first argument that is not an option (the
    top-level options take no value), or "" when there is none."""
    return next((arg for arg in argv if not arg.startswith("-")), "")


def main(argv: list[str] | None = None) -> int:
    """Run the command of ``argv`` (default: the command line) and return its exit code. A
    closed standard output ends it quietly with 141 (depixel_cli/streams.py); warnings of
    the libraries (numpy's overflow notices, Pillow's) never reach the terminal."""
    reserve_closed_descriptors()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                return _main(argv)
            finally:  # --help and --version exit through SystemExit: theirs too
                flush_stdout()
    except BrokenPipeError:
        return closed_pipe()


def _main(argv: list[str] | None) -> int:
    with Signals() as signals:  # Ctrl-C and SIGTERM, from here to the end: see depixel_cli/pool.py
        try:
            parser = build_parser(command_of(sys.argv[1:] if argv is None else argv))
            args, extras = parser.parse_known_args(argv)
            if extras:
                cast(_Parser, getattr(args, "parser", parser)).unrecognized(extras)
            if args.command is None:
                parser.print_help(sys.stderr)
                return Exit.USAGE
            args.signals = signals
            return _run(args)
        except Interrupted as exc:  # at any moment, even while an error is being reported
            say("interrupted")
            return exc.exit_code


def _run(args: argparse.Namespace) -> int:
    """Run the command; every library error becomes one line and an exit code."""
    try:
        return int(args.run(args))
    except BrokenPipeError:  # e.g. `depixel convert - -o - | head`: main ends quietly
        raise
    except Exception as exc:
        if args.signals.signum is not None:  # a failure the stop request caused (a render cut short)
            raise Interrupted(args.signals.signum) from None
        if args.debug:
            raise
        if isinstance(exc, ParameterError):  # a value the library refuses is a usage error
            say(f"error: {error_message(exc)}")
            return Exit.USAGE
        if isinstance(exc, DepixelError):
            say(f"error: {error_message(exc)}")
            return error_exit(args.command)
        first = str(exc).splitlines()[0] if str(exc) else ""  # a bug: one line unless --debug
        say(f"internal error: {type(exc).__name__}: {first} (--debug shows the traceback)")
        return error_exit(args.command)
    except KeyboardInterrupt:
        say("interrupted")
        return Exit.INTERRUPTED


if __name__ == "__main__":
    sys.exit(main())
