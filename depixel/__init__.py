"""depixel: turn pixel art into smooth, resolution-independent SVG.

Implements Kopf & Lischinski, "Depixelizing Pixel Art" (SIGGRAPH 2011). The pipeline is
in :mod:`depixel.pipeline`; each stage is a subpackage (:mod:`depixel.prepare`,
:mod:`depixel.graph`, :mod:`depixel.curves`, :mod:`depixel.optimize`, :mod:`depixel.svg`,
:mod:`depixel.render`), with files in and out in :mod:`depixel.files`.
"""
from __future__ import annotations

import importlib
import importlib.util
from types import ModuleType

from .api import convert, convert_bytes, flatten, prepare_input
from .errors import DepixelError, InputError, OutputError, ParameterError, RenderError
from .files.convert import convert_file, render_file
from .params import Params
from .pipeline import STAGES, Result, depixelize
from .prepare.image import load_image
from .prepare.inputs import PreparedImage
from .svg.writer import to_svg
from .version import __version__

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


def load_submodule(package: str, name: str) -> ModuleType:
    """The submodule ``package.name``, imported on first use: after ``import depixel`` alone,
    ``depixel.diff.compare`` or ``depixel.render.figure`` work as docs/api.md writes them,
    without every start of the command paying for modules it does not use. A name that is no
    submodule (or is private) raises ``AttributeError``, as a missing attribute does."""
    if not name.startswith("_") and importlib.util.find_spec(f"{package}.{name}") is not None:
        return importlib.import_module(f"{package}.{name}")
    raise AttributeError(f"module {package!r} has no attribute {name!r}")


def __getattr__(name: str) -> ModuleType:
    return load_submodule(__name__, name)
