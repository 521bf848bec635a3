"""Read-only arrays for the frozen products the stages pass on."""
from __future__ import annotations

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
