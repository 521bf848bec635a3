"""What a new user is told to install must work: depixel is not a published package, so no
page, message or dialog says ``pip install depixel`` (or ``depixel[extra]`` from an index);
each says to install it from its source folder or a wheel built there."""
from __future__ import annotations

import re

import pytest
from conftest import ROOT

#: ``pip install depixel``, ``pip install "depixel[pdf]"``, ``pip install 'depixel[dask]'``:
#: the name alone, which pip looks up on an index (``"depixel @ git+…"`` says where it is).
FROM_AN_INDEX = re.compile(r"""pip install\s+(?:-\S+\s+)*["']?depixel(?:\[[\w,]+\])?(?!\s*@)["']?(?=[\s`)'";,]|$)""")

#: Where users read instructions: the docs (docs/design.md records decisions, and names the
#: extras it rejected), the README, and every message of the library, the command and the
#: Inkscape extension.
PLACES = sorted({*ROOT.glob("docs/*.md"), *ROOT.glob("docs/ci/*"), ROOT / "README.md", *ROOT.glob("depixel/**/*.py"),
                 *ROOT.glob("cli/**/*.py")} - {ROOT / "docs" / "design.md"})


@pytest.mark.parametrize("path", PLACES, ids=lambda p: str(p.relative_to(ROOT)))
def test_no_instruction_installs_depixel_from_an_index(path):
    text = path.read_text(encoding="utf-8")
    found = [m.group() for m in FROM_AN_INDEX.finditer(text)]
    assert not found, f"{path.relative_to(ROOT)}: {found} (depixel is not on PyPI: its source folder or a wheel)"


def test_the_pattern_sees_each_form():
    for text in ("pip install depixel", "pip install depixel  # x", 'pip install "depixel[pdf]"',
                 "`pip install 'depixel[dask]'`", "pip install -U depixel"):
        assert FROM_AN_INDEX.search(text), text
    for text in ("pip install /path/to/depixel", 'pip install "/path/to/depixel[pdf]"', "pip install .",
                 "pip install dist/depixel-0.1.0-py3-none-any.whl", "pip install depixel-0.1.0.tar.gz",
                 'pip install "depixel @ git+https://example.org/depixel"'):
        assert not FROM_AN_INDEX.search(text), text
