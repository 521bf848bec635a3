"""The resource limits, in one place (docs/limits.md lists them with their messages).

Each limit is checked before the work or memory it guards is spent: input pixels from the
image header (of the frame or page actually decoded), an animation's frames and their pixels
in all from its header before the first frame is decoded, output pixels from the size a render
will have, decompressed bytes while decompressing. An error names the library parameter that
raises the limit (``parameter=``), which the CLI shows as its flag. The checks of an input's
size are the functions below, used wherever an input is opened.
"""
from __future__ import annotations

from .errors import InputError

#: Pixels (width × height) of an input image, frame or page; ``max_pixels``, ``--max-pixels``.
#: Pixel art is small; a larger input is almost always a photo.
DEFAULT_MAX_PIXELS = 1_048_576
#: Frames of an animation (or pages of a TIFF) converted with ``frames="all"``, and the frame
#: index one may ask for (decoding frame N decodes the N before it); ``max_frames``,
#: ``--max-frames``. The pixel limit applies to the sum over the frames as well: a header
#: declaring 2**31 - 1 frames of 4 × 4 is refused before a frame is decoded.
DEFAULT_MAX_FRAMES = 5000
#: Pixels the pipeline can address at all, whatever ``max_pixels`` says: the cell graph and the
#: curves index their nodes, edges and slots in 32 bits (``cells.INDEX``), up to ~10 of each a
#: pixel, so an image is refused past 2**31 / 16 pixels (134,217,728, e.g. 11585 × 11585, which
#: would need over 100 GB) rather than wrap an index silently.
MAX_INDEXED_PIXELS = 2**31 // 16
#: Pixels of a raster output (a PNG, a diff render, an inspect figure); ``max_output_pixels``,
#: ``--max-output-pixels``. 8192 × 4096: a 128 MiB RGBA image.
DEFAULT_MAX_OUTPUT_PIXELS = 1 << 25
#: Pixels of each image ``diff`` compares (input rasters and renders); ``max_pixels`` of
#: :func:`depixel.diff.pairs.diff_files`, ``diff --max-pixels``. 4096 × 4096 stays under 1 GB
#: at DIFF_BYTES_PER_PIXEL.
DEFAULT_MAX_DIFF_PIXELS = 1 << 24
#: Peak memory of one ``diff`` per compared pixel, the whole process (benchmarks/diff_memory.py
#: measures it; tests/test_diff_memory.py holds it): the two 8-bit renders and a few bytes a
#: pixel of results, the arithmetic in bands of rows. ``diff -j auto`` counts with it.
DIFF_BYTES_PER_PIXEL = 64
#: Bytes of an input file or stream, and of a compressed SVG (.svgz) once decompressed.
MAX_FILE_BYTES = 256 * 2**20
#: Peak memory of one conversion per input pixel, above the import baseline (bytes), measured
#: with benchmarks/memory_per_pixel.py on the worst cases from 256² up (noise 0.84-0.95 KB,
#: a checkerboard 0.77-0.89 KB, stripes 0.64-0.71 KB; docs/limits.md has the table).
#: ``-j auto`` divides the available memory by this × the largest input's pixels.
PEAK_BYTES_PER_PIXEL = 1_000
#: Memory of a worker process before its image: 35-38 MB measured with numpy and depixel imported
#: (memory_per_pixel.py's baseline), plus room for cairo when it renders PNG or PDF.
WORKER_BASELINE_BYTES = 80 * 2**20
#: Sides of a PDF page, in points: the PDF format's own range (ISO 32000-1, Annex C: 3 to
#: 14,400 units a side without a user unit), so 4 to 19,200 CSS pixels at cairo's 0.75 pt a pixel.
PDF_PAGE_POINTS = (3.0, 14_400.0)
#: Sides of an SVG's width and height, in CSS pixels: written with 3 decimals, less than
#: 0.001 would be written as 0 (nothing is drawn); over 2**23, cairo's 24.8 fixed-point
#: coordinates (Inkscape's and cairosvg's renderer) cannot place a point and drop path operators.
SVG_SIDE_PIXELS = (0.001, float(2**23))
#: ``<use>`` elements an SVG may draw, counting every copy (a use of a group of uses draws
#: each of them): cairosvg's own limit, which it reaches only after drawing them all (an
#: SVG of 3 KB whose uses fan out to 10**11 copies ran 15 s before failing); counted before.
MAX_SVG_REFERENCES = 100_000


def check_pixels(name: str, width: int, height: int, max_pixels: int | None) -> None:
    """Refuse an image (frame, page) of more than ``max_pixels`` pixels, naming the parameter."""
    if max_pixels is not None and width * height > max_pixels:
        raise InputError(f"{name}: {width}x{height} is {width * height} pixels, over the limit of "
                         f"{max_pixels} (depixel is for pixel art; raise it with max_pixels)", parameter="max_pixels")


def check_frames(name: str, frames: int, max_frames: int | None) -> None:
    """Refuse an animation of more than ``max_frames`` frames (from its header)."""
    if max_frames is not None and frames > max_frames:
        raise InputError(f"{name}: declares {frames} frames, over the limit of {max_frames} "
                         "(raise it with max_frames)", parameter="max_frames")


def check_frame_index(name: str, frame: int, max_frames: int | None) -> None:
    """Refuse frame ``frame`` past ``max_frames`` (it decodes every frame before it)."""
    if max_frames is not None and frame >= max_frames:
        raise InputError(f"{name}: frame {frame} is past the limit of {max_frames} frames "
                         "(raise it with max_frames)", parameter="max_frames")


def check_frames_pixels(name: str, frames: int, pixels: int, max_pixels: int | None) -> None:
    """Refuse ``frames`` frames of ``pixels`` pixels in all over ``max_pixels``: an
    animation's work is the sum of its frames'."""
    if max_pixels is not None and pixels > max_pixels:
        raise InputError(f"{name}: {frames} frames are {pixels} pixels in all, over the limit of {max_pixels} "
                         "(the limit counts every frame; raise it with max_pixels)", parameter="max_pixels")


def check_rendered_frames(name: str, frames: int, pixels: int, max_output_pixels: int | None) -> None:
    """Refuse PNG outputs of ``frames`` frames of ``pixels`` pixels in all over
    ``max_output_pixels`` (each frame alone is checked as any PNG is)."""
    if max_output_pixels is not None and pixels > max_output_pixels:
        raise InputError(f"{name}: {frames} PNG frames are {pixels} pixels in all, over the limit of "
                         f"{max_output_pixels} (the limit counts every frame; raise it with max_output_pixels)",
                         parameter="max_output_pixels")


def check_sprites(name: str, sprites: int, pixels: int, max_pixels: int | None, max_frames: int | None) -> None:
    """Refuse a sprite sheet of more than ``max_frames`` sprites, or whose ``sprites``
    rectangles are more than ``max_pixels`` pixels in all: each sprite is converted alone,
    as each frame of an animation is."""
    if max_frames is not None and sprites > max_frames:
        raise InputError(f"{name}: {sprites} sprites, over the limit of {max_frames} (a sprite counts as a "
                         "frame; raise it with max_frames)", parameter="max_frames")
    if max_pixels is not None and pixels > max_pixels:
        raise InputError(f"{name}: {sprites} sprites are {pixels} pixels in all, over the limit of {max_pixels} "
                         "(the limit counts every sprite; raise it with max_pixels)", parameter="max_pixels")
