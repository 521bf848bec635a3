"""The options stamp: the same 16 hex digits whichever SHA-256 implementation computes it."""
from __future__ import annotations

import hashlib
import json

import depixel
from depixel.files.stamp import options_stamp


def test_options_stamp_is_the_sha256_of_the_sorted_options():
    options = {"fmt": "svg", "scale": 2.0, "background": (1, 2, 3), "params": {"threshold_y": 48}, "width": None}
    text = json.dumps({"version": depixel.__version__, **options}, sort_keys=True, default=str)
    assert options_stamp(**options) == hashlib.sha256(text.encode("utf-8")).hexdigest()[:16]
    assert options_stamp(**{**options, "scale": 3.0}) != options_stamp(**options)
