"""Input — before the paper: an image file or array → the 1× RGBA pixel art the pipeline takes.

Loads and checks images (:mod:`.image`), finds the grid of art saved upscaled
(:mod:`.pixelgrid`), snaps lossy colours to a palette (:mod:`.palette`, :mod:`.chroma`,
:mod:`.chroma_unmix`) and makes a backdrop transparent (:mod:`.backdrop`); :mod:`.inputs`
runs them and gives a :class:`~depixel.prepare.inputs.PreparedImage`.
"""


def __getattr__(name: str):
    """Submodules load on first use (:func:`depixel.load_submodule`)."""
    import depixel  # noqa: PLC0415 (an attribute read while depixel itself imports is a plain miss)

    return depixel.load_submodule(__name__, name)
