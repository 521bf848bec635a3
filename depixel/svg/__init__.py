"""Output — a :class:`~depixel.vector.VectorImage` → SVG text of stacked or cut-out shapes.

:mod:`.outlines` builds the shapes (:mod:`.boundaries`, :mod:`.loops`, :mod:`.holes`,
:mod:`.stacking`), :mod:`.simplify` and :mod:`.curvefit` replace the exact spline by fewer
cubics within a tolerance, :mod:`.writer` and :mod:`.svgtext` write the text.
"""


def __getattr__(name: str):
    """Submodules load on first use (:func:`depixel.load_submodule`)."""
    import depixel  # noqa: PLC0415 (an attribute read while depixel itself imports is a plain miss)

    return depixel.load_submodule(__name__, name)
