"""Exceptions the library raises for problems a user can fix (bad input, bad options).

Each message is one line and names the file or option concerned, so a front end can print
it as is. An error caused by a limit or a parameter names the library parameter
(``max_pixels``) in its message and in :attr:`DepixelError.parameter`; a front end that
calls the parameter something else (the CLI's ``--max-pixels``) rewrites that name with
:meth:`DepixelError.message_for`.
"""
from __future__ import annotations

import os
from collections.abc import Mapping


class DepixelError(Exception):
    """Base class: a problem with the user's input or options, not a bug.

    ``parameter`` is the library parameter that raises the limit or holds the bad value,
    when there is one; the message names it.
    """

    def __init__(self, message: str, *, parameter: str | None = None) -> None:
        super().__init__(message)
        self.parameter = parameter

    def message_for(self, names: Mapping[str, str]) -> str:
        """The message with the parameter's name replaced by what ``names`` calls it
        (e.g. ``{"max_pixels": "--max-pixels"}``); unchanged when it has no such name."""
        text, parameter = str(self), self.parameter
        alias = names.get(parameter) if parameter else None
        if not parameter or not alias or parameter not in text:
            return text
        head, _, tail = text.rpartition(parameter)
        return head + alias + tail


class InputError(DepixelError):
    """The input image cannot be read or is not acceptable (missing, corrupt, too large)."""


class OutputError(DepixelError):
    """The output cannot be written (missing folder, no permission, would overwrite input)."""


class RenderError(DepixelError):
    """Rasterizing an SVG failed (cairo missing, SVG unreadable)."""


class ParameterError(DepixelError, ValueError):
    """A parameter or option has a value the library cannot use (also a ValueError)."""


def report_text(text: str | os.PathLike) -> str:
    """A file name (or a message holding one) as reports write it (JSON, JUnit, HTML): each
    byte of the name that was not UTF-8 (held as a surrogate escape, U+DC80-U+DCFF, by
    ``os.fsdecode``) written as ``\\xNN``, any other lone surrogate as ``\\udNNN``, so the
    text is valid Unicode that every encoder writes and a reader sees where the bytes were."""
    text = os.fspath(text)
    if isinstance(text, bytes):
        text = os.fsdecode(text)
    if not any("\ud800" <= c <= "\udfff" for c in text):
        return text
    return "".join(f"\\x{ord(c) - 0xDC00:02x}" if "\udc80" <= c <= "\udcff" else
                   f"\\u{ord(c):04x}" if "\ud800" <= c <= "\udfff" else c for c in text)


def display_name(path: str | os.PathLike) -> str:
    """A path as shown in a one-line message: undecodable bytes as :func:`report_text`
    writes them, control characters as Python escapes, so a hostile file name cannot break
    the line or the terminal."""
    text = report_text(path)
    return text if text.isprintable() else ascii(text)[1:-1]
