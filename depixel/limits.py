"""The resource limits, in one place (docs/limits.md lists them with their messages).

Each limit is checked before the memory it guards is spent: input pixels from the image
header (of the frame or page actually decoded), output pixels from the size a render will
have, decompressed bytes while decompressing. An error names the library parameter that
raises the limit (``parameter=``), which the CLI shows as its flag.
"""
from __future__ import annotations

#: Pixels (width × height) of an input image, frame or page; ``max_pixels``, ``--max-pixels``.
#: Pixel art is small; a larger input is almost always a photo.
DEFAULT_MAX_PIXELS = 1_048_576
#: Pixels of a raster output (a PNG, a diff render, an inspect figure); ``max_output_pixels``,
#: ``--max-output-pixels``. 8192 × 4096: a 128 MiB RGBA image; ``diff`` needs ~140 bytes a pixel.
DEFAULT_MAX_OUTPUT_PIXELS = 1 << 25
#: Pixels of each image ``diff`` compares (input rasters and renders); ``max_pixels`` of
#: :func:`depixel.diff.diff_files`, ``diff --max-pixels``. Comparing costs ~140 bytes a
#: pixel: 4096 × 4096 stays under 2.5 GB.
DEFAULT_MAX_DIFF_PIXELS = 1 << 24
#: Bytes of an input file or stream, and of a compressed SVG (.svgz) once decompressed.
MAX_FILE_BYTES = 256 * 2**20
#: Peak memory of one conversion per input pixel, above the import baseline (bytes), measured
#: with benchmarks/memory_per_pixel.py on the worst case (a 512×512 checkerboard) at 6769c95.
#: ``-j auto`` divides the available memory by this × the largest input's pixels.
PEAK_BYTES_PER_PIXEL = 8_500
#: Memory of an idle worker process (the interpreter with numpy and depixel imported), bytes.
WORKER_BASELINE_BYTES = 80 * 2**20
