"""``depixel inkscape install|uninstall``: put the Inkscape extension where Inkscape finds it.

The extension (``inkscape_extension/``, shipped as package data) is an ``.inx`` description
and a script; Inkscape runs the script with its own Python, so install also records the
command that runs this depixel (``RECORDED_COMMAND``) for the script to find it.
"""
from __future__ import annotations

import argparse
import json
import shutil
import sys
from pathlib import Path

from depixel.errors import OutputError, display_name
from depixel.files.output import write_atomic

from .options import Exit

#: The extension's own files, shipped in the package.
SOURCE = Path(__file__).resolve().parent / "inkscape_extension"
SHIPPED = ("depixel_inkscape.inx", "depixel_inkscape.py", "depixel_inkscape_place.py")
#: Written at install: {"command": [...]} runs the depixel that installed the extension (the
#: script reads it under the same name, depixel_inkscape.py: RECORDED_COMMAND).
RECORDED_COMMAND = "depixel_inkscape.json"
INSTALLED = (*SHIPPED, RECORDED_COMMAND)
MENU = "Extensions > Raster > Depixelize (depixel)"

DESCRIPTION = f"""\
examples:
  depixel inkscape install                 into Inkscape's user extensions folder
  depixel inkscape install --dir DIR       into DIR (e.g. a portable Inkscape's)
  depixel inkscape uninstall               remove exactly the files install wrote

Install the Inkscape 1.x extension that replaces the selected bitmaps of a drawing
by depixel's shapes: {MENU}. The folder is the one
'inkscape --user-data-directory' prints, plus extensions/ (Inkscape shows it in
Edit > Preferences > System > User extensions). The extension runs this depixel;
restart Inkscape after installing.
"""


def add_parser(sub, name: str, help: str) -> None:
    """Define the subcommand ``name`` (inkscape) with its actions and arguments."""
    p = sub.add_parser(name, help=help, description=DESCRIPTION,
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    actions = p.add_subparsers(dest="action", metavar="ACTION", parser_class=type(p), required=True)
    for name, run, text in (("install", run_install, "copy the extension into Inkscape's extensions folder"),
                            ("uninstall", run_uninstall, "remove the files install wrote")):
        action = actions.add_parser(name, help=text, description=f"{text[0].upper()}{text[1:]}.")
        action.set_defaults(run=run, parser=action)
        action.add_argument("--dir", type=Path, metavar="DIR",
                            help="extensions folder (default: Inkscape's user extensions folder)")
        action.add_argument("--debug", action="store_true", default=argparse.SUPPRESS, help=argparse.SUPPRESS)


def extensions_folder(given: Path | None) -> Path:
    """``--dir``, else ``inkscape --user-data-directory``/extensions."""
    if given is not None:
        return given
    inkscape = shutil.which("inkscape")
    hint = "give the folder with --dir (Inkscape: Edit > Preferences > System > User extensions shows it)"
    if inkscape is None:
        raise OutputError(f"inkscape is not on PATH; {hint}")
    import subprocess  # noqa: PLC0415 (~10 ms at startup, and only `inkscape install` runs a program)

    try:
        done = subprocess.run([inkscape, "--user-data-directory"], capture_output=True, text=True, timeout=120,
                              stdin=subprocess.DEVNULL)
    except (OSError, subprocess.TimeoutExpired) as exc:
        raise OutputError(f"could not run inkscape --user-data-directory ({exc}); {hint}") from None
    lines = [line.strip() for line in done.stdout.splitlines() if line.strip()]
    if done.returncode != 0 or not lines:
        raise OutputError(f"inkscape --user-data-directory did not print a folder (Inkscape 1.0 or later "
                          f"is needed); {hint}")
    return Path(lines[-1]) / "extensions"


def recorded_command() -> list[str]:
    """The command that runs this depixel, whatever Python Inkscape uses."""
    return [sys.executable, "-m", "depixel"]


def run_install(args: argparse.Namespace) -> int:
    folder = extensions_folder(args.dir)
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
