"""Files in, files out — an image file → an SVG, PNG or PDF file, written safely and stamped.

:mod:`.convert` converts and renders file to file, :mod:`.output` writes atomically (never a
partial file, never over an input), :mod:`.stamp` records the options that made an output.
"""


def __getattr__(name: str):
    """Submodules load on first use (:func:`depixel.load_submodule`)."""
    import depixel  # noqa: PLC0415 (an attribute read while depixel itself imports is a plain miss)

    return depixel.load_submodule(__name__, name)
