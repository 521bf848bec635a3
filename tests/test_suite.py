"""The suite's own rules: every property test runs the same examples on every run."""
from __future__ import annotations

import importlib

from conftest import ROOT


def test_every_property_test_is_derandomized():
    """A hypothesis test that draws new examples on each run makes CI flaky and a failure
    hard to reproduce: conftest's profile derandomizes them all, and no ``@settings`` may
    turn that off."""
    checked = 0
    for path in sorted((ROOT / "tests").glob("test_*.py")):
        module = importlib.import_module(path.stem)
        for name in dir(module):
            test = getattr(module, name)
            if name.startswith("test") and hasattr(test, "hypothesis"):
                assert test._hypothesis_internal_use_settings.derandomize, f"{path.name}::{name}"
                checked += 1
    assert checked >= 15
