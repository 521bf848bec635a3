"""``depixel diff``: two files, or two folders of renders (for CI), with reports.

The comparison, the pairing of folders, the reports and the baseline update are the
library's (:mod:`depixel.diff`); this module reads the options, runs the pairs ``-j`` at
a time with a progress bar (:mod:`depixel_cli.pool`, as ``convert``), prints the verdicts
and maps them to the exit code.
"""
from __future__ import annotations

import argparse
import json
import os
from pathlib import Path

from depixel.errors import display_name, report_text
from depixel.limits import DEFAULT_MAX_DIFF_PIXELS

from ..options import (
    FLAG_OF_PARAMETER,
    Exit,
    colour,
    non_negative_int,
    positive_float,
    positive_int,
    unit_float,
)
from ..streams import print_stdout

DESCRIPTION = """\
examples:
  depixel diff expected.svg actual.svg                 exit 0 same, 1 different, 2 error
  depixel diff sprite.svg sprite.png --diff-out d.png  SVG rendered at the PNG's size
  depixel diff sprite.svg sprite.png --scale 8         the SVG against the 1x pixel art, at 8x
  depixel diff a.svg b.svg --scale 4 --max-ratio 0.001 --json
  depixel diff baseline/ current/ --html report/ --junit diff.xml    folders, for CI
  depixel diff baseline/ current/ --update --prune     approve: the baseline becomes the current

Compare two images (SVG, PDF or PNG) the way a person would. Both are brought to one size
(a PNG's size, or the SVGs' own, times --scale; a PNG is enlarged by nearest neighbour, an
SVG rendered at that size), flattened over a background colour neither contains (default
magenta, so seams and alpha leaks show) and compared pixel by pixel with pixelmatch's YIQ
distance; anti-aliasing differences are ignored, except in an SVG or PDF drawn at under 3
pixels an art pixel, where every pixel counts (docs/cli.md says when a pixel counts as
anti-aliasing). The images are the same when no pixel differs, or when the differing pixels
are within either tolerance given.

Two folders: files are paired by relative path (a.png with a.svg when only the extension
differs); each pair is same, different, missing (only in BASELINE), new (only in CURRENT)
or error. Exit 0 when all are same (new/missing accepted with --allow-new/--allow-missing),
1 when any is not, 2 when nothing could be compared.
"""


def add_parser(sub, name: str, help: str) -> None:
    """Define the subcommand ``name`` (diff) with its arguments."""
    from ..convert.command import jobs_option  # noqa: PLC0415

    diff = sub.add_parser(name, help=help, description=DESCRIPTION,
                          formatter_class=argparse.RawDescriptionHelpFormatter)
    diff.set_defaults(run=run_diff, parser=diff)
    diff.add_argument("a", metavar="A", help="SVG, PDF or PNG; or the baseline folder")
    diff.add_argument("b", metavar="B", help="SVG, PDF or PNG; or the current folder")
    diff.add_argument("--scale", type=positive_float, default=1.0,
                      help="compare at this multiple of the size: a PNG is enlarged by nearest neighbour, an "
                           "SVG rendered to match (default 1: the PNG's size, or the SVGs' own)")
    diff.add_argument("--threshold", type=unit_float, default=0.1, metavar="T",
                      help="colour distance (0-1) above which two pixels differ: pixelmatch's threshold, "
                           "a YIQ distance over 35215*T^2 (default 0.1, as pixelmatch)")
    diff.add_argument("--max-pixels-diff", type=non_negative_int, metavar="N",
                      help="same if at most N pixels differ")
    diff.add_argument("--max-ratio", type=unit_float, metavar="R",
                      help="same if at most this fraction of the pixels differs (with --max-pixels-diff: "
                           "within either bound; with neither: no pixel may differ)")
    diff.add_argument("--max-pixels", type=positive_int, default=DEFAULT_MAX_DIFF_PIXELS, metavar="N",
                      help=f"refuse to compare images larger than this (default {DEFAULT_MAX_DIFF_PIXELS})")
    diff.add_argument("--background", type=colour, metavar="COLOR",
                      help="flatten both over this colour (default: magenta, or another colour neither image has)")
    diff.add_argument("--include-aa", action="store_true",
                      help="count every pixel over the threshold, anti-aliasing too")
    diff.add_argument("--mask", action="append", default=[], metavar="X,Y,W,H|IMAGE",
                      help="ignore a rectangle (in the pixels of the images at --scale 1), or the light pixels "
                           "of a mask image stretched to the comparison; repeatable")
    diff.add_argument("--allow-size-mismatch", action="store_true",
                      help="compare images of different sizes (the area only one covers counts)")
    diff.add_argument("--diff-out", metavar="PNG|DIR",
                      help="write a picture of the differences (red; yellow: anti-aliasing): a .png file, or "
                           "for folders a folder of NAME.diff.png")
    diff.add_argument("--json", action="store_true", help="print the report as JSON on stdout")
    folders = diff.add_argument_group("folders")
    folders.add_argument("--html", metavar="DIR",
                         help="write a report to read in a browser: DIR/index.html and its pictures")
    folders.add_argument("--junit", metavar="FILE", help="write a JUnit XML report (one testcase per file)")
    folders.add_argument("--allow-new", action="store_true", help="files only in CURRENT do not fail")
    folders.add_argument("--allow-missing", action="store_true", help="files only in BASELINE do not fail")
    folders.add_argument("--update", action="store_true",
                         help="copy the current files that differ, and the new ones, over the baseline")
    folders.add_argument("--prune", action="store_true", help="with --update: remove the missing files too")
    folders.add_argument("-j", "--jobs", type=jobs_option, default="auto", metavar="N|auto",
                         help="pairs compared in parallel (default auto: one per core)")
    diff.add_argument("--debug", action="store_true", default=argparse.SUPPRESS,
                      help="show the full traceback on errors")


def run_diff(args: argparse.Namespace) -> int:
    folders = [os.path.isdir(path) for path in (args.a, args.b)]
    if folders[0] != folders[1]:
        folder, other = (args.a, args.b) if folders[0] else (args.b, args.a)
        args.parser.error(f"{display_name(folder)} is a folder but {display_name(other)} is not: "
                          "compare two files or two folders")
    if folders[0]:
        from .folders import run_folders  # noqa: PLC0415

        return run_folders(args, settings(args))
    given = [flag for flag, on in (("--html", args.html), ("--junit", args.junit), ("--update", args.update),
                                   ("--prune", args.prune), ("--allow-new", args.allow_new),
                                   ("--allow-missing", args.allow_missing)) if on]
    if given:
        args.parser.error(f"{given[0]} compares folders: give two folders")
    return _files(args)


def settings(args: argparse.Namespace):
    """The library's comparison settings from the options."""
    from depixel.diff.pairs import Settings  # noqa: PLC0415

    return Settings(scale=args.scale, threshold=args.threshold, background=args.background,
                    allow_size_mismatch=args.allow_size_mismatch, include_antialiasing=args.include_aa,
                    max_pixels=args.max_pixels, max_pixels_diff=args.max_pixels_diff, max_ratio=args.max_ratio,
                    mask=_mask(args), names=FLAG_OF_PARAMETER)


def _mask(args: argparse.Namespace):
    """``--mask`` values: rectangles, and at most one image."""
    from depixel.diff.mask import Mask, parse_rectangle, read_mask_image  # noqa: PLC0415
    from depixel.errors import DepixelError  # noqa: PLC0415

    rectangles, images = [], []
    for value in args.mask:
        if "," in value and not os.path.exists(value):
            try:
                rectangles.append(parse_rectangle(value))
            except DepixelError as exc:
                args.parser.error(f"--mask: {exc}")
        else:
            images.append(value)
    if len(images) > 1:
        args.parser.error("--mask: give at most one mask image (rectangles may be repeated)")
    mask = read_mask_image(images[0]) if images else Mask()
    return Mask(tuple(rectangles), mask.image, mask.image_name)


def _files(args: argparse.Namespace) -> int:
    """Two files: one verdict, as a line or JSON."""
    from depixel.diff.compare import within  # noqa: PLC0415
    from depixel.diff.pairs import diff_files  # noqa: PLC0415

    from ..tools import _png, _write  # noqa: PLC0415

    if args.diff_out == "-" and args.json:
        args.parser.error("--diff-out - and --json both write to stdout: write the picture to a file "
                          "(--diff-out d.png)")
    if args.diff_out is not None and args.diff_out != "-" and Path(args.diff_out).suffix.lower() != ".png":
        args.parser.error(f"--diff-out {display_name(args.diff_out)}: the picture of the differences is a PNG; "
                          "name it .png")
    chosen = settings(args)
    comparison, background = diff_files(args.a, args.b, chosen)
    count, ratio = comparison.different_pixels, comparison.ratio
    same = within(comparison, args.max_pixels_diff, args.max_ratio)
    if args.diff_out:
        _write(args.diff_out, _png(comparison.diff_image()), protect=(Path(args.a), Path(args.b)))
    h, w = comparison.different.shape
    total = comparison.compared_pixels
    if args.json:
        report = {
            "a": report_text(args.a), "b": report_text(args.b), "same": same, "width": w, "height": h,
            "different_pixels": count, "antialiased_pixels": int(comparison.antialiased.sum()),
            "total_pixels": total, "ratio": ratio, "threshold": args.threshold,
            "max_pixels_diff": args.max_pixels_diff, "max_ratio": args.max_ratio,
            "background": "#{:02x}{:02x}{:02x}".format(*background),
            "diff_out": args.diff_out and report_text(args.diff_out),
        }
        if w * h != total:
            report["ignored_pixels"] = w * h - total
        print_stdout(json.dumps(report, indent=2))
    else:
        verdict = "same" if same else "different"
        masked = f", {w * h - total} masked" if w * h != total else ""
        print_stdout(f"{verdict}: {count} of {total} pixels differ ({100 * ratio:.3g}%) at {w}x{h}, "
                     f"threshold {args.threshold}{masked}")
    return Exit.OK if same else Exit.FAILED
