"""``depixel convert --dry-run``: what each job of a batch would do, writing nothing.

Its own module because a dry run looks further than the up-to-date check (it decodes the
inputs it would convert, so that a corrupt one fails here as in the run) and shares only
the planning with the run itself (:mod:`depixel_cli.convert.batch`).
"""
from __future__ import annotations

from depixel.errors import DepixelError, display_name
from depixel.files import convert as files
from depixel.prepare.image import frame_count

from ..options import error_message
from .batch import Job, Outcome, _outputs_to_make, kept_lines, listed


def preview(job: Job) -> Outcome:
    """``--dry-run``: what :func:`run_job` would do, writing nothing (the outputs it would
    write are ``planned``). An input with outputs to make is decoded as the conversion
    would decode it (not converted), so one that the run would fail as corrupt fails here."""
    out = Outcome(job.source, job.output)
    opt = job.options
    try:
        whole = opt.frames == "all" or opt.convert.output.animate
        frame_count(job.source, opt.convert.limits.max_frames if whole else None)
        job = listed(job)  # the header is read: an unreadable input fails
        todo = _outputs_to_make(job, out)
        if todo:
            for _ in files.decoded_frames(files.InputFile.read(job.source), dict.fromkeys(t.frame for t in todo),
                                          opt.convert, every_frame=opt.frames == "all"):
                pass
        out.planned = [target.path for target in todo]
        if opt.explicit and (out.kept or out.edited):
            out.error = kept_lines(out)[0][1]
    except DepixelError as exc:
        out.error = error_message(exc)
    except MemoryError:
        out.error = f"{display_name(job.source)}: not enough memory to convert it"
    return out
