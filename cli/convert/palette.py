"""``depixel convert``'s palettes: an Aseprite input's names its swatches, and ``--export-palette``."""
from __future__ import annotations

import argparse

from depixel.errors import DepixelError
from depixel.options import ConvertOptions

from ..options import error_message
from .inputs import expand_inputs

__all__ = ["export_palette"]


def export_palette(args: argparse.Namespace, options: ConvertOptions, frames: str | int) -> str | None:
    """``--export-palette OUT.gpl``: the palette of the one input's conversion (of its frame
    N, else its first), or the error's line."""
    from depixel.files.palette import export_palette as write  # noqa: PLC0415

    found, problems = expand_inputs(args.inputs, args.recursive, exclude=args.out_dir,
                                    skip_outputs=args.out_dir is None)
    if problems or len(found) != 1:
        return f"--export-palette writes the palette of one input, not of {len(found)}"
    try:
        write(found[0][0], args.export_palette, options, frame=frames if isinstance(frames, int) else 0)
    except DepixelError as exc:
        return error_message(exc)
    return None
