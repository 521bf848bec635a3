"""depixel: turn pixel art into smooth, resolution-independent SVG.

Implements Kopf & Lischinski, "Depixelizing Pixel Art" (SIGGRAPH 2011). The pipeline is
in :mod:`depixel.pipeline`; each stage has its own module.
"""
from __future__ import annotations

__version__ = "0.1.0"

from .api import convert, convert_bytes, convert_file, flatten, prepare_input, render_file
from .errors import DepixelError, InputError, OutputError, ParameterError, RenderError
from .image import load_image
from .params import Params
from .pipeline import STAGES, Result, depixelize
from .prepare import PreparedImage
from .svg import to_svg

__all__ = [
    "__version__",
    "DepixelError",
    "InputError",
    "OutputError",
    "ParameterError",
    "RenderError",
    "Params",
    "STAGES",
    "Result",
    "depixelize",
    "PreparedImage",
    "prepare_input",
    "load_image",
    "to_svg",
    "convert",
    "convert_bytes",
    "convert_file",
    "flatten",
    "render_file",
]
