"""depixel's version: the one place it is written (pyproject.toml reads it from here, and every
output's options stamp includes it, so a new release reconverts stamped outputs)."""

__version__ = "0.1.0"
