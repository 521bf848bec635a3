"""``depixel inkscape check``: can the Python that Inkscape runs extensions with run ours?

Inkscape 1.x runs a Python extension with the interpreter its preferences name
(``python-interpreter`` in the group ``extensions`` of ``preferences.xml``, in its profile
folder, the parent of the user extensions folder), else the first ``python3`` (then
``python``) on PATH, with its own extension folders first on PYTHONPATH. That Python needs
lxml, cssselect and numpy for inkex, which Debian and Ubuntu only recommend. This module
finds the interpreter as Inkscape does and runs the extension's own check under it
(``extension/depixel_inkscape_check.py``, which also gives the exact fix).

Inkscape for Windows and macOS (and the Flatpak and AppImage builds) bundle their own Python
with these modules; there the check cannot see that Python, and says so.
"""
from __future__ import annotations

import json
import os
import shutil
import sys
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

from depixel.errors import display_name

#: the interpreter Inkscape 1.x looks for when its preferences name none (Linux; Windows: pythonw)
DEFAULT_INTERPRETERS = ("python3", "python")
CHECK_SCRIPT = "depixel_inkscape_check.py"


@dataclass(frozen=True)
class Interpreter:
    """The Python Inkscape would run the extension with, and how it was found."""

    path: str | None  # None: not found
    how: str  # "the python-interpreter preference", "the first python3 on PATH", ...


@dataclass(frozen=True)
class Finding:
    """What the check found: ``ok``, or a one-line ``problem`` with the ``fix`` when known."""

    interpreter: Interpreter
    report: dict | None  # what the check script printed, when it ran
    problem: str | None
    fix: str | None = None

    @property
    def ok(self) -> bool:
        return self.problem is None


def preferred_interpreter(profile: Path) -> str | None:
    """The ``python-interpreter`` of Inkscape's preferences in ``profile``, if set."""
    try:
        root = ET.parse(profile / "preferences.xml").getroot()
    except (OSError, ET.ParseError):
        return None
    for group in root.findall("group"):
        if group.get("id") == "extensions" and group.get("python-interpreter"):
            return group.get("python-interpreter")
    return None


def find_interpreter(profile: Path | None) -> Interpreter:
    """The interpreter as Inkscape finds it: the preference (a bare name looked up on PATH),
    else python3, else python on PATH."""
    preferred = preferred_interpreter(profile) if profile is not None else None
    if preferred:
        how = f"python-interpreter in {display_name(profile / 'preferences.xml')}"  # type: ignore[operator]
        path = preferred if os.path.isabs(preferred) else shutil.which(preferred)
        return Interpreter(path if path and os.path.isfile(path) else None, how)
    for name in DEFAULT_INTERPRETERS:
        path = shutil.which(name)
        if path:
            return Interpreter(path, f"the first {name} on PATH")
    return Interpreter(None, f"{' or '.join(DEFAULT_INTERPRETERS)} on PATH")


def check(extensions: Path, system_extensions: Path | None, source: Path) -> Finding:
    """Run the extension's check under Inkscape's Python, with Inkscape's PYTHONPATH (the user
    extensions folder, then the system one holding inkex)."""
    interpreter = find_interpreter(extensions.parent)
    if sys.platform in ("win32", "darwin"):
        return Finding(interpreter, None, None)  # a bundled Python: nothing here to look at
    if interpreter.path is None:
        return Finding(interpreter, None, f"Inkscape finds no Python to run extensions with ({interpreter.how})",
                       "install Python 3 with lxml, cssselect and numpy")
    import subprocess  # noqa: PLC0415 (~10 ms at startup: only `inkscape` runs programs)

    folders = [str(extensions)] + ([str(system_extensions)] if system_extensions else [])
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(folders + [os.environ.get("PYTHONPATH", "")]).rstrip(os.pathsep)}
    try:
        done = subprocess.run([interpreter.path, str(source / CHECK_SCRIPT)], capture_output=True, text=True,
                              env=env, timeout=120, stdin=subprocess.DEVNULL)
        report = json.loads(done.stdout.strip().splitlines()[-1])
    except (OSError, subprocess.TimeoutExpired, ValueError, IndexError):
        return Finding(interpreter, None, f"{display_name(interpreter.path)} ({interpreter.how}) does not run "
                                          "the extension's check: is it Python 3?")
    if report["too_old"]:
        return Finding(interpreter, report, f"{display_name(interpreter.path)} is Python {report['version']}: the "
                                            "extension needs 3.7 or later")
    if report["missing"]:
        them = "it" if len(report["missing"]) == 1 else "them"
        return Finding(interpreter, report, f"{display_name(interpreter.path)} ({interpreter.how}) lacks "
                                            f"{', '.join(report['missing'])}, which inkex needs; install {them}",
                       report["fix"])
    return Finding(interpreter, report, None)


def describe(finding: Finding) -> list[str]:
    """The lines ``depixel inkscape check`` prints on stdout."""
    interpreter, report = finding.interpreter, finding.report
    if report is None and finding.ok:
        return ["Inkscape for Windows and macOS runs extensions with its own Python, which has what inkex "
                "needs: nothing to check"]
    if report is None:
        return [f"Inkscape runs extensions with: {interpreter.how} (none found)"]
    lines = [f"Inkscape runs extensions with {display_name(interpreter.path or '')} ({interpreter.how}; "
             f"Python {report['version']})"]
    for module in [*report["required"], *(m for m in report["missing"] if m not in report["required"])]:
        lines.append(f"  {module:<10} {'missing' if module in report['missing'] else 'ok'}")
    if report["inkex_found"]:
        lines.append(f"  {'inkex':<10} {report['inkex'] or 'not importable without the modules above'}")
    if interpreter.how.startswith("the first"):
        lines += DESKTOP_NOTE
    return lines


#: Said when the interpreter was found on this shell's PATH: Inkscape started from the
#: desktop gets the session's PATH, not the shell's (a pyenv or conda python3 first on the
#: shell's PATH is usually not on the desktop's), and a Flatpak or Snap Inkscape its own.
DESKTOP_NOTE = [
    "note: this is the python3 on this shell's PATH; Inkscape started from the desktop menu may find "
    "another one (the desktop session's PATH), and a Flatpak, Snap or AppImage Inkscape uses its own.",
    "  to be sure, name it in Inkscape's preferences.xml (python-interpreter in the group extensions), or run "
    "Extensions > Raster > Depixelize once: a missing module is reported there in one line",
]
