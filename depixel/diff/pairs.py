"""One pair of files → a verdict with its figures, and the pictures a report shows.

:func:`diff_files` is the comparison of ``depixel diff A B``: read, draw at one size
(:mod:`.sources`), flatten over a background colour neither image has (so a seam or an
alpha leak shows as that colour), leave out the masked pixels (:mod:`.mask`) and compare
(:mod:`.compare`). :func:`compare_pair` does the same for a pair of a folder comparison and
never raises: a problem is an ``error`` verdict with its one-line reason.
"""
from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from .. import validate
from ..colour import Colour
from ..errors import DepixelError, display_name
from ..limits import DEFAULT_MAX_DIFF_PIXELS
from .compare import DEFAULT_THRESHOLD, Comparison, compare, flatten_in_place, pick_background, within
from .mask import Mask, ignored
from .sources import Source, draw_pair, pixels, read, sizes, too_coarse_for_antialiasing

SAME, DIFFERENT, MISSING, NEW, ERROR = "same", "different", "missing", "new", "error"
VERDICTS = (SAME, DIFFERENT, MISSING, NEW, ERROR)


@dataclass(frozen=True)
class Pair:
    """Two files to compare, by relative path (``/``-separated); one may be None."""

    baseline: str | None
    current: str | None

    @property
    def name(self) -> str:
        """The name a report shows: the current file's, else the baseline's."""
        return self.current if self.current is not None else self.baseline or ""


@dataclass(frozen=True)
class Settings:
    """How every pair is compared (the options of ``depixel diff``)."""

    scale: float = 1.0
    threshold: float = DEFAULT_THRESHOLD
    background: tuple[int, int, int] | None = None
    allow_size_mismatch: bool = False
    include_antialiasing: bool = False
    max_pixels: int | None = DEFAULT_MAX_DIFF_PIXELS
    max_pixels_diff: int | None = None
    max_ratio: float | None = None
    mask: Mask = Mask()
    names: Mapping[str, str] = field(default_factory=dict)  # parameter → CLI flag, for messages

    def __post_init__(self) -> None:
        validate.number("threshold", self.threshold, low=0, high=1)
        object.__setattr__(self, "max_pixels", validate.limit("max_pixels", self.max_pixels))


@dataclass(frozen=True)
class Pictures:
    """Where :func:`compare_pair` writes pictures, each folder optional: ``report`` gets
    ``<name>.baseline.png``, ``.current.png`` and ``.diff.png`` of a changed file (one of
    the first two for a missing or new one), ``diffs`` the ``<name>.diff.png`` alone."""

    report: str | None = None
    diffs: str | None = None


@dataclass(frozen=True)
class PairResult:
    """The verdict on one pair, with its figures (pixel counts at the comparison size)."""

    name: str
    verdict: str
    baseline: str | None = None
    current: str | None = None
    width: int | None = None
    height: int | None = None
    different_pixels: int = 0
    antialiased_pixels: int = 0
    ignored_pixels: int = 0
    ratio: float = 0.0
    identical: bool = False  # same bytes: same without rendering
    error: str | None = None
    pictures: tuple[tuple[str, str], ...] = ()  # (kind, path relative to its folder) written

    def summary(self) -> str:
        """One line: the verdict and its figures or reason."""
        if self.verdict == ERROR:  # the reason names the file
            return f"error: {self.error}"
        if self.verdict in (MISSING, NEW):
            where = "the baseline" if self.verdict == MISSING else "the current folder"
            return f"{self.verdict}: {display_name(self.name)}: only in {where}"
        if self.identical:
            return f"same: {display_name(self.name)}: identical files"
        total = (self.width or 0) * (self.height or 0) - self.ignored_pixels
        return (f"{self.verdict}: {display_name(self.name)}: {self.different_pixels} of {total} pixels differ "
                f"({100 * self.ratio:.3g}%) at {self.width}x{self.height}")


def compare_pair(pair: Pair, baseline: str | os.PathLike, current: str | os.PathLike, settings: Settings,
                 pictures: Pictures = Pictures()) -> PairResult:
    """The verdict on one pair of ``baseline``/``current`` files; never raises (a problem is
    an ``error`` verdict). Identical files are ``same`` without being rendered."""
    base = PairResult(pair.name, ERROR, pair.baseline, pair.current)
    try:
        if pair.baseline is None or pair.current is None:
            lone = pair.current if pair.baseline is None else pair.baseline
            assert lone is not None  # a pair has at least one file
            side = "current" if pair.baseline is None else "baseline"
            folder = current if pair.baseline is None else baseline
            written, size = _lone_picture(Path(folder, lone), side, pair.name, settings, pictures)
            return replace(base, verdict=NEW if pair.baseline is None else MISSING, width=size[0], height=size[1],
                           pictures=written)
        a, b = (read(Path(folder, name), settings.max_pixels)
                for folder, name in ((baseline, pair.baseline), (current, pair.current)))
        if a.data == b.data:
            return replace(base, verdict=SAME, identical=True)
        keep = pictures.report is not None
        comparison, _, originals = compare_sources(a, b, settings, keep=keep)
        same = within(comparison, settings.max_pixels_diff, settings.max_ratio)
        verdict = SAME if same else DIFFERENT
        written = () if same else _pictures(comparison, originals, pair.name, pictures)
        h, w = comparison.different.shape
        return replace(base, verdict=verdict, width=w, height=h, different_pixels=comparison.different_pixels,
                       antialiased_pixels=int(comparison.antialiased.sum()),
                       ignored_pixels=w * h - comparison.compared_pixels, ratio=comparison.ratio, pictures=written)
    except DepixelError as exc:
        return replace(base, error=exc.message_for(settings.names))
    except MemoryError:
        return replace(base, error=f"{display_name(pair.name)}: not enough memory to compare it")
    except OSError as exc:
        return replace(base, error=f"{display_name(pair.name)}: cannot write a picture ({exc.strerror or exc})")
    except Exception as exc:  # a bug: still a verdict, so one pair never stops the others
        return replace(base, error=f"{display_name(pair.name)}: internal error ({type(exc).__name__}: {exc})")


def compare_sources(a: Source, b: Source, settings: Settings,
                    keep: bool = False) -> tuple[Comparison, Colour, tuple[np.ndarray, np.ndarray] | None]:
    """Draw, flatten and compare two files read; returns the comparison, the background
    used and, with ``keep``, copies of both drawings before flattening (for pictures)."""
    first, second = draw_pair(a, b, scale=settings.scale, allow_size_mismatch=settings.allow_size_mismatch,
                              max_pixels=settings.max_pixels)
    h, w = first.shape[:2]
    mask = ignored(settings.mask, w, h, settings.scale, settings.max_pixels)
    background = settings.background or pick_background([first, second])
    originals = (first.copy(), second.copy()) if keep else None
    every_pixel = settings.include_antialiasing or any(
        too_coarse_for_antialiasing(s, x.shape[1], x.shape[0]) for s, x in ((a, first), (b, second)))
    result = compare(flatten_in_place(first, background), flatten_in_place(second, background),
                     settings.threshold, every_pixel, mask)
    return result, background, originals


def diff_files(path_a: str | os.PathLike, path_b: str | os.PathLike, settings: Settings = Settings(),
               **changes) -> tuple[Comparison, Colour]:
    """Load, flatten and compare two SVG/PDF/raster files with ``settings`` (``changes``, its
    field names as keywords, as ``scale=8``, replace some of them); returns the comparison and
    the background used."""
    if changes:
        settings = replace(settings, **changes)
    comparison, colour, _ = compare_sources(read(path_a, settings.max_pixels), read(path_b, settings.max_pixels),
                                            settings)
    return comparison, colour


def _pictures(comparison: Comparison, originals: tuple[np.ndarray, np.ndarray] | None, name: str,
              pictures: Pictures) -> tuple[tuple[str, str], ...]:
    written = []
    if pictures.diffs is not None:
        _save(comparison.diff_image(), Path(pictures.diffs, picture_name(name, "diff")))
        written.append(("diff_out", picture_name(name, "diff")))
    if pictures.report is not None and originals is not None:
        for kind, image in (("baseline", originals[0]), ("current", originals[1]), ("diff", comparison.diff_image())):
            _save(image, Path(pictures.report, picture_name(name, kind)))
            written.append((kind, picture_name(name, kind)))
    return tuple(written)


#: The longest file name most filesystems take (NAME_MAX), in bytes.
NAME_BYTES = 255


def picture_name(name: str, kind: str) -> str:
    """``NAME.KIND.png``, the picture of kind ``kind`` of the file ``name`` (a relative path):
    when its last part would be longer than a file name may be, that part is cut and a
    digest of the whole name added (``NAME-CUT~1a2b3c4d.KIND.png``), so a long name still
    gets its picture and two long names never share one."""
    folder, _, last = name.rpartition("/")
    tail = f".{kind}.png"
    raw = os.fsencode(last)
    if len(raw) + len(tail.encode()) <= NAME_BYTES:
        return f"{name}{tail}"
    import hashlib  # noqa: PLC0415

    digest = hashlib.sha1(os.fsencode(name)).hexdigest()[:8]
    cut = os.fsdecode(raw[:NAME_BYTES - len(tail) - len(digest) - 1])
    return f"{folder}/{cut}~{digest}{tail}" if folder else f"{cut}~{digest}{tail}"


def _lone_picture(path: Path, side: str, name: str, settings: Settings,
                  pictures: Pictures) -> tuple[tuple[tuple[str, str], ...], tuple[int | None, int | None]]:
    """The render of a missing or new file for the report, and its size (none when it
    cannot be drawn: the report then says so; the verdict stays)."""
    if pictures.report is None:
        return (), (None, None)
    try:
        source = read(path, settings.max_pixels)
        (width, height), _ = sizes(source, source, settings.scale)
        image = pixels(source, width, height, settings.max_pixels)
    except DepixelError:
        return (), (None, None)
    _save(image, Path(pictures.report, picture_name(name, side)))
    return ((side, picture_name(name, side)),), (width, height)


def _save(image, path: Path) -> None:
    """An ``(H, W, 4) uint8`` array as PNG (its folders made as needed)."""
    from PIL import Image  # noqa: PLC0415

    from ..files.output import make_folders  # noqa: PLC0415

    make_folders(path.parent)
    Image.fromarray(image, "RGBA").save(path, "PNG")


@dataclass(frozen=True)
class Job:
    """One pair of a folder comparison, as a worker process gets it."""

    pair: Pair
    baseline: str
    current: str
    settings: Settings
    pictures: Pictures = Pictures()


def run_job(job: Job) -> PairResult:
    """:func:`compare_pair` on a job (never raises)."""
    return compare_pair(job.pair, job.baseline, job.current, job.settings, job.pictures)
