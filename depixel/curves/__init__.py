"""Paper §3.3 — the cell graph → quadratic B-spline curves along its visible edges.

:mod:`.pairing` pairs the visible edges at every node and chains them, :mod:`.splines` gives
the :class:`~depixel.curves.splines.SplineSet` (curves, control points, their drawing) and
:mod:`.bspline` the curve maths every later stage shares.
"""

#: its modules, each imported on first use (``depixel/__init__.py``)
__all__ = ["bspline", "drawing", "pairing", "splines"]
