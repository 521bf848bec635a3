"""A batch's files in packs: the pipelines of a pack's files run in one pass (issue 44).

Each file is then converted by its own job as before (:func:`depixel_cli.convert.batch.run_job`:
decoding, preparation, writing, stamps, its own errors); only its ``depixelize`` call finds
its result already computed (:func:`depixel.pipeline.ahead`), where the relaxation of the
whole pack ran in one pass (:mod:`depixel.optimize.pack`). The pass is an optimization and
nothing else: it reads each file and prepares it as its job will, and where it reads or
prepares something else (a file that changed in between, an option it does not follow),
the job finds no result ahead and runs its pipeline itself. A file that fails in the pass is
converted (and fails) by its job alone; the results are byte-identical to one file at a time
(``tests/test_packs.py``).
"""
from __future__ import annotations

from collections.abc import Iterator, Sequence
from contextlib import ExitStack, contextmanager

import numpy as np

from depixel.api import passes, prepared_input
from depixel.files.convert import InputFile
from depixel.pipeline import PASS_IMAGES
from depixel.prepare.image import load_image
from depixel.prepare.inputs import lossy_format

from .batch import Job, Outcome, run_job


def packs(count: int, workers: int = 1) -> list[range]:
    """The indices of ``count`` jobs in packs, in order: as many files as one pass takes
    (:data:`depixel.pipeline.PASS_IMAGES`), read and prepared a pack at a time; for
    ``workers`` processes, small enough that each gets three or more (the last packs then
    keep them all busy)."""
    size = max(1, min(PASS_IMAGES, -(-count // (3 * workers)) if workers > 1 else PASS_IMAGES))
    return [range(first, min(first + size, count)) for first in range(0, count, size)]


def run_pack(pack: tuple[Job, ...]) -> list[Outcome]:
    """:func:`~depixel_cli.convert.batch.run_job` of each job of ``pack``, their pipelines in one
    pass (a worker's task); never raises."""
    with packed(pack):
        return [run_job(job) for job in pack]


@contextmanager
def packed(jobs: Sequence[Job]) -> Iterator[None]:
    """Within the block, the pipelines of the jobs that can be read and prepared here run in
    passes, their SVG outlines simplified together (:func:`depixel.api.passes`; the others
    are left to their jobs)."""
    images = [rgba for job in jobs if (rgba := _prepared(job)) is not None]
    with ExitStack() as stack:
        if len(images) > 1:
            stack.enter_context(passes(images, jobs[0].options.convert, jobs[0].options.formats))
        yield


def _prepared(job: Job) -> np.ndarray | None:
    """The pixels ``job`` will give ``depixelize``, as its conversion reads and prepares its
    input (:func:`depixel.files.convert.convert_frames`), or None when they cannot be had."""
    opt = job.options
    if opt.frames == "all":
        return None
    frame = 0 if opt.frames == "first" else int(opt.frames)
    limits = opt.convert.limits
    try:
        source = InputFile.read(job.source)
        rgba = load_image(source.data, limits.max_pixels, frame, max_frames=limits.max_frames, name=source.name)
        return prepared_input(rgba, opt.convert.prepare, lossy=lossy_format(source.data), max_pixels=None).rgba
    except Exception:  # its job reports it
        return None
