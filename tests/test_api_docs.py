"""docs/api.md is true: its Python blocks run, print what their comments say, and every
function it names exists under that dotted name, after ``import depixel`` alone, with the
parameters it lists.

Each block runs in a fresh interpreter (a module imported by another test cannot make a
dotted name work by accident), from a scratch folder holding a copy of ``fixtures/``.
"""
from __future__ import annotations

import inspect
import re
import shutil
import subprocess
import sys
from functools import reduce

import pytest
from conftest import FIXTURES, ROOT

DOC = ROOT / "docs" / "api.md"
TEXT = DOC.read_text()
BLOCKS = [(TEXT[: match.start()].count("\n") + 2, match.group(1))
          for match in re.finditer(r"```python\n(.*?)```", TEXT, flags=re.S)]
#: a ``print(...)  # what it prints`` line; a trailing "..." means "starts with"
PRINT = re.compile(r"^\s*print\(.*\)\s+#\s?(.*)$")


def expected_prints(code: str) -> list[str]:
    return [match.group(1) for line in code.splitlines() if (match := PRINT.match(line))]


def test_the_page_has_blocks():
    assert len(BLOCKS) >= 3, "docs/api.md lost its examples"


@pytest.mark.parametrize("line, code", BLOCKS, ids=[f"line-{line}" for line, _ in BLOCKS])
def test_each_block_runs_and_prints_what_it_says(line, code, tmp_path):
    shutil.copytree(FIXTURES, tmp_path / "fixtures")
    done = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, f"docs/api.md, the block at line {line}, failed:\n{done.stderr}"
    printed = done.stdout.splitlines()
    expected = expected_prints(code)
    assert len(printed) == len(expected), f"docs/api.md line {line}: printed {printed}, the comments say {expected}"
    for shown, got in zip(expected, printed):
        ok = got.startswith(shown[:-3].rstrip()) if shown.endswith("...") else got == shown
        assert ok, f"docs/api.md, block at line {line}: the comment says {shown!r}, it printed {got!r}"


def documented_calls() -> list[tuple[str, list[str]]]:
    """Every ``depixel.…`` name in backticks on the page, with the parameter names written
    after it when it is written as a call."""
    calls = []
    for match in re.finditer(r"`(depixel(?:\.\w+)+)(\(([^`]*)\))?`", TEXT):
        name, arguments = match.group(1), match.group(3)
        words = [] if not arguments else [part.split("=")[0].strip() for part in arguments.split(",")]
        calls.append((name, [w for w in words if w.isidentifier()]))
    return calls


def test_every_documented_name_resolves_after_import_depixel_alone():
    names = sorted({name for name, _ in documented_calls()})
    assert "depixel.diff.pairs.diff_files" in names and "depixel.render.figure.figure" in names
    code = ("import functools, depixel\n"
            f"for name in {names!r}:\n"
            "    functools.reduce(getattr, name.split('.')[1:], depixel)\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr.strip().splitlines()[-1]


@pytest.mark.parametrize("name, parameters", [call for call in documented_calls() if call[1]],
                         ids=lambda value: value if isinstance(value, str) else "")
def test_documented_parameters_exist(name, parameters):
    import depixel

    function = reduce(getattr, name.split(".")[1:], depixel)
    accepted = inspect.signature(function).parameters
    unknown = [p for p in parameters if p not in accepted]
    assert not unknown, f"docs/api.md writes {name}({', '.join(unknown)}), which it does not take"


def test_a_misspelt_parameter_names_the_closest_field():
    import depixel

    with pytest.raises(depixel.ParameterError, match=r"^Params has no field 'iteration'; did you mean iterations\?$"
                       ) as info:
        depixel.Params().replace(iteration=1)
    assert info.value.parameter == "iteration"
    with pytest.raises(depixel.ParameterError, match=r"^seed no longer does anything: .*; leave it out$"):
        depixel.Params().replace(seed=1)  # gone with the random trials (issue 31): said so, not "no field"
    with pytest.raises(depixel.ParameterError, match="'curve_wieght'; did you mean curve_weight"):
        depixel.Params().replace(curve_wieght=2.0)
    with pytest.raises(depixel.ParameterError, match="no field 'zzz'; the fields are threshold_y, "):
        depixel.Params().replace(zzz=1)
    assert depixel.Params().replace(curve_weight=2.0).curve_weight == 2.0


def test_results_print_in_one_line():
    import numpy as np

    import depixel
    from depixel.diff.compare import compare

    ghost = depixel.api.load(FIXTURES / "ghost.png")
    result = depixel.depixelize(ghost)
    flat = depixel.flatten(ghost, "white")
    products = [result, result.similarity, result.resolution, result.cells, result.vector, result.splines,
                result.optimized, result.optimized.corners, depixel.prepare_input(ghost), compare(flat, flat)]
    for product in products:
        text = repr(product)
        assert "\n" not in text and "array(" not in text and len(text) < 1000, text[:200]
    assert repr(compare(flat, flat)).startswith("Comparison(a=uint8[16, 18, 4], b=uint8[16, 18, 4], "
                                                "different=bool[16, 18]")
    assert "energy_before=" in repr(result.optimized)  # numbers stay, arrays go
    assert np.shares_memory(result.similarity.rgba, result.similarity.rgba)  # (repr copies nothing)
