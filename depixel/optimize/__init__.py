"""Paper §3.4 — splines → optimized splines: corners kept, staircasing relaxed away.

:mod:`.corners` finds the corners of Figure 7, :mod:`.relax` moves the control points to lower
|curvature| + ‖p − p̂‖⁴, :mod:`.harmonic` lets the other nodes follow, :mod:`.fidelity` keeps
pixel centres inside their cells; :mod:`.stage` runs them (:class:`~depixel.optimize.stage.OptimizedSplines`).
"""


def __getattr__(name: str):
    """Submodules load on first use (:func:`depixel.load_submodule`)."""
    import depixel  # noqa: PLC0415 (an attribute read while depixel itself imports is a plain miss)

    return depixel.load_submodule(__name__, name)
