"""Paper §3.4 — splines → optimized splines: corners kept, staircasing relaxed away.

:mod:`.corners` finds the corners of Figure 7, :mod:`.straight` puts constant-slope staircases on
their line, :mod:`.relax` moves the control points to lower
|curvature| + ‖p − p̂‖⁴, :mod:`.harmonic` lets the other nodes follow, :mod:`.fidelity` keeps
pixel centres inside their cells; :mod:`.stage` runs them (:class:`~depixel.optimize.stage.OptimizedSplines`),
:mod:`.pack` for many images' curves at once (their relaxation in one pass).
"""

#: its modules, each imported on first use (``depixel/__init__.py``)
__all__ = ["corners", "energy", "fidelity", "harmonic", "joined", "junctions", "pack", "relax", "stage", "straight",
           "trials", "walkback"]
