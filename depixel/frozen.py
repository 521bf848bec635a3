"""Read-only arrays for the frozen products the stages pass on."""
from __future__ import annotations

from dataclasses import fields
from typing import Any

import numpy as np


def freeze(product: Any) -> None:
    """Make every numpy array field of a dataclass instance read-only, so a stage cannot
    change what an earlier stage produced (writing raises ``ValueError``)."""
    for f in fields(product):
        value = getattr(product, f.name)
        if isinstance(value, np.ndarray):
            value.setflags(write=False)
        elif isinstance(value, tuple):  # NamedTuples of arrays
            for item in value:
                if isinstance(item, np.ndarray):
                    item.setflags(write=False)
