"""depixel: turn pixel art into smooth, resolution-independent SVG.

Implements Kopf & Lischinski, "Depixelizing Pixel Art" (SIGGRAPH 2011). The pipeline is
in :mod:`depixel.pipeline`; each stage is a subpackage (:mod:`depixel.prepare`,
:mod:`depixel.graph`, :mod:`depixel.curves`, :mod:`depixel.optimize`, :mod:`depixel.svg`,
:mod:`depixel.render`), with files in and out in :mod:`depixel.files`.
"""
from __future__ import annotations

import importlib
from types import ModuleType

from .api import convert, convert_bytes, cut_sheet, flatten, prepare_input
from .errors import DepixelError, InputError, OutputError, ParameterError, RenderError
from .files.convert import convert_file, render_file
from .params import Params
from .pipeline import STAGES, Result, depixelize
from .prepare.animation import Animation, read_animation
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
    "Animation",
    "read_animation",
    "to_svg",
    "convert",
    "convert_bytes",
    "convert_file",
    "cut_sheet",
    "flatten",
    "render_file",
    "read_aseprite",
    "tag_frames",
]
#: names of ``__all__`` imported on their first use: the Aseprite reader is ~15 ms of imports
#: that a conversion of any other file does not need
_ON_FIRST_USE = {"read_aseprite": "prepare.aseprite", "tag_frames": "prepare.aseprite"}


def __getattr__(name: str):
    if name in _ON_FIRST_USE:
        return getattr(importlib.import_module(f"{__name__}.{_ON_FIRST_USE[name]}"), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


#: The folders of the package (docs/design.md, Map); each lists its modules in its ``__all__``.
FOLDERS = ("prepare", "graph", "curves", "optimize", "svg", "render", "files", "diff")


def _load_on_first_use(package: ModuleType) -> None:
    """Give ``package`` (a folder) the module ``__getattr__`` and ``__dir__`` of PEP 562:
    ``package.NAME`` imports its module NAME, one of its ``__all__``, on first use, and
    ``dir(package)`` lists them all. So after ``import depixel`` alone every module is reachable
    by its dotted name, as docs/api.md writes them (``depixel.render.figure.figure``), and
    seen by ``dir()`` and IDEs (``__all__``), while the command imports only what it uses."""
    modules = frozenset(package.__all__)

    def __getattr__(name: str) -> ModuleType:
        if name in modules:
            return importlib.import_module(f"{package.__name__}.{name}")
        raise AttributeError(f"module {package.__name__!r} has no attribute {name!r}")

    def __dir__() -> list[str]:
        return sorted(set(vars(package)) | modules)

    setattr(package, "__getattr__", __getattr__)  # noqa: B010 (a module attribute, not a method)
    setattr(package, "__dir__", __dir__)  # noqa: B010


for _folder in FOLDERS:  # the folder faces hold no code: one mechanism, here, for all of them
    _load_on_first_use(importlib.import_module(f"{__name__}.{_folder}"))
del _folder
