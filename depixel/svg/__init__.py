"""Output — a :class:`~depixel.vector.VectorImage` → SVG text of stacked or cut-out shapes.

:mod:`.outlines` builds the shapes (:mod:`.boundaries`, :mod:`.loops`, :mod:`.holes`, :mod:`.insets`,
:mod:`.runfit`, :mod:`.stacking`, :mod:`.lenses`), :mod:`.simplify` and :mod:`.curvefit` replace the
exact spline by fewer cubics within a tolerance (:mod:`.passes`: many images' at once), :mod:`.writer`
and :mod:`.svgtext` write the text (the smooth shading's groups: :mod:`.smoothgroups`,
:mod:`.markup`, :mod:`.hiding`), :mod:`.swatches` how the shapes are painted (palette swap,
Inkscape swatches). :mod:`.layers` puts several documents into one as layers (a sheet),
:mod:`.animation` frames into one animated SVG.
"""

#: its modules, each imported on first use (``depixel/__init__.py``)
__all__ = ["animation", "boundaries", "breaks", "curvefit", "hiding", "holes", "insets", "layers", "lenses", "loops",
           "markup", "outlines", "passes", "reference", "runfit", "simplify", "smoothgroups", "stacking", "svgtext",
           "swatches", "writer"]
