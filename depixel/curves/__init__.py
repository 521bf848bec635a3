"""Paper §3.3 — the cell graph → quadratic B-spline curves along its visible edges.

:mod:`.pairing` pairs the visible edges at every node and chains them, :mod:`.splines` gives
the :class:`~depixel.curves.splines.SplineSet` (curves, control points, their drawing) and
:mod:`.bspline` the curve maths every later stage shares.
"""


def __getattr__(name: str):
    """Submodules load on first use (:func:`depixel.load_submodule`)."""
    import depixel  # noqa: PLC0415 (an attribute read while depixel itself imports is a plain miss)

    return depixel.load_submodule(__name__, name)
