"""docs/ci.md's shell script and workflow, as written there: the CI story works."""
from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import FIXTURES, ROOT
from PIL import Image

DOC = (ROOT / "docs" / "ci.md").read_text()


def block(language: str, after: str) -> str:
    """The first ```language block after the heading ``after``."""
    return re.search(rf"{re.escape(after)}.*?```{language}\n(.*?)```", DOC, re.S).group(1)


def test_the_shell_script_compares_reports_and_approves(tmp_path):
    script = tmp_path / "visual-regression.sh"
    script.write_text(block("sh", "## A shell script"))
    art = tmp_path / "art"
    (art / "items").mkdir(parents=True)
    shutil.copy(FIXTURES / "heart.png", art / "heart.png")
    shutil.copy(FIXTURES / "mushroom.png", art / "items" / "mushroom.png")
    env = {**os.environ, "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ.get('PATH', '')}"}

    def run(*args: str) -> subprocess.CompletedProcess:
        return subprocess.run(["sh", str(script), *args], cwd=tmp_path, env=env, capture_output=True, text=True,
                              timeout=300)

    first = run()
    assert first.returncode == 1 and "new: heart.svg" in first.stdout, first.stderr
    assert run("--approve").returncode == 0
    assert sorted(p.relative_to(tmp_path / "renders").as_posix() for p in (tmp_path / "renders").rglob("*.svg")) \
        == ["heart.svg", "items/mushroom.svg"]
    same = run()
    assert same.returncode == 0 and same.stdout.splitlines()[-1].startswith("same: 2 files"), same.stdout
    sprite = Image.open(art / "items" / "mushroom.png").convert("RGB")
    sprite.putpixel((5, 5), (24, 20, 37))  # one red pixel of the cap made dark
    sprite.save(art / "items" / "mushroom.png")
    changed = run()
    assert changed.returncode == 1 and "different: items/mushroom.svg" in changed.stdout
    assert "--approve" in changed.stderr
    assert "items/mushroom.svg" in (tmp_path / "build" / "diff-report" / "index.html").read_text()
    assert (tmp_path / "build" / "diff.xml").is_file()
    assert run("--approve").returncode == 0 and run().returncode == 0


def test_the_workflow_compares_uploads_and_approves():
    yaml = pytest.importorskip("yaml", reason="PyYAML reads the workflow (pip install pyyaml)")
    workflow = yaml.safe_load(block("yaml", "## GitHub Actions"))
    steps = workflow["jobs"]["renders"]["steps"]
    text = [str(step.get("run", "")) + str(step.get("uses", "")) for step in steps]
    assert any("depixel diff renders build/renders" in t and "--html build/diff-report" in t for t in text)
    assert any("upload-artifact" in t for t in text)
    assert any("--update --prune" in t and "git push" in t for t in text)
    assert "approve" in workflow[True]["workflow_dispatch"]["inputs"]  # YAML 1.1 reads the key "on" as True
