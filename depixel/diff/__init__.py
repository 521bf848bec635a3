"""Comparing renders — two SVG/PDF/PNG files, or two folders of them → verdicts (``depixel diff``).

:mod:`.compare` compares two images pixel by pixel (YIQ distance, anti-aliasing);
:mod:`.sources` reads and draws the files at one size (refusing what cannot be seen),
:mod:`.mask` the regions left out, :mod:`.pdf` PDF pages; :mod:`.pairs` gives one pair its
verdict and pictures; :mod:`.folders` pairs two folders; :mod:`.reports` (JSON, JUnit) and
:mod:`.html` report them, :mod:`.staging` writes report folders whole, :mod:`.update`
approves a change.
"""

#: its modules, each imported on first use (``depixel/__init__.py``)
__all__ = ["compare", "folders", "html", "mask", "pairs", "pdf", "reports", "sources", "staging", "update"]
