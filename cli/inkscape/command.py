"""``depixel inkscape install|uninstall|check``: put the Inkscape extension where Inkscape finds it.

The extension (``extension/``, shipped as package data) is an ``.inx`` description
and a script; Inkscape runs the script with its own Python, so install also records the
command that runs this depixel (``RECORDED_COMMAND``) for the script to find it, and first
checks that this Python has what inkex needs (:mod:`depixel_cli.inkscape.python`).
"""
from __future__ import annotations

import argparse
import json
import shutil
import sys
from pathlib import Path

from depixel.errors import DepixelError, OutputError, display_name
from depixel.files.output import write_atomic

from ..options import Exit
from .python import CHECK_SCRIPT, Finding, check, describe

#: The extension's own files, shipped in the package.
SOURCE = Path(__file__).resolve().parent / "extension"
SHIPPED = ("depixel_inkscape.inx", "depixel_inkscape.py", "depixel_inkscape_place.py", CHECK_SCRIPT)
#: Written at install: {"command": [...]} runs the depixel that installed the extension (the
#: script reads it under the same name, depixel_inkscape.py: RECORDED_COMMAND).
RECORDED_COMMAND = "depixel_inkscape.json"
INSTALLED = (*SHIPPED, RECORDED_COMMAND)
MENU = "Extensions > Raster > Depixelize (depixel)"

DESCRIPTION = f"""\
examples:
  depixel inkscape install                 into Inkscape's user extensions folder
  depixel inkscape install --dir DIR       into DIR (e.g. a portable Inkscape's)
  depixel inkscape check                   can Inkscape's Python run the extension?
  depixel inkscape uninstall               remove exactly the files install wrote

Install the Inkscape 1.x extension that replaces the selected bitmaps of a drawing
by depixel's shapes: {MENU}. The folder is the one
'inkscape --user-data-directory' prints, plus extensions/ (Inkscape shows it in
Edit > Preferences > System > User extensions). The extension runs this depixel;
restart Inkscape after installing. Inkscape runs extensions with its own Python (its
preferences' python-interpreter, else python3 on PATH), which needs lxml, cssselect and
numpy for inkex: install checks that first and prints the command that installs what
is missing (--force installs the extension anyway).
"""


def add_parser(sub, name: str, help: str) -> None:
    """Define the subcommand ``name`` (inkscape) with its actions and arguments."""
    p = sub.add_parser(name, help=help, description=DESCRIPTION,
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    actions = p.add_subparsers(dest="action", metavar="ACTION", parser_class=type(p), required=True)
    for name, run, text in (("install", run_install, "check Inkscape's Python, then copy the extension into "
                                                     "Inkscape's extensions folder"),
                            ("uninstall", run_uninstall, "remove the files install wrote"),
                            ("check", run_check, "check that the Python Inkscape runs extensions with has "
                                                 "what the extension needs")):
        action = actions.add_parser(name, help=text, description=f"{text[0].upper()}{text[1:]}.")
        action.set_defaults(run=run, parser=action)
        action.add_argument("--dir", type=Path, metavar="DIR",
                            help="extensions folder (default: Inkscape's user extensions folder); Inkscape's "
                                 "preferences are looked for in its parent")
        if name == "install":
            action.add_argument("--force", action="store_true",
                                help="install even when Inkscape's Python lacks a module the extension needs")
        action.add_argument("--debug", action="store_true", default=argparse.SUPPRESS, help=argparse.SUPPRESS)


class InkscapePythonError(DepixelError):
    """The Python Inkscape runs extensions with cannot run the extension."""


def extensions_folder(given: Path | None) -> Path:
    """``--dir``, else ``inkscape --user-data-directory``/extensions."""
    if given is not None:
        return given
    hint = "give the folder with --dir (Inkscape: Edit > Preferences > System > User extensions shows it)"
    if shutil.which("inkscape") is None:
        raise OutputError(f"inkscape is not on PATH; {hint}")
    try:
        folder = inkscape_folder("--user-data-directory")
    except OSError as exc:
        raise OutputError(f"could not run inkscape --user-data-directory ({exc}); {hint}") from None
    if folder is None:
        raise OutputError(f"inkscape --user-data-directory did not print a folder (Inkscape 1.0 or later "
                          f"is needed); {hint}")
    return folder / "extensions"


def inkscape_folder(option: str) -> Path | None:
    """The folder ``inkscape OPTION`` prints (``--user-data-directory``, ``--system-data-directory``),
    None when it prints none; OSError when it cannot be run."""
    import subprocess  # noqa: PLC0415 (~10 ms at startup, and only `inkscape` runs a program)

    inkscape = shutil.which("inkscape")
    if inkscape is None:
        return None
    try:
        done = subprocess.run([inkscape, option], capture_output=True, text=True, timeout=120,
                              stdin=subprocess.DEVNULL)
    except subprocess.TimeoutExpired as exc:
        raise OSError(str(exc)) from None
    lines = [line.strip() for line in done.stdout.splitlines() if line.strip()]
    return Path(lines[-1]) if done.returncode == 0 and lines else None


def check_python(folder: Path) -> Finding:
    """Run the check for the extensions folder ``folder``, with Inkscape's inkex when found."""
    try:
        system = inkscape_folder("--system-data-directory")
    except OSError:
        system = None
    return check(folder, system / "extensions" if system is not None else None, SOURCE)


def run_check(args: argparse.Namespace) -> int:
    finding = check_python(extensions_folder(args.dir))
    print("\n".join(describe(finding)))
    if not finding.ok:
        raise InkscapePythonError(f"{finding.problem}: {finding.fix}" if finding.fix else str(finding.problem))
    print("the extension can run")
    return Exit.OK


def recorded_command() -> list[str]:
    """The command that runs this depixel, whatever Python Inkscape uses."""
    return [sys.executable, "-m", "depixel"]


def run_install(args: argparse.Namespace) -> int:
    folder = extensions_folder(args.dir)
    finding = check_python(folder)
    if not finding.ok:
        print("\n".join(describe(finding)))
        problem = f"{finding.problem}: {finding.fix}" if finding.fix else str(finding.problem)
        if not args.force:
            raise InkscapePythonError(f"{problem}; the extension was not installed (--force installs it anyway)")
        print(f"depixel: warning: {problem}; installing anyway (--force)", file=sys.stderr)
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputError(f"{display_name(folder)}: cannot create folder ({exc.strerror or exc})") from None
    for name in SHIPPED:
        write_atomic(folder / name, (SOURCE / name).read_bytes())
    record = {"command": recorded_command(), "note": "written by 'depixel inkscape install': the command "
              "the extension runs unless its dialog or $DEPIXEL names another depixel"}
    write_atomic(folder / RECORDED_COMMAND, json.dumps(record, indent=2) + "\n")
    print(f"installed the Inkscape extension in {display_name(folder)}: {', '.join(INSTALLED)}")
    print(f"restart Inkscape, select a bitmap and use {MENU}")
    return Exit.OK


def run_uninstall(args: argparse.Namespace) -> int:
    folder = extensions_folder(args.dir)
    removed = []
    for name in INSTALLED:
        path = folder / name
        try:
            path.unlink()
        except FileNotFoundError:
            continue
        except OSError as exc:
            raise OutputError(f"{display_name(path)}: cannot remove ({exc.strerror or exc})") from None
        removed.append(name)
    if removed:
        print(f"removed from {display_name(folder)}: {', '.join(removed)}")
    else:
        print(f"the extension is not installed in {display_name(folder)}: nothing removed")
    return Exit.OK
