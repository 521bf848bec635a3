"""The package is typed (PEP 561): ``depixel/py.typed`` ships with it, and a user's script that
calls the public API passes ``mypy --strict`` (issue 43)."""
from __future__ import annotations

import os
import subprocess
import sys

import pytest
from conftest import ROOT

pytest.importorskip("mypy")

#: what a user writes: the keyword entry points on a numpy array, a PIL image and files
USER_SCRIPT = '''
from pathlib import Path

import numpy as np
from PIL import Image

import depixel
from depixel.prepare.gpl import PaletteMap, read_palette

pixels = np.zeros((4, 4, 4), np.uint8)
svg: str = depixel.convert(pixels, scale=2.0, shading="flat", swatches=True)
again: str = depixel.convert(Image.new("RGBA", (4, 4)), palette_map=("from.gpl", "to.gpl"))
png: bytes = depixel.convert_bytes(pixels, "png", scale=4, palette_map=PaletteMap(read_palette("a.gpl"),
                                                                                  read_palette("b.gpl")))
out: Path = depixel.convert_file("in.png", "out.eps", width=640, background="white")
result: depixel.Result = depixel.depixelize(pixels)
prepared: depixel.PreparedImage = depixel.prepare_input(pixels, pixel_size=1)
print(svg, again, png, out.name, result.vector.shape, prepared.pixel_size)
'''


def test_the_package_ships_its_py_typed_marker():
    assert (ROOT / "depixel" / "py.typed").is_file()
    assert 'depixel = ["py.typed"]' in (ROOT / "pyproject.toml").read_text()  # (package data, so wheels have it)


def test_a_user_script_passes_mypy_strict(tmp_path):
    script = tmp_path / "user.py"
    script.write_text(USER_SCRIPT)
    # the worktree on the path, as an installed package: mypy reads it only through py.typed,
    # and reports the user's script alone
    env = {**os.environ, "PYTHONPATH": str(ROOT), "MYPY_CACHE_DIR": str(tmp_path / ".mypy_cache")}
    run = subprocess.run([sys.executable, "-m", "mypy", "--strict", "--no-incremental", str(script)],
                         cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stdout + run.stderr
    assert "Success: no issues found in 1 source file" in run.stdout


def test_every_public_function_is_annotated_whole():
    """Every parameter and return of ``depixel.__all__``'s functions (and classes' ``__init__``)
    has a type: mypy --strict would take an unannotated parameter as Any and check nothing."""
    import inspect

    import depixel

    missing = []
    for name in depixel.__all__:
        value = getattr(depixel, name)
        if not inspect.isfunction(value):
            continue
        signature = inspect.signature(value)
        missing += [f"{name}({p})" for p, item in signature.parameters.items()
                    if item.annotation is inspect.Parameter.empty]
        if signature.return_annotation is inspect.Signature.empty:
            missing.append(f"{name} -> ?")
    assert not missing, missing
