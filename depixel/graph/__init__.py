"""Paper §3.1-3.2 — RGBA pixels → the similarity graph, its crossings resolved → the reshaped cells.

:mod:`.similarity` links similar neighbours (YUV thresholds), :mod:`.crossings` keeps one
diagonal of each crossing (curves, sparse pixels, islands), :mod:`.cells` reshapes the pixel
cells into the cell graph (quarter-pixel nodes); :mod:`.components` holds the graph kernels.
"""


def __getattr__(name: str):
    """Submodules load on first use (:func:`depixel.load_submodule`)."""
    import depixel  # noqa: PLC0415 (an attribute read while depixel itself imports is a plain miss)

    return depixel.load_submodule(__name__, name)
