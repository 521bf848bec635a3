"""What the Python that Inkscape runs extensions with lacks, and the command that installs it.

Inkscape runs the extension with its own Python (its preferences' ``python-interpreter``,
else ``python3`` on PATH), and inkex, Inkscape's extension library, imports lxml, cssselect
and numpy, which a Linux distribution only recommends with Inkscape. This module is
standard library only, so it runs where inkex cannot be imported:

- ``depixel_inkscape.py`` imports it first: when a module is missing, the extension shows
  one plain line with the fix (:func:`exit_missing`) instead of a traceback; and under
  ``inkscape --batch-process`` its messages go to Inkscape's own stderr
  (:func:`messages_to_inkscape`), where nobody has to close a dialog;
- ``depixel inkscape check`` and ``install`` run it as a program under that Python
  (``python3 depixel_inkscape_check.py``), which prints what it found as JSON.

It runs on Python 3.6+ (to say that a Python is too old, rather than fail to parse).
"""
import json
import os
import sys

#: (module, Debian/Ubuntu package, pip package) of what inkex imports: lxml (every 1.x),
#: numpy (since 1.1, inkex.bezier), cssselect (since 1.2, inkex.css)
REQUIRED = (("lxml", "python3-lxml", "lxml"), ("cssselect", "python3-cssselect", "cssselect"),
            ("numpy", "python3-numpy", "numpy"))
#: the extension's own syntax needs Python 3.7
MIN_PYTHON = (3, 7)


def missing_modules(inkex_error=None):
    """The modules this Python cannot import that the extension needs: those of REQUIRED,
    then whatever else importing inkex failed on (``inkex_error``, a ModuleNotFoundError)."""
    missing = []
    for module, _, _ in REQUIRED:
        try:
            __import__(module)
        except ImportError:
            missing.append(module)
    name = getattr(inkex_error, "name", None)
    if name and name.split(".")[0] not in missing:
        missing.append(name.split(".")[0])
    return missing


def install_command(missing, os_release="/etc/os-release"):
    """The command that installs ``missing`` for this Python: the distribution's packages for
    Debian's and Ubuntu's own Python (its pip refuses to install into it), else pip run by
    this very interpreter."""
    packages = {module: (debian, pip) for module, debian, pip in REQUIRED}
    if debian_system_python(os_release):
        names = [packages.get(m, ("python3-" + m.lower().replace("_", "-"), m))[0] for m in missing]
        return "sudo apt install " + " ".join(names)
    names = [packages.get(m, (m, m))[1] for m in missing]
    return quote(sys.executable) + " -m pip install " + " ".join(names)


def debian_system_python(os_release="/etc/os-release"):
    """Whether this is the Python of a Debian or Ubuntu system (/usr, no virtual environment)."""
    if sys.prefix != "/usr" or getattr(sys, "base_prefix", sys.prefix) != sys.prefix:
        return False
    try:
        with open(os_release, encoding="utf-8") as fh:
            fields = dict(line.rstrip("\n").split("=", 1) for line in fh if "=" in line)
    except OSError:
        return False
    family = (fields.get("ID", "") + " " + fields.get("ID_LIKE", "")).replace('"', "").split()
    return "debian" in family or "ubuntu" in family


def quote(path):
    """``path`` as a shell would need it (quoted when it holds spaces or quotes)."""
    if path and all(c.isalnum() or c in "/._-+:\\" for c in path):
        return path
    return '"' + path.replace('"', '\\"') + '"'


def missing_message(missing):
    """The one line the extension shows when modules are missing."""
    them = "it" if len(missing) == 1 else "them"
    return (f"Depixelize: the Python that Inkscape runs extensions with ({sys.executable}) lacks "
            f"{', '.join(missing)}, which inkex (Inkscape's extension library) needs. Install {them}: "
            f"{install_command(missing)}")


def exit_missing(error):
    """Called by the extension when importing inkex (or lxml) failed: one plain line on stderr
    (Inkscape's own under --batch-process), exit status 1, no traceback."""
    messages_to_inkscape()
    missing = missing_modules(error)
    if sys.version_info < MIN_PYTHON:
        text = (f"Depixelize: Inkscape runs extensions with Python {sys.version_info[0]}.{sys.version_info[1]} "
                f"({sys.executable}); the extension needs {MIN_PYTHON[0]}.{MIN_PYTHON[1]} or later")
    elif missing:
        text = missing_message(missing)
    else:
        text = f"Depixelize: cannot import inkex ({error}); is this run by Inkscape 1.x?"
    sys.stderr.write(text + "\n")
    sys.exit(1)


def messages_to_inkscape():
    """Under ``inkscape --batch-process`` send this process's stderr to Inkscape's own: Inkscape
    shows whatever an extension writes to stderr in a dialog that waits for OK, which nobody
    is there to press in a batch. Linux only (the parent's command line and stderr under
    /proc); elsewhere nothing changes."""
    parent = os.getppid()
    try:
        with open(f"/proc/{parent}/cmdline", "rb") as fh:
            arguments = fh.read().split(b"\0")
        if b"--batch-process" not in arguments:
            return
        target = os.open(f"/proc/{parent}/fd/2", os.O_WRONLY | os.O_APPEND)
    except OSError:
        return
    sys.stderr.flush()
    os.dup2(target, 2)
    os.close(target)


def report():
    """What ``depixel inkscape check`` needs to know about this Python, as a dict."""
    error = None
    version = None
    try:
        import inkex  # noqa: F401, PLC0415 (found on the PYTHONPATH the check gives: Inkscape's own)

        version = getattr(inkex, "__version__", "1.x")
    except ImportError as exc:
        error = exc
    inkex_found = error is None or getattr(error, "name", None) != "inkex"
    missing = missing_modules(error if inkex_found else None)
    return {
        "python": sys.executable,
        "version": ".".join(str(part) for part in sys.version_info[:3]),
        "too_old": sys.version_info < MIN_PYTHON,
        "required": [module for module, _, _ in REQUIRED],
        "missing": missing,
        "inkex": version,
        "inkex_found": inkex_found,
        "fix": install_command(missing) if missing else None,
    }


if __name__ == "__main__":
    print(json.dumps(report()))
