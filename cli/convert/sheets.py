"""``depixel convert``'s options for sprite sheets and Aseprite files: ``--sheet``,
``--sheet-json``, ``--tag`` (docs/inputs.md, "Sprite sheets" and "Aseprite files"; docs/animation.md,
"Aseprite tags").

Its own module so that the command's module stays the command; the library does the work
(:func:`depixel.prepare.sheet.sheet_of`, :func:`depixel.api.sheet_conversions`,
:func:`depixel.prepare.aseprite.tag_frames`), the batch names the outputs
(:mod:`depixel_cli.convert.inputs`: ``{sprite}``, :func:`depixel_cli.convert.batch.chosen_frames`;
an animation's tags: :mod:`depixel_cli.convert.tags`).
"""
from __future__ import annotations

import argparse
from functools import partial

import numpy as np

from depixel import api
from depixel.errors import ParameterError
from depixel.files.convert import InputFile
from depixel.options import ConvertOptions
from depixel.prepare.animation import Animation
from depixel.prepare.inputs import lossy_format

from .batch import Outcome, record_prepared
from .inputs import uses


def sheet_option(text: str) -> str:
    """``--sheet``: auto or a grid, WxH[+GAP[,GAPY]][@X,Y]."""
    from depixel.prepare.sheet import sheet_spec  # noqa: PLC0415 (only for a sheet)

    try:
        return sheet_spec(text)
    except ParameterError as exc:
        raise argparse.ArgumentTypeError(str(exc).replace("sheet grid ", "", 1)) from None


def add_sheet_options(parser: argparse.ArgumentParser) -> None:
    """The group of --sheet, --sheet-json and --tag."""
    sheets = parser.add_argument_group("sprite sheets and Aseprite files (docs/inputs.md)")
    sheets.add_argument("--sheet", type=sheet_option, metavar="auto|WxH[+GAP][@X,Y]",
                        help="the input is a sprite sheet, each sprite converted alone: auto finds the sprites "
                             "(cells between transparent or one-colour gutters, else each connected sprite), WxH "
                             "cuts a grid of W x H cells (+GAP or +GAPX,GAPY pixels between cells, @X,Y the first "
                             "cell's corner); empty cells are skipped. -o FILE writes one file with a layer per "
                             "sprite at its place; --out-dir or beside the input, a file per sprite, "
                             "{stem}-{sprite}.svg (sprites r0c0, r0c1, ... of a grid; --name without {sprite}: "
                             "the layered file)")
    sheets.add_argument("--sheet-json", metavar="FILE",
                        help="like --sheet, with the sprites placed by the JSON Aseprite or TexturePacker wrote "
                             "beside the sheet (hash or array); each sprite named after its frame, without the "
                             "extension")
    sheets.add_argument("--tag", metavar="NAME",
                        help="an Aseprite file's tag: with --animate, one file that plays it as Aseprite does (its "
                             "direction and repeat count; without --tag, --animate writes a file per tag, "
                             "{stem}-{tag}.svg, or FILE-{tag}.svg for -o FILE); with --frames all, its frames "
                             "(each once, named by frame number); else the first frame it plays")


def check_sheet_options(args: argparse.Namespace) -> None:
    """Refuse what --sheet, --sheet-json and --tag cannot do together (usage errors)."""
    parser, sheet = args.parser, args.sheet is not None or args.sheet_json is not None
    if args.sheet is not None and args.sheet_json is not None:
        parser.error("give --sheet or --sheet-json, not both (the JSON places the sprites itself)")
    if sheet and args.frames == "all":
        parser.error("--sheet cuts one image into sprites: pick its frame with --frames N, not all")
    if args.sheet_json is not None and len(args.inputs) > 1:
        parser.error("--sheet-json FILE places the sprites of one sheet: give that sheet alone")
    if args.name is not None and uses(args.name, "sprite") and not sheet:
        parser.error("--name's {sprite} names the sprites of --sheet or --sheet-json: give one of them")
    if args.tag is not None and sheet:
        parser.error("--tag picks frames of an Aseprite file; a sheet's sprites are cut from one frame")
    if args.name is not None and uses(args.name, "tag") and args.tag is None and not args.animate:
        parser.error("--name's {tag} names the outputs of an Aseprite file's tags: give --animate (a file per tag) "
                     "or --tag NAME")
    if args.tag is not None and args.frames not in ("first", "all"):
        parser.error("--frames N numbers the file's frames and --tag picks a tag's: give one of them")


def converted(image: np.ndarray | Animation, source: InputFile, fmt: str, options: ConvertOptions,
              out: Outcome) -> bytes:
    """``-o -``: one frame of ``source`` (or the animation, with ``animate``) as ``fmt``,
    unstamped; a sheet cut here, to say in ``out.notes`` what was found."""
    title, lossy = None if source.path is None else source.path.name, lossy_format(source.data)
    noted = partial(record_prepared, out, source=source.name, target="-")
    if not options.output.is_sheet or isinstance(image, Animation):  # (the options refuse animate with a sheet)
        return api.conversions(image, {fmt: None}, options, name=source.name, title=title, lossy=lossy,
                               on_prepared=noted)[fmt]
    from depixel.prepare.sheet import sheet_of  # noqa: PLC0415

    sheet = sheet_of(image, options.output.sheet, options.output.sheet_json, source.name)
    out.notes.append(f"{source.name}: {sheet.description}")
    return api.sheet_conversions(image, sheet, {fmt: None}, options, name=source.name, title=title, lossy=lossy,
                                 on_prepared=noted)[fmt]
