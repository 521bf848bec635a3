"""``depixel diff BASELINE CURRENT`` on two folders: run the pairs, print, report, update.

Every pair is a job of :func:`depixel.diff.pairs.run_job`, run ``-j`` processes at a time
by :mod:`depixel_cli.pool` (this process for one) with ``convert``'s progress bar. The
report folders are written under a temporary name and moved into place at the end
(:mod:`depixel.diff.staging`): an error or an interrupt leaves no half-written report.
"""
from __future__ import annotations

import argparse
import json
import os
from pathlib import Path

from depixel.diff.folders import pair_folders, status, totals
from depixel.diff.pairs import ERROR, SAME, Job, PairResult, Pictures, Settings, run_job
from depixel.diff.update import RECORD
from depixel.errors import DepixelError, OutputError, display_name, report_text
from depixel.files.output import write_atomic
from depixel.limits import DIFF_BYTES_PER_PIXEL, WORKER_BASELINE_BYTES

from ..convert.run import Progress
from ..options import Exit, say
from ..pool import Finished, run_jobs
from ..streams import print_stdout

EXIT_OF_STATUS = {"same": Exit.OK, "different": Exit.FAILED, "error": Exit.USAGE}


def run_folders(args: argparse.Namespace, settings: Settings) -> int:
    from depixel.diff.staging import Staged  # noqa: PLC0415

    if args.prune and not args.update:
        args.parser.error("--prune removes missing files from the baseline: use it with --update")
    if (clash := output_clash(args)) is not None:
        args.parser.error(clash)
    pairs = pair_folders(args.a, args.b)
    html = Staged(args.html) if args.html else None
    try:
        diffs = Staged(args.diff_out) if args.diff_out else None
    except BaseException:
        if html is not None:
            html.discard()
        raise
    staged = [s for s in (html, diffs) if s is not None]
    try:
        from depixel.diff.html import IMAGES  # noqa: PLC0415

        pictures = Pictures(report=str(html.path / IMAGES) if html else None,
                            diffs=str(diffs.path) if diffs else None)
        jobs = [Job(pair, args.a, args.b, settings, pictures) for pair in pairs]
        results = _run(jobs, workers(args.jobs, len(jobs), settings.max_pixels or 0), args)
        if results is None:  # interrupted
            for folder in staged:
                folder.discard()
            say("interrupted")
            return 128 + args.signals.signum
        return _finish(args, settings, results, html, diffs)
    except BaseException:
        for folder in staged:
            folder.discard()
        raise


def output_clash(args: argparse.Namespace) -> str | None:
    """Why the outputs asked for would overwrite one another or the compared folders, or
    None. A report folder (``--html``, ``--diff-out``) is replaced whole when it is done, so
    nothing else may be inside it, and it may not be or hold either folder compared."""
    def real(path: str) -> str:
        return os.path.realpath(path)

    def within(inner: str, outer: str) -> bool:
        return inner == outer or inner.startswith(outer.rstrip(os.sep) + os.sep)

    folders = [(flag, value) for flag, value in (("--html", args.html), ("--diff-out", args.diff_out)) if value]
    for flag, value in folders:
        for what, compared in (("the baseline", args.a), ("the current folder", args.b)):
            if within(real(compared), real(value)):
                held = "is" if real(compared) == real(value) else "holds"
                return (f"{flag} {display_name(value)} {held} {what} {display_name(compared)}: a report folder is "
                        "replaced whole; give it a folder of its own")
    for flag, value in folders:
        others = [(f, v) for f, v in folders if f != flag] + ([("--junit", args.junit)] if args.junit else [])
        for other, inner in others:
            if within(real(inner), real(value)):
                where = "is" if real(inner) == real(value) else "is inside"
                return (f"{other} {display_name(inner)} {where} {flag} {display_name(value)}, a folder replaced "
                        f"whole when the report is done: write them apart")
    return None


def _run(jobs: list[Job], count: int, args: argparse.Namespace) -> list[PairResult] | None:
    """Every job's result in order; None when a signal stopped the run."""
    results: list[PairResult | None] = [None] * len(jobs)
    progress = Progress(len(jobs))
    signals = args.signals

    def finished(done: Finished) -> None:
        job = jobs[done.index]
        if done.result is not None:
            results[done.index] = done.result
        elif done.died:
            results[done.index] = PairResult(job.pair.name, ERROR, job.pair.baseline, job.pair.current,
                                         error=f"worker process died ({done.died}), also when retried")
        progress.step()

    def started(index: int) -> None:
        progress.current(Path(jobs[index].pair.name))

    try:
        if count <= 1 or len(jobs) <= 1:
            for index, job in enumerate(jobs):  # a signal raises Interrupted here: the caller cleans up
                started(index)
                finished(Finished(index, run_job(job)))
        else:
            signals.raising = False  # the pool stops its workers on a signal and reports
            run_jobs(jobs, count, run_job, finished, signals, started=started)
            signals.raising = True
    finally:
        progress.close()
    if signals.signum is not None or any(r is None for r in results):
        return None
    return [r for r in results if r is not None]


def _finish(args: argparse.Namespace, settings: Settings, results: list[PairResult], html, diffs) -> int:
    """Update the baseline if asked, write the reports, print the verdicts; the exit code.
    An update refused or stopped half-way still prints every verdict and what it changed,
    then the reason (exit 2); one stopped by Ctrl-C prints what it changed, then stops."""
    from depixel.diff.html import html_report  # noqa: PLC0415
    from depixel.diff.reports import json_report, junit_report  # noqa: PLC0415
    from depixel.diff.update import UpdateStopped, update_baseline  # noqa: PLC0415

    found = status(results, args.allow_new, args.allow_missing)
    updated: list[tuple[str, str]] | None = None
    after, problem = results, None
    if args.update:
        updated = []
        try:
            _, after = update_baseline(results, args.a, args.b, prune=args.prune, changed=updated)
        except DepixelError as exc:
            problem = exc.message_for({})
            if not isinstance(exc, UpdateStopped):  # refused: nothing changed, the verdicts stand
                updated = None
        except BaseException:  # Ctrl-C: what was done is said before "interrupted"
            if updated:
                print_lines([f"{action}: {display_name(name)}" for action, name in updated])
                say(f"--update stopped after {len(updated)} changes (also listed in "
                    f"{display_name(Path(args.a, RECORD))})")
            raise
    final = status(after, args.allow_new, args.allow_missing) if after and problem is None else \
        ("same" if updated and problem is None else found)
    if args.junit:
        write_atomic(args.junit, junit_report(results, args.allow_new, args.allow_missing))
    if html is not None:
        _named(html, lambda: write_atomic(html.path / "index.html",
                                          html_report(results, args.a, args.b, found, describe(args))))
        html.publish()
    if diffs is not None:
        diffs.publish()
    if args.json:
        folders = {"diff_out": report_text(args.diff_out)} if args.diff_out else {}
        report = json_report(results, final, _settings_entry(args), folders, updated)
        if problem is not None:
            report["error"] = report_text(problem)
        print_stdout(json.dumps(report, indent=2))
    else:
        lines = [r.summary() for r in results if r.verdict != SAME]
        lines += [f"{action}: {display_name(name)}" for action, name in updated or []]
        lines.append(_totals_line(results, final, args, updated is not None))
        print_lines(lines)
    if problem is not None:
        say(f"error: {problem}")
        return Exit.USAGE
    return EXIT_OF_STATUS[final]


def _named(staged, write) -> None:
    """Run ``write`` (a file into a staged folder); an error names the folder asked for,
    not the temporary one."""
    try:
        write()
    except OutputError as exc:
        text = str(exc).replace(display_name(staged.path), display_name(staged.shown))
        raise OutputError(text) from None


def _totals_line(results: list[PairResult], final: str, args: argparse.Namespace, updated: bool) -> str:
    counts = totals(results)
    parts = [f"{n} {verdict}" for verdict, n in counts.items() if n]
    allowed = [what for what, on in (("new", args.allow_new), ("missing", args.allow_missing)) if on]
    note = f" ({' and '.join(allowed)} allowed)" if allowed else ""
    after = " after --update" if updated else ""  # (not when the update was refused)
    files = f"{len(results)} file{'' if len(results) == 1 else 's'}"
    return f"{final}{after}: {files}: {', '.join(parts) or 'none found'}{note}"


def describe(args: argparse.Namespace) -> str:
    """The comparison's settings in one line, for the HTML report."""
    parts = [f"scale {args.scale:g}", f"threshold {args.threshold:g}"]
    if args.max_pixels_diff is not None:
        parts.append(f"at most {args.max_pixels_diff} pixels may differ")
    if args.max_ratio is not None:
        parts.append(f"at most {100 * args.max_ratio:g}% may differ")
    if args.include_aa:
        parts.append("anti-aliasing counted")
    if args.mask:
        parts.append(f"masked: {', '.join(args.mask)}")
    return "; ".join(parts)


def _settings_entry(args: argparse.Namespace) -> dict:
    return {"baseline": args.a, "current": args.b, "scale": args.scale, "threshold": args.threshold,
            "max_pixels_diff": args.max_pixels_diff, "max_ratio": args.max_ratio,
            "include_aa": args.include_aa, "mask": args.mask, "allow_new": args.allow_new,
            "allow_missing": args.allow_missing, "html": args.html, "junit": args.junit,
            "diff_out": args.diff_out}


def workers(option: str | int, pairs: int, max_pixels: int) -> int:
    """``-j``: the number given, or one per core when each worker's largest comparison
    (``max_pixels`` at DIFF_BYTES_PER_PIXEL) fits in the available memory."""
    from ..convert.run import available_memory, cores  # noqa: PLC0415

    if option != "auto":
        return max(1, min(int(option), pairs))
    count = max(1, min(cores(), pairs))
    memory = available_memory()
    if memory is not None:
        count = max(1, min(count, memory // (WORKER_BASELINE_BYTES + DIFF_BYTES_PER_PIXEL * max_pixels)))
    return count


def print_lines(lines: list[str]) -> None:
    if lines:
        print_stdout("\n".join(lines))
