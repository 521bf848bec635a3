"""Paper §3.1-3.2 — RGBA pixels → the similarity graph, its crossings resolved → the reshaped cells.

:mod:`.similarity` links similar neighbours (YUV thresholds), :mod:`.crossings` keeps one
diagonal of each crossing (curves, sparse pixels, islands), :mod:`.cells` reshapes the pixel
cells into the cell graph (quarter-pixel nodes); :mod:`.components` holds the graph kernels.
"""

#: its modules, each imported on first use (``depixel/__init__.py``)
__all__ = ["cells", "components", "crossings", "similarity"]
