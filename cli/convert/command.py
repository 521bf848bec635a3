"""``depixel convert``: one file (``-o FILE``, ``-`` for stdin/stdout) or many (``--out-dir DIR``)."""
from __future__ import annotations

import argparse
import json
import sys
import time
from dataclasses import replace
from pathlib import Path

from depixel import api
from depixel.errors import OutputError, display_name
from depixel.files import convert as files
from depixel.limits import DEFAULT_MAX_FRAMES, DEFAULT_MAX_OUTPUT_PIXELS, DEFAULT_MAX_PIXELS
from depixel.pipeline import STAGES
from depixel.svg.outlines import LAYOUTS
from depixel.svg.writer import DEFAULT_PRECISION, DEFAULT_SIMPLIFY

from ..options import (
    Exit,
    add_dask_options,
    add_input_options,
    add_tuning,
    check_input_options,
    colour,
    convert_options,
    int_range,
    positive_float,
    positive_int,
    tolerance,
)
from ..streams import print_stdout, stdin_closed
from .batch import (
    DONE,
    Job,
    Options,
    Outcome,
    kept_lines,
    summary,
    totals_line,
)
from .dry_run import preview
from .inputs import DEFAULT_NAME, SHEET_NAME, expand_inputs, make_folders, name_template, plan
from .prune import Pruned, prune_batch, with_pruned
from .run import Progress, Repeats, auto_jobs, cores, run
from .sheets import add_sheet_options, check_sheet_options
from .stream import convert_stream

DESCRIPTION = """\
examples:
  depixel convert sprite.png                            sprite.svg beside it (the paper's result)
  depixel convert sprite.png -o sprite.png --scale 8    rendered 8x as PNG (or .pdf)
  depixel convert icons/ -r --out-dir svg/ -j 4         a whole folder tree, 4 files at a time
  depixel convert 'art/*.gif' --out-dir out --frames all    every frame: name-000.svg, ...
  depixel convert walk.gif -o walk.svg --animate        one SVG that plays every frame (or .png: an APNG)
  depixel convert art/ --out-dir out --format svg,png --name '{stem}-{suffix}'   two formats
  cat sprite.png | depixel convert - -o - > sprite.svg  stdin to stdout
  depixel convert sprite.png -o cells.svg --stage cells     only the reshaped pixel cells
  depixel convert ghost_x4.jpg -o ghost.svg --transparent auto   upscaled JPEG on a backdrop
  depixel convert sheet.png --sheet auto -o sheet.svg   a sprite sheet: a layer per sprite
  depixel convert sheet.png --sheet 32x32+2 --out-dir out   a file per sprite: sheet-r0c0.svg, ...
  depixel convert hero.aseprite --tag walk --frames all --out-dir out   an Aseprite tag's frames

Convert pixel art to SVG, PNG or PDF (Kopf & Lischinski, Depixelizing Pixel Art, 2011).
Upscaled pixel art is detected and converted at 1x, the SVG laid over the input (same
width/height); JPEG noise is snapped to a palette (see the input options and docs/inputs.md).
The format comes from the output's extension (--format for a name without .svg/.png/.pdf;
a format that contradicts the extension is refused). Without -o and --out-dir, each output
is written beside its input (sprite.png -> sprite.svg); with --out-dir, outputs keep the
inputs' relative folders; an output made from the same input with the same options is up
to date and skipped (--force reconverts it). An existing output that depixel did not write
(no stamp) is kept, and one edited since depixel wrote it is kept and reported as an error,
unless --force (-o FILE too: it overwrites only what depixel wrote). A failed file is
reported and the rest go on; the exit code is 1 if any file failed, was edited or changed
while converted; a batch ends with a summary line on stderr (--dry-run: the same, writing
nothing). Ctrl-C (or SIGTERM) stops: no new file is started, files being converted are
abandoned without leaving partial files, what was done is reported (exit 130, or 143 for
SIGTERM); a second Ctrl-C exits at once.
"""


def frames_option(text: str) -> str | int:
    if text in ("first", "all"):
        return text
    try:
        return int_range(0)(text)
    except argparse.ArgumentTypeError:
        raise argparse.ArgumentTypeError(f"expected first, all or a frame number, not {text!r}") from None


def formats_option(text: str) -> tuple[str, ...]:
    """``--format``: one format or several, comma-separated (``svg,png``), each once."""
    formats = tuple(dict.fromkeys(part.strip().lower() for part in text.split(",")))
    unknown = [f for f in formats if f not in api.FORMATS]
    if unknown or not formats:
        raise argparse.ArgumentTypeError(f"{text!r}: choose from {', '.join(api.FORMATS)} (several: svg,png)")
    return formats


def template_option(text: str) -> str:
    try:
        return name_template(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def jobs_option(text: str) -> str | int:
    if text == "auto":
        return text
    try:
        return positive_int(text)
    except argparse.ArgumentTypeError:
        raise argparse.ArgumentTypeError(f"expected auto or a number of processes, not {text!r}") from None


def add_parser(sub, name: str, help: str) -> None:
    """Define the subcommand ``name`` (convert) with its arguments."""
    p = sub.add_parser(name, help=help, description=DESCRIPTION,
                       usage="%(prog)s INPUT... [-o FILE | --out-dir DIR] [options]",
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    p.set_defaults(run=run_convert, parser=p)
    p.add_argument("inputs", nargs="+", metavar="INPUT",
                   help="image files, folders or globs; - reads one image from stdin")
    out = p.add_argument_group("output (default: each output beside its input, sprite.png -> sprite.svg)")
    out.add_argument("-o", "--output", metavar="FILE", help="output file for a single input; - writes to stdout")
    out.add_argument("--out-dir", metavar="DIR", type=Path,
                     help="folder for the outputs, at the inputs' relative places")
    out.add_argument("--format", type=formats_option, metavar="svg|png|pdf[,...]",
                     help="output format (default: from -o's extension, else svg); must agree with a "
                          ".svg/.png/.pdf name; several, comma-separated, write one output of each (without -o)")
    out.add_argument("--name", type=template_option, metavar="TEMPLATE",
                     help="name of each output without -o, the format's extension added: {stem} (the "
                          "input's name without extension, the default), {suffix} (its extension without the "
                          "dot), {frame} (the frame number, 000, 001, ...), {sprite} (with --sheet: a file per "
                          "sprite, its name; the default there is {stem}-{sprite}); e.g. --name '{stem}-{suffix}'")
    size = out.add_mutually_exclusive_group()
    size.add_argument("--scale", type=positive_float, default=1.0,
                      help="size as a multiple of the input's size: SVG width/height, PNG pixels, PDF size "
                           "(default 1)")
    size.add_argument("--width", type=positive_int, metavar="W",
                      help="output width in pixels (SVG width, PNG pixels), height to match")
    size.add_argument("--height", type=positive_int, metavar="H", help="output height in pixels, width to match")
    out.add_argument("--background", type=colour, metavar="COLOR",
                     help="flatten the image onto this colour first (#rgb, #rrggbb or a name like white)")
    out.add_argument("--shading", choices=api.SHADINGS, default="smooth",
                     help="smooth (default): the paper's edge-aware smooth shading (SVG: a blur filter inside "
                          "each shaded region; PNG: the paper's renderer); flat: flat colour bands")
    out.add_argument("--frames", type=frames_option, default="first", metavar="first|all|N",
                     help="frames of an animated image: the first (default), all (name-000.svg, ...) or frame N")
    out.add_argument("--animate", action="store_true",
                     help="every frame of an animated GIF, APNG, WebP or Aseprite file in one output, in the file's "
                          "timing: an SVG with a layer a frame that plays in browsers (other renderers show the "
                          "first), or an animated PNG; a still image is its one frame (no PDF)")
    out.add_argument("--stage", choices=STAGES, default="optimized",
                     help="stop at this pipeline stage (default: optimized, the final result)")
    out.add_argument("--precision", type=int_range(0, 12), default=DEFAULT_PRECISION, metavar="N",
                     help=f"decimals of the numbers in the SVG (default {DEFAULT_PRECISION})")
    out.add_argument("--layout", choices=LAYOUTS, default="stacked",
                     help="SVG shapes: stacked (default), each drawn over the ones it lies on and continuing "
                          "under the ones above it, as an illustrator layers them; or cutout, shapes that tile "
                          "the image exactly (renderers that anti-alias each shape show faint seams)")
    out.add_argument("--simplify", type=tolerance, default=DEFAULT_SIMPLIFY, metavar="TOL",
                     help=f"fit fewer curves within TOL pixels of the exact spline, keeping corners, straight "
                          f"runs, every pixel centre in its colour and every thin diagonal (default "
                          f"{DEFAULT_SIMPLIFY}; 0 writes the exact spline, one quadratic per span)")
    out.add_argument("--max-pixels", type=positive_int, default=DEFAULT_MAX_PIXELS, metavar="N",
                     help=f"refuse larger images, frames or pages (default {DEFAULT_MAX_PIXELS}; pixel art is small)")
    out.add_argument("--max-output-pixels", type=positive_int, default=DEFAULT_MAX_OUTPUT_PIXELS, metavar="N",
                     help=f"refuse larger PNG outputs (default {DEFAULT_MAX_OUTPUT_PIXELS})")
    out.add_argument("--max-frames", type=positive_int, default=DEFAULT_MAX_FRAMES, metavar="N",
                     help=f"refuse animations of more frames with --frames all, and frame numbers from N on "
                          f"(default {DEFAULT_MAX_FRAMES}); --max-pixels counts the frames' pixels in all")
    add_sheet_options(p)
    batch = p.add_argument_group("many files")
    batch.add_argument("-r", "--recursive", action="store_true", help="also convert the images in subfolders")
    batch.add_argument("--force", action="store_true",
                       help="reconvert every file, and overwrite outputs that depixel did not write or that were "
                            "edited since (default: skip outputs made from the same input with the same options, "
                            "keep the others)")
    batch.add_argument("--prune", action="store_true",
                       help="with --out-dir DIR: remove the outputs there whose inputs are gone (files depixel wrote, "
                            "unedited, of the run's formats; -r: in all subfolders), so that DIR mirrors its "
                            "inputs; give the --name and --format of the runs that made DIR")
    batch.add_argument("-n", "--dry-run", action="store_true",
                       help="list what would be converted, what is up to date and what would be kept, on stdout; "
                            "write nothing")
    batch.add_argument("-j", "--jobs", type=jobs_option, default="auto", metavar="N|auto",
                       help=f"files converted in parallel (default auto: one per core, {cores()} here); auto or N, "
                            "fewer when the largest image would not fit in the available memory that many times")
    add_dask_options(batch)
    batch.add_argument("--json", action="store_true",
                       help="print a JSON summary on stdout (files, ok, skipped, failed with reasons, every output "
                            "with its status, what the input preparation found, interrupted, seconds)")
    batch.add_argument("-q", "--quiet", action="store_true", help="no notes on stderr (errors are still shown)")
    add_input_options(p)
    add_tuning(p)
    p.add_argument("--debug", action="store_true", default=argparse.SUPPRESS,
                   help="show the full traceback on errors")


def run_convert(args: argparse.Namespace) -> int:
    parser = args.parser
    formats = _check_destination(args)
    options = Options(convert_options(args), formats, args.frames, force=args.force, tag=args.tag)

    start = time.perf_counter()
    signals = args.signals
    args.repeats = Repeats()
    if args.inputs == ["-"] or args.output == "-":
        outcome = convert_stream(args.inputs[0], args.output, options)
        _report(outcome, Progress(0), args)
        outcomes = [outcome]
    elif args.output is not None:
        found, problems = expand_inputs(args.inputs, args.recursive)
        if problems or len(found) != 1:
            parser.error(problems[0][1] if problems else f"-o takes one input, not {len(found)}; use --out-dir DIR "
                         "for several (or neither: each output is written beside its input)")
        # an explicitly named output is written even when up to date; its frames are counted by the job
        job = Job(found[0][0], Path(args.output), replace(options, explicit=True), frames=0)
        if args.dry_run:
            outcomes = [preview(job)]
            _list_planned(outcomes, args)
        else:
            outcomes = run([job], 1, lambda o: _report(o, Progress(0), args), signals)
    else:
        outcomes = _convert_batch(args, options)
    seconds = time.perf_counter() - start
    interrupted = signals.signum is not None
    pruned: Pruned | None = getattr(args, "pruned", None)
    if args.json:
        print_stdout(json.dumps(with_pruned(summary(outcomes, seconds, interrupted, args.dry_run), pruned,
                                            args.dry_run), indent=2))
    if (args.output is None and not args.quiet) or interrupted:  # every batch, in a terminal or a log
        extra = [] if pruned is None else pruned.totals(args.dry_run)
        print(f"depixel: {totals_line(outcomes, seconds, interrupted, args.dry_run, extra)}", file=sys.stderr)
    if interrupted:
        return 128 + signals.signum
    # a file not done in a batch that was not interrupted: a --dask batch stopped (no worker, scheduler lost)
    failed = pruned is not None and pruned.failed()
    return Exit.FAILED if failed or any(o.error or o.edited or o.changed or o.state != DONE for o in outcomes) else \
        Exit.OK


def _check_destination(args: argparse.Namespace) -> tuple[str, ...]:
    """Refuse contradictory destinations (usage errors); the output formats."""
    parser = args.parser
    if args.output is not None and args.out_dir is not None:
        parser.error("give either -o FILE (one input) or --out-dir DIR (many), not both")
    if "-" in args.inputs and (len(args.inputs) > 1 or args.output is None):
        parser.error("- (stdin) must be the only input, with -o FILE or -o -")
    if "-" in args.inputs and stdin_closed():
        parser.error("- reads the image from standard input, which is closed")
    if args.output == "-" and (args.frames == "all" or args.json):
        parser.error("-o - writes one image to stdout: no --frames all or --json with it")
    if args.animate and args.frames != "first":
        parser.error(f"--animate writes every frame into one file; --frames {args.frames} picks frames for a file "
                     "each: give one of them")
    if args.dry_run and (args.output == "-" or "-" in args.inputs):
        parser.error("--dry-run looks at output files: not with - (stdin or stdout)")
    if args.prune and args.out_dir is None:
        parser.error("--prune removes the outputs in --out-dir DIR whose inputs are gone: give --out-dir DIR")
    if args.out_dir is not None and args.out_dir.exists() and not args.out_dir.is_dir():
        parser.error(f"--out-dir {display_name(args.out_dir)}: is a file, not a folder")
    if args.dask is not None and args.output is not None:
        parser.error("--dask converts batches: use it with --out-dir DIR (or without -o)")
    if args.output is not None and args.name is not None:
        parser.error("-o FILE names the output itself; --name names those of --out-dir DIR or beside the input")
    check_sheet_options(args)
    check_input_options(args)
    if args.output is not None and args.format is not None and len(args.format) > 1:
        parser.error("-o writes one file in one format; for several formats use --out-dir DIR or no -o "
                     "(each output is then written beside its input)")
    if args.output in (None, "-"):
        formats = args.format or ("svg",)
    else:
        try:
            formats = (files.output_format(args.output, args.format and args.format[0]),)
        except OutputError as exc:
            parser.error(str(exc).replace("the format", "--format").replace("give --format", "use --format"))
    if args.animate and "pdf" in formats:
        parser.error("--animate writes an SVG or a PNG (an animated PNG); a PDF cannot play frames: convert one "
                     "with --frames N")
    return formats


def _convert_batch(args: argparse.Namespace, options: Options) -> list[Outcome]:
    """Every input under --out-dir, or beside itself: plan, make folders, run the pool with a
    progress bar."""
    beside = args.out_dir is None
    found, problems = expand_inputs(args.inputs, args.recursive, exclude=args.out_dir, skip_outputs=beside)
    sheet = options.convert.output.is_sheet
    jobs, failed = plan(found, args.out_dir, options, args.name or (SHEET_NAME if sheet else DEFAULT_NAME))
    if args.dry_run:  # no folder made, nothing written
        outcomes = failed + [Outcome(Path(arg), error=text) for arg, text in problems] + [preview(j) for j in jobs]
        _list_planned(outcomes, args)
    args.pruned = prune_batch(args, options.formats, found, problems, jobs, failed)  # before: it needs no output
    if args.dry_run:
        return outcomes
    jobs, unmade = make_folders(jobs)
    failed += unmade + [Outcome(Path(arg), error=text) for arg, text in problems]
    progress = Progress(len(jobs))
    try:
        for outcome in failed:
            _report(outcome, progress, args, step=False)
        if args.dask is not None:
            from ..dask.batch import run_dask  # noqa: PLC0415

            return failed + run_dask(jobs, args.dask, args.out_dir, lambda o: _report(o, progress, args), args.signals,
                                     progress, timeout=args.dask_timeout, debug=args.debug)
        workers, note = auto_jobs(jobs, asked=None if args.jobs == "auto" else args.jobs)
        if note:
            progress.message(f"note: {note}")
        return failed + run(jobs, workers, lambda o: _report(o, progress, args), args.signals, progress)
    finally:
        for line in args.repeats.lines():
            progress.message(line)
        progress.close()


def _report(outcome: Outcome, progress: Progress, args: argparse.Namespace, step: bool = True) -> None:
    if outcome.state != DONE:
        return
    for note in () if args.quiet else outcome.notes:
        progress.message(f"note: {note}")
    kept = kept_lines(outcome)
    for kind, line in kept:
        if kind == "edited" or outcome.error == line:  # an edit (or a -o FILE not depixel's) is an error
            progress.message(f"error: {line}")
        elif not args.quiet:
            progress.message(f"note: {line}")
    if outcome.changed:
        progress.message(f"error: {outcome.changed}")
    if outcome.error and outcome.error not in (line for _, line in kept) and \
            (args.debug or args.repeats.first(outcome)):
        progress.message(f"error: {outcome.error}")
        if args.debug and outcome.traceback:
            progress.message(outcome.traceback.rstrip())
    if step:
        progress.step()


def _list_planned(outcomes: list[Outcome], args: argparse.Namespace) -> None:
    """``--dry-run`` without ``--json``: one line per output on stdout, what would become of it."""
    if args.json:
        return
    for o in outcomes:
        lines = [f"would convert  {display_name(p)}" for p in o.planned]
        lines += [f"up to date     {display_name(p)}" for p in o.up_to_date]
        lines += [f"{kind:<14} {line}" for kind, line in kept_lines(o)]
        if o.error and not (o.kept or o.edited):
            lines.append(f"failed         {o.error}")
        if lines:
            print_stdout("\n".join(lines))
