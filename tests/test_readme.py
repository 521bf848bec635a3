"""The README's commands, run as a reader runs them, print what the README shows.

The ``sh`` blocks of its "Commands" section are run line by line, in order, with bash, in a
scratch copy of the repository's ``fixtures/`` (the commands' working folder), with this
environment's ``depixel`` and ``python`` first on PATH. A line ``#   TEXT`` (a hash and
three spaces) under a command is output the README shows for it: each must be printed by
that command (stderr, then stdout), in the order shown, ``...`` standing for lines left out
(a trailing comma does not count, so an excerpt of a JSON object may end anywhere). When a
change to depixel changes an output, the failure names the README line to update.

Finally the commands may only have written into ``out/``, which .gitignore covers: the
README's commands leave no untracked file in a checkout.
"""
from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from dataclasses import dataclass, field
from pathlib import Path

from conftest import FIXTURES, ROOT

README = ROOT / "README.md"
OUTPUT = "#   "  # the prefix of an output line the README shows


@dataclass
class Command:
    line: int  # in README.md, from 1
    text: str
    shown: list[tuple[int, str]] = field(default_factory=list)  # (README line, output line)


def readme_commands(text: str) -> list[Command]:
    """The commands of the sh blocks of the Commands section, with the output shown under each."""
    section = re.search(r"^## Commands\n(.*?)(?=^## )", text, flags=re.S | re.M)
    assert section, "README.md has no '## Commands' section"
    first = text[: section.start(1)].count("\n") + 1
    commands: list[Command] = []
    inside = False
    for number, line in enumerate(section.group(1).splitlines(), start=first):
        if line.startswith("```"):
            inside = line.strip() == "```sh" if not inside else False
        elif inside and line.startswith(OUTPUT):
            assert commands, f"README.md line {number}: output shown before any command"
            commands[-1].shown.append((number, line[len(OUTPUT):]))
        elif inside and line.strip() and not line.lstrip().startswith("#"):
            commands.append(Command(number, line))
    return commands


def normal(line: str) -> str:
    return line.strip().removesuffix(",")


def missing_lines(shown: list[tuple[int, str]], printed: list[str]) -> list[tuple[int, str]]:
    """The shown lines not printed in that order ("..." skipped)."""
    lines = [normal(p) for p in printed]
    at, missing = 0, []
    for number, text in shown:
        if normal(text) in ("...", "…"):
            continue
        try:
            at = lines.index(normal(text), at) + 1
        except ValueError:
            missing.append((number, text))
    return missing


def test_the_matcher_follows_order_and_skips_ellipses():
    printed = ["{", '  "files": 10,', '  "ok": 10,', '  "seconds": 2.7', "}"]
    assert missing_lines([(1, "{"), (2, '"files": 10,'), (3, "..."), (4, "}")], printed) == []
    assert missing_lines([(1, '"ok": 10'), (2, '"files": 10')], printed) == [(2, '"files": 10')]  # order
    assert missing_lines([(1, '"ok": 9,')], printed) == [(1, '"ok": 9,')]  # figures count


def test_the_readme_commands_print_what_the_readme_shows(tmp_path):
    commands = readme_commands(README.read_text())
    assert len(commands) >= 20 and sum(len(c.shown) for c in commands) >= 30, "the README lost its examples"
    shutil.copytree(FIXTURES, tmp_path / "fixtures")
    before = {p.relative_to(tmp_path) for p in tmp_path.rglob("*")}
    env = {**os.environ, "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ['PATH']}",
           "COLUMNS": "80"}
    env.pop("PYTHONPATH", None)
    failures = []
    for command in commands:
        done = subprocess.run(["bash", "-c", command.text], cwd=tmp_path, env=env, capture_output=True, text=True,
                              timeout=600)
        printed = done.stderr.splitlines() + done.stdout.splitlines()
        if "Traceback" in done.stderr:
            failures.append(f"README.md line {command.line}: {command.text}\n  crashed:\n{done.stderr}")
        for number, text in missing_lines(command.shown, printed):
            failures.append(f"README.md line {number} shows {text!r}, which `{command.text.split('  #')[0]}` "
                            f"(line {command.line}) no longer prints; it printed:\n  " + "\n  ".join(printed))
    assert not failures, "\n\n".join(failures)
    made = {p.relative_to(tmp_path) for p in tmp_path.rglob("*")} - before
    outside = sorted(str(p) for p in made if p.parts[0] != "out")
    assert not outside, f"the README's commands wrote outside out/: {outside}"
    assert "/out/" in (ROOT / ".gitignore").read_text().splitlines(), ".gitignore no longer covers out/"
