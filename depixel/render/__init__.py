"""Paper §3.5 and pictures — vector images → pixels.

:mod:`.shading` is the paper's smooth renderer (truncated Gaussians per region), :mod:`.raster`
renders any SVG through cairosvg (its embedded pictures decoded once: :mod:`.images`),
:mod:`.overlay` lays a conversion over its upscaled input and
:mod:`.figure` draws every stage in one picture (``depixel inspect``); :mod:`.animation` writes
rendered frames as an animated PNG.
"""

#: its modules, each imported on first use (``depixel/__init__.py``)
__all__ = ["animation", "figure", "images", "overlay", "raster", "references", "shading", "visibility"]
