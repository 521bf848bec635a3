"""Files in, files out — an image file → an SVG, PNG or PDF file, written safely and stamped.

:mod:`.convert` converts and renders file to file, :mod:`.output` writes atomically (never a
partial file, never over an input), :mod:`.stamp` records the options that made an output;
:mod:`.sheet` converts a sprite sheet a sprite at a time.
"""

#: its modules, each imported on first use (``depixel/__init__.py``)
__all__ = ["convert", "output", "sheet", "stamp"]
