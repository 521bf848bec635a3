"""``depixel inkscape install|uninstall|check``: put the Inkscape extension where Inkscape finds it.

The extension (``extension/``, shipped as package data) is an ``.inx`` description
and a script; Inkscape runs the script with its own Python, so install also records the
command that runs this depixel (``RECORDED_COMMAND``) for the script to find it, and first
checks that this Python has what inkex needs (:mod:`depixel_cli.inkscape.python`).
"""
from __future__ import annotations

import argparse
import hashlib
import json
import shutil
import sys
from pathlib import Path

from depixel.errors import DepixelError, OutputError, display_name
from depixel.files.output import make_folders, remove_file, write_atomic

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
  depixel inkscape uninstall               remove the files install wrote (unless edited since)

Install the Inkscape 1.x extension that replaces the selected bitmaps of a drawing
by depixel's shapes: {MENU}. The folder is the one
'inkscape --user-data-directory' prints, plus extensions/ (Inkscape shows it in
Edit > Preferences > System > User extensions). The extension runs this depixel;
restart Inkscape after installing. Inkscape runs extensions with its own Python (its
preferences' python-interpreter, else python3 on PATH), which needs lxml, cssselect and
numpy for inkex: install checks that first and prints the command that installs what
is missing (--force installs the extension anyway). Install writes only files it wrote
before (a record beside them keeps their digests) and never through a symbolic link;
uninstall removes only those, unchanged: --force replaces or removes any file of their
names.
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
                                help="install even when Inkscape's Python lacks a module the extension needs, "
                                     "or over files of the same names that install did not write (or that "
                                     "were edited since)")
        if name == "uninstall":
            action.add_argument("--force", action="store_true",
                                help="remove the extension's files even when install did not write them or "
                                     "they were edited since")
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
    files = {name: (SOURCE / name).read_bytes() for name in SHIPPED}
    if not args.force:
        check_ours(folder, files)
    make_folders(folder)
    for name, data in files.items():  # a link in their place is replaced, never written through
        write_atomic(folder / name, data, replace_link=True)
    record = {"command": recorded_command(), "note": "written by 'depixel inkscape install': the command "
              "the extension runs unless its dialog or $DEPIXEL names another depixel; 'files' lists what "
              "install wrote, which uninstall removes (unless edited since)",
              "files": {name: _digest(data) for name, data in files.items()}}
    write_atomic(folder / RECORDED_COMMAND, json.dumps(record, indent=2) + "\n", replace_link=True)
    print(f"installed the Inkscape extension in {display_name(folder)}: {', '.join(INSTALLED)}")
    print(f"restart Inkscape, select a bitmap and use {MENU}")
    return Exit.OK


def _digest(data: bytes) -> str:
    return "sha256:" + hashlib.sha256(data).hexdigest()


def installed_files(folder: Path) -> dict[str, str] | None:
    """{name: digest} of the files the last install in ``folder`` wrote, from its record;
    None when there is no record of an install there (or the file of that name is not one).
    A record of an install before digests were kept lists the files it would have written."""
    path = folder / RECORDED_COMMAND
    try:
        if path.is_symlink():
            return None
        record = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    if not isinstance(record, dict) or not isinstance(record.get("command"), list):
        return None
    files = record.get("files")
    if not isinstance(files, dict):  # an older install's record: its files are the shipped ones
        return {name: _digest((SOURCE / name).read_bytes()) for name in SHIPPED}
    return {str(name): str(digest) for name, digest in files.items() if name in SHIPPED}


def _ours(path: Path, digest: str | None, shipped: bytes) -> bool:
    """Whether ``path`` may be replaced or removed: a file (not a link) that install wrote
    and that is unchanged since, or that holds exactly what install writes."""
    if path.is_symlink() or not path.is_file():
        return False
    data = path.read_bytes()
    return _digest(data) == digest or data == shipped


def check_ours(folder: Path, files: dict[str, bytes]) -> None:
    """Refuse (one line) to install over a file that install did not write: one edited since,
    another program's of that name, or a symbolic link (it would be written through)."""
    known = installed_files(folder) or {}
    record = folder / RECORDED_COMMAND
    if (record.is_symlink() or record.exists()) and installed_files(folder) is None:
        raise OutputError(f"{display_name(record)}: exists and is not the record of 'depixel inkscape install'; "
                          "refusing to replace it (--force does)")
    for name, data in files.items():
        path = folder / name
        if (path.is_symlink() or path.exists()) and not _ours(path, known.get(name), data):
            what = "is a symbolic link" if path.is_symlink() else \
                "was edited since install wrote it" if name in known else "was not written by install"
            raise OutputError(f"{display_name(path)}: {what}; refusing to replace it, nothing was installed "
                              "(--force replaces it)")


def run_uninstall(args: argparse.Namespace) -> int:
    folder = extensions_folder(args.dir)
    known = installed_files(folder)
    if known is None:
        present = [name for name in SHIPPED if (folder / name).is_symlink() or (folder / name).exists()]
        if not args.force or not present:
            hint = f" ({', '.join(present)} there: --force removes them)" if present else ""
            print(f"no record of 'depixel inkscape install' in {display_name(folder)}: nothing removed{hint}")
            return Exit.OK
        known = {}
    removed, kept = [], []
    for name in SHIPPED:
        path = folder / name
        if not (path.is_symlink() or path.exists()):
            continue
        if args.force or _ours(path, known.get(name), (SOURCE / name).read_bytes()):
            remove_file(path)
            removed.append(name)
        else:
            kept.append(name)
    if not kept and installed_files(folder) is not None:
        remove_file(folder / RECORDED_COMMAND)
        removed.append(RECORDED_COMMAND)
    if removed:
        print(f"removed from {display_name(folder)}: {', '.join(removed)}")
    if kept:
        print(f"kept in {display_name(folder)}: {', '.join(kept)} (changed since install wrote them, or not "
              "written by it: --force removes them)")
    if not removed and not kept:
        print(f"the extension is not installed in {display_name(folder)}: nothing removed")
    return Exit.OK
