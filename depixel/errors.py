"""Exceptions the library raises for problems a user can fix (bad input, bad options).

Each message is one line and names the file or option concerned, so a front end can print
it as is.
"""
from __future__ import annotations

import os


class DepixelError(Exception):
    """Base class: a problem with the user's input or options, not a bug."""


class InputError(DepixelError):
    """The input image cannot be read or is not acceptable (missing, corrupt, too large)."""


class OutputError(DepixelError):
    """The output cannot be written (missing folder, no permission, would overwrite input)."""


class RenderError(DepixelError):
    """Rasterizing an SVG failed (cairo missing, SVG unreadable)."""


def display_name(path: str | os.PathLike) -> str:
    """A path as shown in a one-line message: control characters and undecodable bytes
    (surrogate escapes) are written as Python escapes, so a hostile file name cannot break
    the line or the terminal."""
    text = os.fspath(path)
    if isinstance(text, bytes):
        text = os.fsdecode(text)
    return text if text.isprintable() else ascii(text)[1:-1]
