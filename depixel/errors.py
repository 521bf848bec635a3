"""Exceptions the library raises for problems a user can fix (bad input, bad options).

Each message is one line and names the file or option concerned, so a front end can print
it as is.
"""
from __future__ import annotations


class DepixelError(Exception):
    """Base class: a problem with the user's input or options, not a bug."""


class InputError(DepixelError):
    """The input image cannot be read or is not acceptable (missing, corrupt, too large)."""


class OutputError(DepixelError):
    """The output cannot be written (missing folder, no permission, would overwrite input)."""


class RenderError(DepixelError):
    """Rasterizing an SVG failed (cairo missing, SVG unreadable)."""
