"""Frozen dataclasses: read-only arrays and a one-line repr for the products the stages pass
on; the fields of the options objects as a file's stamp digests them (:func:`stamp_fields`)."""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import field, fields
from typing import Any

import numpy as np


def freeze(product: Any) -> None:
    """Make every numpy array field of a dataclass instance read-only, so a stage cannot
    change what an earlier stage produced (writing raises ``ValueError``).

    Called from ``__post_init__``, when the instance's ``__dict__`` holds its fields and
    nothing else (the products have no ``__slots__``; a ``cached_property`` is stored there
    only later): reading it is a few µs cheaper a product than ``dataclasses.fields``."""
    for value in vars(product).values():
        if isinstance(value, np.ndarray):
            value.setflags(write=False)
        elif isinstance(value, tuple):  # NamedTuples of arrays
            for item in value:
                if isinstance(item, np.ndarray):
                    item.setflags(write=False)


def compact_repr(product: Any) -> str:
    """``Name(field=value, …)`` of a dataclass product with each array shown as its type and
    shape (``uint8[16, 18, 4]``) and each product inside it as ``Name(…)``: printing a result
    shows what it holds in a line, not thousands of numbers (the default dataclass repr
    prints every array whole)."""
    parts = [f"{f.name}={_short(getattr(product, f.name))}" for f in fields(product) if f.repr]
    return f"{type(product).__name__}({', '.join(parts)})"


def _short(value: Any) -> str:
    if isinstance(value, np.ndarray):
        return f"{value.dtype}[{', '.join(map(str, value.shape))}]"
    if type(value).__repr__ is compact_repr:
        return f"{type(value).__name__}(…)"
    if isinstance(value, tuple) and any(isinstance(item, np.ndarray) for item in value):
        items = ", ".join(_short(item) for item in value)
        return f"{type(value).__name__}({items})" if hasattr(value, "_fields") else f"({items})"
    if isinstance(value, (list, dict)) and len(value) > 8:
        return f"{type(value).__name__} of {len(value)}"
    return repr(value)


#: Metadata key of an options field added after the stamp's format was fixed: a rule
#: ``(options, value) -> bool`` saying when the field is left out of the digest.
LEFT_OUT = "left out of the stamp"


def added(default: Any, *, left_out: Callable[[Any, Any], bool] | None = None) -> Any:
    """The field of an option added after the stamp's format was fixed: left out of the
    options digest while it is at ``default`` (or whenever ``left_out(options, value)``), so
    an output stamped before the option existed is still up to date (docs/design.md, Options)."""
    rule = left_out or (lambda options, value: value == default)
    return field(default=default, metadata={LEFT_OUT: rule})


def stamp_fields(options: Any) -> dict[str, Any]:
    """Every field of the options dataclass ``options`` by name, as the stamp digests them:
    all of them, but an :func:`added` field its rule leaves out. A new field is in the digest
    unless it says otherwise."""
    digested = {}
    for item in fields(options):
        value = getattr(options, item.name)
        rule = item.metadata.get(LEFT_OUT)
        if rule is None or not rule(options, value):
            digested[item.name] = value
    return digested
