"""``depixel inkscape install`` / ``uninstall`` touch only the files install wrote: a
customised copy, another program's file of the same name or a symbolic link into another
checkout is refused (``--force`` replaces it, a link by a file, never written through), and
uninstall removes only what install wrote and nobody edited since. And ``check`` says that
a desktop-launched Inkscape may run another Python. Each test runs the command."""
from __future__ import annotations

import json
from pathlib import Path

import pytest
from test_inkscape import ready_python

from depixel_cli.inkscape import command as installer
from depixel_cli.main import main
from depixel_cli.options import Exit


def run(*argv: str, capsys) -> tuple[int, str, str]:
    try:
        code = main(["inkscape", *argv])
    except SystemExit as exc:
        code = int(exc.code or 0)
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture
def folder(tmp_path, monkeypatch) -> Path:
    """An extensions folder whose Inkscape Python passes the check."""
    ready_python(tmp_path, monkeypatch)
    path = tmp_path / "extensions"
    path.mkdir()
    return path


def contents(folder: Path) -> dict[str, bytes | str]:
    """Every entry of ``folder``: a file's bytes, a link's target."""
    return {p.name: f"-> {p.readlink()}" if p.is_symlink() else p.read_bytes() for p in folder.iterdir()}


SCRIPT = "depixel_inkscape.py"


def test_install_refuses_to_replace_a_customised_copy_unless_forced(folder, capsys):
    assert run("install", "--dir", str(folder), capsys=capsys)[0] == Exit.OK
    (folder / SCRIPT).write_text("# my own version of the script\n")
    before = contents(folder)
    code, _, err = run("install", "--dir", str(folder), capsys=capsys)
    assert code == Exit.FAILED and err.count("\n") == 1 and "edited since" in err and "--force" in err, err
    assert contents(folder) == before
    assert run("install", "--dir", str(folder), "--force", capsys=capsys)[0] == Exit.OK
    assert (folder / SCRIPT).read_bytes() == (installer.SOURCE / SCRIPT).read_bytes()


def test_install_refuses_a_file_of_another_program_unless_forced(folder, capsys):
    (folder / "depixel_inkscape.inx").write_text("<inkscape-extension>someone else's</inkscape-extension>")
    before = contents(folder)
    code, _, err = run("install", "--dir", str(folder), capsys=capsys)
    assert code == Exit.FAILED and "not written by install" in err, err
    assert contents(folder) == before  # nothing installed, not even the other files


def test_install_never_writes_through_a_link_into_another_checkout(folder, tmp_path, capsys):
    checkout = tmp_path / "checkout" / "cli" / "inkscape" / "extension"
    checkout.mkdir(parents=True)
    theirs = checkout / SCRIPT
    theirs.write_text("# the other checkout's script, being edited\n")
    (folder / SCRIPT).symlink_to(theirs)
    code, _, err = run("install", "--dir", str(folder), capsys=capsys)
    assert code == Exit.FAILED and "symbolic link" in err, err
    assert run("install", "--dir", str(folder), "--force", capsys=capsys)[0] == Exit.OK
    assert theirs.read_text() == "# the other checkout's script, being edited\n"
    assert not (folder / SCRIPT).is_symlink()
    assert (folder / SCRIPT).read_bytes() == (installer.SOURCE / SCRIPT).read_bytes()


def test_uninstall_where_install_never_ran_removes_nothing(folder, capsys):
    for name in installer.INSTALLED:
        (folder / name).write_text(f"the user's own {name}\n")
    before = contents(folder)
    code, out, _ = run("uninstall", "--dir", str(folder), capsys=capsys)
    assert code == Exit.OK and "nothing removed" in out
    assert contents(folder) == before


def test_uninstall_keeps_a_file_edited_since_install(folder, capsys):
    assert run("install", "--dir", str(folder), capsys=capsys)[0] == Exit.OK
    record = json.loads((folder / installer.RECORDED_COMMAND).read_text())
    assert set(record["files"]) == set(installer.SHIPPED)
    (folder / SCRIPT).write_text("# edited by hand\n")
    code, out, _ = run("uninstall", "--dir", str(folder), capsys=capsys)
    assert code == Exit.OK and f"kept in {folder}: {SCRIPT}" in out
    assert sorted(contents(folder)) == sorted([SCRIPT, installer.RECORDED_COMMAND])  # the record stays with it
    assert run("uninstall", "--dir", str(folder), "--force", capsys=capsys)[0] == Exit.OK
    assert contents(folder) == {}


def test_check_says_a_desktop_inkscape_may_use_another_python(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("PATH", str(Path(__import__("sys").executable).parent))  # python3 found on PATH
    (tmp_path / "extensions").mkdir()
    code, out, _ = run("check", "--dir", str(tmp_path / "extensions"), capsys=capsys)
    assert "the first python3 on PATH" in out
    assert "desktop" in out and "python-interpreter" in out
