"""docs/ci.md's shell script and workflow are real files (docs/ci/), quoted whole in the page
and run here: the CI story works, also in a build folder kept from run to run."""
from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import yaml
from conftest import FIXTURES, ROOT
from PIL import Image

DOC = (ROOT / "docs" / "ci.md").read_text()
SCRIPT = ROOT / "docs" / "ci" / "visual-regression.sh"
WORKFLOW = ROOT / "docs" / "ci" / "renders.yml"
#: the test's interpreter's folder first on the PATH: its depixel and its python
ENV = {**os.environ, "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ.get('PATH', '')}"}


def block(language: str, after: str) -> str:
    """The first ```language block after the heading ``after``."""
    return re.search(rf"{re.escape(after)}.*?```{language}\n(.*?)```", DOC, re.S).group(1)


def test_the_page_quotes_the_files_whole():
    assert block("sh", "## A shell script") == SCRIPT.read_text()
    assert block("yaml", "## GitHub Actions") == WORKFLOW.read_text()
    assert "(ci/visual-regression.sh)" in DOC and "(ci/renders.yml)" in DOC


def art_folder(root: Path) -> Path:
    art = root / "art"
    (art / "items").mkdir(parents=True)
    shutil.copy(FIXTURES / "heart.png", art / "heart.png")
    shutil.copy(FIXTURES / "mushroom.png", art / "items" / "mushroom.png")
    return art


def edit_the_mushroom(art: Path) -> None:
    sprite = Image.open(art / "items" / "mushroom.png").convert("RGB")
    sprite.putpixel((5, 5), (24, 20, 37))  # one red pixel of the cap made dark
    sprite.save(art / "items" / "mushroom.png")


def test_the_shell_script_compares_reports_and_approves(tmp_path):
    script = tmp_path / "visual-regression.sh"
    shutil.copy(SCRIPT, script)  # copied into the project, as the page says
    art = art_folder(tmp_path)

    def run(*args: str) -> subprocess.CompletedProcess:
        return subprocess.run(["sh", str(script), *args], cwd=tmp_path, env=ENV, capture_output=True, text=True,
                              timeout=300)

    first = run()
    assert first.returncode == 1 and "new: heart.svg" in first.stdout, first.stderr
    assert run("--approve").returncode == 0
    assert sorted(p.relative_to(tmp_path / "renders").as_posix() for p in (tmp_path / "renders").rglob("*.svg")) \
        == ["heart.svg", "items/mushroom.svg"]
    same = run()
    assert same.returncode == 0 and same.stdout.splitlines()[-1].startswith("same: 2 files"), same.stdout
    edit_the_mushroom(art)
    changed = run()
    assert changed.returncode == 1 and "different: items/mushroom.svg" in changed.stdout
    assert "--approve" in changed.stderr
    assert "items/mushroom.svg" in (tmp_path / "build" / "diff-report" / "index.html").read_text()
    assert (tmp_path / "build" / "diff.xml").is_file()
    assert run("--approve").returncode == 0 and run().returncode == 0


def test_the_shell_script_run_twice_in_a_kept_build_folder_reports_a_deleted_sprite_missing(tmp_path):
    script = tmp_path / "visual-regression.sh"
    shutil.copy(SCRIPT, script)
    art = art_folder(tmp_path)
    env = {**ENV, "BUILD": "kept"}

    def run(*args: str) -> subprocess.CompletedProcess:
        return subprocess.run(["sh", str(script), *args], cwd=tmp_path, env=env, capture_output=True, text=True,
                              timeout=300)

    assert run().returncode == 1 and run("--approve").returncode == 0 and run().returncode == 0
    (art / "heart.png").unlink()
    gone = run()
    assert gone.returncode == 1, gone.stderr
    assert "missing: heart.svg" in gone.stdout and not (tmp_path / "kept" / "renders" / "heart.svg").exists()
    assert run("--approve").returncode == 0 and not (tmp_path / "renders" / "heart.svg").exists()
    assert run().returncode == 0


def evaluate(condition: str, approve: bool, failed: bool) -> bool:
    """A step's ``if`` as GitHub reads the workflow's few forms (``!``, ``&&``, ``always()``,
    ``inputs.approve``): without a status function, ``success() &&`` is implied."""
    text = re.fullmatch(r"\$\{\{(.*)\}\}", condition.strip(), re.S).group(1)
    status = re.search(r"\b(always|success|failure|cancelled)\(\)", text)
    python = re.sub(r"!(?!=)", " not ", text).replace("&&", " and ").replace("||", " or ")
    python = python.replace("always()", "True").replace("success()", "(not failed)")
    python = python.replace("failure()", "failed").replace("inputs.approve", "approve")
    value = eval(python, {}, {"approve": approve, "failed": failed})  # noqa: S307 (the workflow's own text)
    return bool(value) and (status is not None or not failed)


def run_workflow(workspace: Path, approve: bool) -> dict[str, tuple[int, str] | str]:
    """The workflow's steps in ``workspace`` (a checkout), as GitHub's runner runs them:
    each ``run`` with ``bash -eo pipefail``, skipped when its ``if`` is false; the actions
    (checkout, setup-python, upload-artifact) and the install step are the test's part.
    Returns each step's (exit code, output) by name, or what became of it."""
    steps = yaml.safe_load(WORKFLOW.read_text())["jobs"]["renders"]["steps"]
    env = {**ENV, "GITHUB_STEP_SUMMARY": str(workspace / "summary.md")}
    failed, done = False, {}
    for index, step in enumerate(steps):
        name = step.get("name", step.get("uses", str(index)))
        if "if" in step and not evaluate(step["if"], approve, failed) or "if" not in step and failed:
            done[name] = "skipped"
        elif "uses" in step:
            done[name] = "action"
        elif "pip install" in step["run"]:
            done[name] = "installed"  # this interpreter's depixel, on the PATH
        else:
            assert "${{" not in step["run"], step["run"]  # no expression to expand in a script
            script = workspace.parent / f"step-{index}.sh"
            script.write_text(step["run"])
            result = subprocess.run(["bash", "--noprofile", "--norc", "-eo", "pipefail", str(script)],
                                    cwd=workspace, env=env, capture_output=True, text=True, timeout=300)
            failed = failed or result.returncode != 0
            done[name] = (result.returncode, result.stdout + result.stderr)
    return done


def git(*args: str, cwd: Path) -> str:
    return subprocess.run(["git", "-c", "user.name=t", "-c", "user.email=t@example.org", "-c", "init.defaultBranch=main",
                           *args], cwd=cwd, env=ENV, capture_output=True, text=True, check=True).stdout


@pytest.mark.skipif(shutil.which("git") is None, reason="the approval commits and pushes with git")
def test_the_workflow_compares_uploads_and_approves(tmp_path):
    workflow = yaml.safe_load(WORKFLOW.read_text())
    assert "approve" in workflow[True]["workflow_dispatch"]["inputs"]  # YAML 1.1 reads the key "on" as True
    assert any("upload-artifact" in step.get("uses", "") and step["with"]["path"] == "build/diff-report"
               for step in workflow["jobs"]["renders"]["steps"])
    origin, project = tmp_path / "origin.git", tmp_path / "project"
    git("init", "-q", "--bare", str(origin), cwd=tmp_path)
    git("clone", "-q", str(origin), str(project), cwd=tmp_path)
    art_folder(project)
    git("add", "-A", cwd=project)
    git("commit", "-q", "-m", "art", cwd=project)
    git("push", "-q", "origin", "HEAD:main", cwd=project)

    def checkout(name: str) -> Path:
        git("clone", "-q", "--branch", "main", str(origin), name, cwd=tmp_path)
        return tmp_path / name

    first = run_workflow(checkout("run1"), approve=False)
    assert first["compare with the baseline"][0] == 1  # no baseline yet: every render is new
    assert "new: heart.svg" in first["compare with the baseline"][1]
    assert first["keep the report"] == "action" and (tmp_path / "run1" / "build" / "diff-report").is_dir()
    assert "| heart.svg | new |" in (tmp_path / "run1" / "summary.md").read_text()
    assert first["approve (update the baseline and commit it)"] == "skipped"

    approval = run_workflow(checkout("run2"), approve=True)
    assert approval["compare with the baseline"] == "skipped"
    assert approval["approve (update the baseline and commit it)"][0] == 0
    assert git("ls-tree", "-r", "--name-only", "main", cwd=origin).split() == \
        ["art/heart.png", "art/items/mushroom.png", "renders/heart.svg", "renders/items/mushroom.svg"]

    kept = checkout("run3")
    same = run_workflow(kept, approve=False)
    assert same["compare with the baseline"][0] == 0 and "same: 2 files" in same["compare with the baseline"][1]
    assert "| heart.svg | same |" in (kept / "summary.md").read_text()

    # a self-hosted runner keeps the workspace: build/ stays from the run before
    (kept / "art" / "heart.png").unlink()
    edit_the_mushroom(kept / "art")
    git("commit", "-q", "-am", "a sprite deleted, one edited", cwd=kept)
    (kept / "summary.md").unlink()
    changed = run_workflow(kept, approve=False)
    output = changed["compare with the baseline"][1]
    assert changed["compare with the baseline"][0] == 1
    assert "missing: heart.svg" in output and "different: items/mushroom.svg" in output, output
    verdicts = (kept / "summary.md").read_text()
    assert "| heart.svg | missing |" in verdicts and "| items/mushroom.svg | different |" in verdicts
