"""Shared test helpers: images from character maps, fixture paths, the shared corpus."""
from __future__ import annotations

import re
import signal
from pathlib import Path

import numpy as np
import pytest
from hypothesis import settings

# Every property test runs the same examples on every run and machine (CI never flakes, a
# failure reproduces) and leaves no example database behind: the profile is the default of
# each ``@settings``, which names only what it changes.
settings.register_profile("depixel", derandomize=True, database=None)
settings.load_profile("depixel")

# A suite started in the background of a script (``nohup pytest &``) inherits SIGINT ignored,
# and so would every command it runs: the tests of Ctrl-C need the terminal's default.
if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)

ROOT = Path(__file__).resolve().parent.parent
FIXTURES = ROOT / "fixtures"
SHARED = ROOT.parent / "shared"
CORPUS = SHARED / "corpus" / "paper"
JUDGE = SHARED / "tools" / "judge.py"

COLOURS = {
    ".": (255, 255, 255, 255),
    "#": (0, 0, 0, 255),
    "r": (220, 30, 30, 255),
    "g": (30, 180, 60, 255),
    "b": (30, 60, 220, 255),
    "y": (240, 220, 40, 255),
    " ": (0, 0, 0, 0),
}


def art(text: str, colours: dict | None = None) -> np.ndarray:
    """``(H, W, 4) uint8`` image from a character map (see COLOURS)."""
    table = dict(COLOURS, **(colours or {}))
    rows = [r.strip() for r in text.strip().splitlines()]
    return np.array([[table[ch] for ch in row] for row in rows], dtype=np.uint8)


def drop_summary(err: str) -> str:
    """A batch's stderr without the summary line it ends with (``depixel: N files: ...``),
    which must be there."""
    lines = err.rstrip("\n").splitlines()
    assert lines and re.match(r"depixel: \d+ files?: ", lines[-1]), err
    return "\n".join(lines[:-1])


def fixture_pngs() -> list[Path]:
    return sorted(p for p in FIXTURES.iterdir() if p.suffix in (".png", ".gif"))


def corpus_pngs() -> list[Path]:
    return sorted(CORPUS.glob("*.png")) if CORPUS.is_dir() else []


needs_corpus = pytest.mark.skipif(not CORPUS.is_dir(), reason="../shared/corpus not present")
