"""Paper §3.5 and pictures — vector images → pixels.

:mod:`.shading` is the paper's smooth renderer (truncated Gaussians per region), :mod:`.raster`
renders any SVG through cairosvg, :mod:`.overlay` lays a conversion over its upscaled input and
:mod:`.figure` draws every stage in one picture (``depixel inspect``).
"""


def __getattr__(name: str):
    """Submodules load on first use (:func:`depixel.load_submodule`)."""
    import depixel  # noqa: PLC0415 (an attribute read while depixel itself imports is a plain miss)

    return depixel.load_submodule(__name__, name)
