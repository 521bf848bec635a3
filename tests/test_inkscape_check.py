"""``depixel inkscape check`` and the extension when Inkscape's Python lacks what inkex needs.

Inkscape runs extensions with its preferences' python-interpreter, else ``python3`` on PATH;
inkex imports lxml, cssselect and numpy. A virtual environment made without pip and without
the system's packages is a Python that has none of them, as Debian's python3 is without
python3-lxml & co.
"""
from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from test_inkscape import why_not

from depixel_cli.inkscape import command as installer
from depixel_cli.main import main
from depixel_cli.options import Exit

SCRIPT = installer.SOURCE / "depixel_inkscape.py"
CHECK = installer.SOURCE / "depixel_inkscape_check.py"


@pytest.fixture(scope="module")
def bare_python(tmp_path_factory) -> str:
    """A Python without lxml, cssselect and numpy."""
    folder = tmp_path_factory.mktemp("bare")
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(folder / "venv")], check=True)
    python = str(folder / "venv" / "bin" / "python")
    for module in ("lxml", "cssselect", "numpy"):
        assert subprocess.run([python, "-c", f"import {module}"], capture_output=True).returncode != 0
    return python


def preferences(profile: Path, python: str) -> Path:
    """Inkscape's profile folder whose preferences name ``python``; its extensions folder."""
    (profile / "extensions").mkdir(parents=True)
    (profile / "preferences.xml").write_text(
        '<?xml version="1.0"?>\n<inkscape version="1">\n  <group id="window" />\n'
        f'  <group id="extensions" python-interpreter="{python}" org.other.setting="1" />\n</inkscape>\n')
    return profile / "extensions"


def test_check_names_what_is_missing_and_the_command(tmp_path, bare_python, capsys):
    folder = preferences(tmp_path, bare_python)
    assert main(["inkscape", "check", "--dir", str(folder)]) == Exit.FAILED
    out, err = capsys.readouterr()
    assert out.splitlines()[:4] == [
        f"Inkscape runs extensions with {bare_python} (python-interpreter in {tmp_path / 'preferences.xml'}; "
        f"Python {sys.version.split()[0]})",
        "  lxml       missing", "  cssselect  missing", "  numpy      missing"]
    # with Inkscape installed, its inkex is tried too
    assert out.splitlines()[4:] in ([], ["  inkex      not importable without the modules above"])
    assert err == (f"depixel: error: {bare_python} (python-interpreter in {tmp_path / 'preferences.xml'}) lacks "
                   f"lxml, cssselect, numpy, which inkex needs; install them: {bare_python} -m pip install lxml "
                   "cssselect numpy\n")


def test_install_refuses_unless_forced(tmp_path, bare_python, capsys):
    folder = preferences(tmp_path, bare_python)
    assert main(["inkscape", "install", "--dir", str(folder)]) == Exit.FAILED
    err = capsys.readouterr().err
    assert err.endswith("; the extension was not installed (--force installs it anyway)\n") and err.count("\n") == 1
    assert list(folder.iterdir()) == []
    assert main(["inkscape", "install", "--dir", str(folder), "--force"]) == Exit.OK
    out, err = capsys.readouterr()
    assert "installing anyway (--force)" in err and "installed the Inkscape extension" in out
    assert sorted(p.name for p in folder.iterdir()) == sorted(installer.INSTALLED)


def test_a_python_with_the_modules_passes(tmp_path, capsys, monkeypatch):
    """This Python (the test environment's, lxml and numpy included) plus a stand-in for
    whatever it lacks (cssselect): the check passes and says which inkex it would use."""
    folder = preferences(tmp_path, sys.executable)
    stubs = tmp_path / "stubs"
    for module in ("lxml", "cssselect", "numpy"):
        if subprocess.run([sys.executable, "-c", f"import {module}"], capture_output=True).returncode:
            (stubs / module).mkdir(parents=True)
            (stubs / module / "__init__.py").write_text("")
    monkeypatch.setenv("PYTHONPATH", str(stubs))
    assert main(["inkscape", "check", "--dir", str(folder)]) == Exit.OK
    out = capsys.readouterr().out.splitlines()
    assert out[1:4] == ["  lxml       ok", "  cssselect  ok", "  numpy      ok"] and out[-1] == "the extension can run"


def test_without_a_preference_python3_on_path_is_the_one(tmp_path, bare_python, capsys, monkeypatch):
    (tmp_path / "extensions").mkdir()
    (tmp_path / "bin").mkdir()
    (tmp_path / "bin" / "python3").symlink_to(bare_python)
    monkeypatch.setenv("PATH", str(tmp_path / "bin"))
    assert main(["inkscape", "check", "--dir", str(tmp_path / "extensions")]) == Exit.FAILED
    out = capsys.readouterr().out
    assert out.startswith(f"Inkscape runs extensions with {tmp_path / 'bin' / 'python3'} (the first python3 on PATH;")
    monkeypatch.setenv("PATH", str(tmp_path / "nothing"))
    assert main(["inkscape", "check", "--dir", str(tmp_path / "extensions")]) == Exit.FAILED
    assert "Inkscape finds no Python to run extensions with (python3 or python on PATH)" in capsys.readouterr().err


@pytest.mark.parametrize("os_release, debian", [('ID=debian\n', True), ('ID=ubuntu\nID_LIKE=debian\n', True),
                                                ('ID=linuxmint\nID_LIKE="ubuntu debian"\n', True),
                                                ('ID=fedora\n', False)])
def test_the_fix_for_a_distribution_python_is_its_packages(tmp_path, monkeypatch, os_release, debian):
    sys.path.insert(0, str(installer.SOURCE))
    try:
        import depixel_inkscape_check as check
    finally:
        sys.path.remove(str(installer.SOURCE))
    (tmp_path / "os-release").write_text(os_release)
    monkeypatch.setattr(sys, "prefix", "/usr")
    monkeypatch.setattr(sys, "base_prefix", "/usr")
    monkeypatch.setattr(sys, "executable", "/usr/bin/python3")
    release = str(tmp_path / "os-release")
    expected = "sudo apt install python3-lxml python3-numpy" if debian else "/usr/bin/python3 -m pip install lxml numpy"
    assert check.install_command(["lxml", "numpy"], release) == expected
    monkeypatch.setattr(sys, "base_prefix", "/usr/local")  # a virtual environment: pip
    assert check.install_command(["lxml"], release) == "/usr/bin/python3 -m pip install lxml"


def test_the_extension_says_what_is_missing_in_one_line(tmp_path, bare_python):
    """No traceback: one line, the command that installs the modules, exit status 1."""
    inkex = tmp_path / "path" / "inkex"  # PyPI's inkex alone, as Inkscape puts its own on PYTHONPATH
    import inkex as pypi_inkex

    shutil.copytree(Path(pypi_inkex.__file__).parent, inkex)
    document = tmp_path / "in.svg"
    document.write_text('<svg xmlns="http://www.w3.org/2000/svg"/>')
    done = subprocess.run([bare_python, str(SCRIPT), "--id=x", str(document)], capture_output=True, text=True,
                          env={"PATH": "/usr/bin:/bin", "PYTHONPATH": str(inkex.parent)})
    assert done.returncode == 1 and done.stdout == ""
    assert done.stderr == (f"Depixelize: the Python that Inkscape runs extensions with ({bare_python}) lacks lxml, "
                           "cssselect, numpy, which inkex (Inkscape's extension library) needs. Install them: "
                           f"{bare_python} -m pip install lxml cssselect numpy\n")


def test_under_batch_process_the_message_goes_to_inkscapes_stderr(tmp_path, bare_python):
    """A parent whose command line holds --batch-process stands for ``inkscape --batch-process``:
    what the extension says reaches the parent's own stderr, and the extension's stderr (what
    Inkscape would show in a dialog waiting for OK) stays empty."""
    document = tmp_path / "in.svg"
    document.write_text('<svg xmlns="http://www.w3.org/2000/svg"/>')
    parent = ("import subprocess, sys\n"
              "done = subprocess.run(sys.argv[2:], capture_output=True)\n"
              "print(repr(done.stderr), done.returncode)\n")
    child = [bare_python, str(SCRIPT), "--id=x", str(document)]
    for flag, in_dialog in (("--batch-process", False), ("--with-gui", True)):
        done = subprocess.run([sys.executable, "-c", parent, flag, *child], capture_output=True, text=True,
                              env={"PATH": "/usr/bin:/bin"})
        seen_by_inkscape, code = done.stdout.rsplit(" ", 1)
        assert int(code) == 1
        if in_dialog:
            assert "lacks lxml" in seen_by_inkscape and done.stderr == ""
        else:
            assert seen_by_inkscape == "b''" and done.stderr.startswith("Depixelize: the Python that Inkscape runs")


def test_the_skip_reason_of_the_inkscape_tests_names_what_is_missing(bare_python):
    reason = why_not(bare_python, {"PATH": "/usr/bin:/bin"})
    assert reason == f"{bare_python} lacks lxml, cssselect, numpy ({bare_python} -m pip install lxml cssselect numpy)"
