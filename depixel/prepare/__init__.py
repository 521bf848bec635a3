"""Input — before the paper: an image file or array → the 1× RGBA pixel art the pipeline takes.

Loads and checks images (:mod:`.image`, decoding with :mod:`.pillow`), finds the grid of art saved upscaled
(:mod:`.pixelgrid`), snaps lossy colours to a palette (:mod:`.palette`, :mod:`.chroma`,
:mod:`.chroma_unmix`) and makes a backdrop transparent (:mod:`.backdrop`); :mod:`.inputs`
runs them and gives a :class:`~depixel.prepare.inputs.PreparedImage`. :mod:`.aseprite` reads
Aseprite files, :mod:`.animation` an animation's frames with their timing (:mod:`.gif`,
:mod:`.apng`), :mod:`.sheet` and :mod:`.sheet_json` find a sprite sheet's sprites.
"""

#: its modules, each imported on first use (``depixel/__init__.py``)
__all__ = ["animation", "apng", "aseprite", "aseprite_compose", "aseprite_format", "backdrop", "chroma",
           "chroma_unmix", "gif", "image", "inputs", "noisy", "palette", "pillow", "pixelgrid", "sheet", "sheet_json"]
