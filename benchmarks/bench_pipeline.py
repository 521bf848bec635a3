"""Pipeline timings in the layout of the paper's table, a scaling series, peak memory and
the whole-process time of ``depixel convert``.

    python benchmarks/bench_pipeline.py                    # default (optimized) stage
    python benchmarks/bench_pipeline.py --stage cells      # only the stages up to the cell graph

1. Paper corpus (``../shared/corpus/paper/*.png``): every image is run ``--repeats`` times
   in-process (after one warm-up run); per image the median of each stage is kept, and the
   table gives median / average / min / max over the images, in milliseconds. File I/O is
   excluded; "SVG writing" is :func:`depixel.to_svg` (text only, not written to disk).
2. Scaling (``../shared/corpus/frames/*.png``): centre crops of each frame (tilings of it
   for sizes larger than a frame), median seconds and microseconds per pixel, and the peak
   RSS of a fresh process that runs the pipeline once on that input.
3. ``depixel convert SPRITE -o out.svg`` as a subprocess (import cost included), median of
   ``--convert-runs`` runs, beside ``python -c "import numpy, PIL.Image"`` (the floor any
   numpy + Pillow tool pays). The children may write bytecode (``PYTHONDONTWRITEBYTECODE``
   is dropped for them): an installed package has it, and compiling ~40 modules per run
   would be measured instead.

When ``vtracer`` (a Rust tracer, ``pip install vtracer``; not a dependency) is importable,
its time on the same inputs (the PNG bytes, default settings) is printed beside ours, so
the ratio can be read on any machine.

Everything runs single-threaded: BLAS/OpenMP thread counts are pinned to 1 before numpy
is imported, here and in every child process.
"""
from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMEXPR_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse  # noqa: E402
import platform  # noqa: E402
import re  # noqa: E402
import statistics  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

import depixel  # noqa: E402
from depixel import Params, depixelize, load_image, to_svg  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_CORPUS = Path(__file__).resolve().parents[1].parent / "shared" / "corpus"
DEFAULT_SIZES = "32x32,64x64,128x128,256x224"
#: statistic over the repeated runs of one image (``--per-image``)
PER_IMAGE = statistics.median

#: table rows → the pipeline timing keys they add up ("svg" is timed here, not by the pipeline)
ROWS = (
    ("similarity graph construction", ("similarity", "crossings")),
    ("cell graph", ("cells",)),
    ("spline extraction", ("splines",)),
    ("spline optimization", ("corners", "optimize")),
    ("SVG writing", ("svg",)),
)


def run_once(rgba: np.ndarray, stage: str) -> dict[str, float]:
    """Seconds per timing key for one run of the pipeline plus SVG writing."""
    result = depixelize(rgba, Params(), stage=stage)
    t = time.perf_counter()
    to_svg(result.vector)
    timings = dict(result.timings)
    timings["svg"] = time.perf_counter() - t
    return timings


def timed(rgba: np.ndarray, stage: str, repeats: int) -> dict[str, float]:
    """Per-key median (``--per-image min``: minimum) over ``repeats`` runs after one warm-up;
    "total" is that statistic of the run totals."""
    run_once(rgba, stage)
    runs = [run_once(rgba, stage) for _ in range(repeats)]
    out = {key: PER_IMAGE(r[key] for r in runs) for key in runs[0]}
    out["total"] = PER_IMAGE(sum(r.values()) for r in runs)
    return out


def vtracer_module():
    """The vtracer module, or None when it is not installed."""
    try:
        import vtracer  # noqa: PLC0415
    except ImportError:
        return None
    return vtracer


def png_bytes(rgba: np.ndarray) -> bytes:
    from io import BytesIO  # noqa: PLC0415

    from PIL import Image  # noqa: PLC0415

    buffer = BytesIO()
    Image.fromarray(rgba, "RGBA").save(buffer, "PNG")
    return buffer.getvalue()


def vtracer_seconds(vtracer, rgba: np.ndarray, repeats: int) -> float:
    """vtracer's time on one image (PNG bytes in, SVG text out), after one warm-up run."""
    data = png_bytes(rgba)
    vtracer.convert_raw_image_to_svg(data, img_format="png")
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        vtracer.convert_raw_image_to_svg(data, img_format="png")
        times.append(time.perf_counter() - t)
    return PER_IMAGE(times)


def row_value(timings: dict[str, float], keys: tuple[str, ...]) -> float | None:
    if not all(k in timings for k in keys):
        return None
    return sum(timings[k] for k in keys)


def print_table(title: str, per_image: list[dict[str, float]]) -> None:
    """The paper's table: one row per stage group, median/average/min/max in ms."""
    print(f"\n### {title}\n")
    print("| stage | median ms | average ms | min ms | max ms |")
    print("|---|---:|---:|---:|---:|")
    for label, keys in ROWS + (("total", ("total",)),):
        values = [row_value(t, keys) for t in per_image]
        if any(v is None for v in values):
            print(f"| {label} | n/a | n/a | n/a | n/a |")
            continue
        ms = np.array(values) * 1e3
        bold = "**" if label == "total" else ""
        print(f"| {bold}{label}{bold} | {np.median(ms):.2f} | {ms.mean():.2f} | {ms.min():.2f} | {ms.max():.2f} |")


def parse_sizes(text: str) -> list[tuple[int, int]]:
    """"32x32,256x224" → [(32, 32), (224, 256)] as (height, width)."""
    sizes = []
    for item in text.split(","):
        w, h = (int(v) for v in item.lower().split("x"))
        sizes.append((h, w))
    return sizes


def crop_or_tile(frame: np.ndarray, h: int, w: int) -> np.ndarray:
    """A centred ``h × w`` crop of the frame, tiling it first when it is smaller."""
    fh, fw = frame.shape[:2]
    reps = (-(-h // fh), -(-w // fw), 1)
    big = np.tile(frame, reps) if reps != (1, 1, 1) else frame
    top, left = (big.shape[0] - h) // 2, (big.shape[1] - w) // 2
    return np.ascontiguousarray(big[top : top + h, left : left + w])


def peak_rss_mb(frame_path: Path, h: int, w: int, stage: str) -> tuple[float, float]:
    """(peak RSS, peak RSS after imports) in MB of a fresh process running one input once."""
    out = subprocess.run(
        [sys.executable, __file__, "--probe-memory", f"{frame_path}:{w}x{h}", "--stage", stage],
        check=True, capture_output=True, text=True,
    ).stdout.split()
    return float(out[0]), float(out[1])


def high_water_mb() -> float:
    """Peak RSS of this process in MB.

    VmHWM rather than ``ru_maxrss``: Linux carries the parent's RSS into ``ru_maxrss`` across
    the vfork + exec that starts a child, which would hide the child's own figure.
    """
    try:
        status = Path("/proc/self/status").read_text()
        return float(re.search(r"VmHWM:\s*(\d+) kB", status).group(1)) / 1024.0
    except (OSError, AttributeError):
        import resource

        return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def probe_memory(spec: str, stage: str) -> None:
    """Child process of :func:`peak_rss_mb`: prints peak RSS (MB) after a run and before it."""
    path, size = spec.rsplit(":", 1)
    (h, w), = parse_sizes(size)
    rgba = crop_or_tile(load_image(path), h, w)
    before = high_water_mb()
    to_svg(depixelize(rgba, Params(), stage=stage).vector)
    print(f"{high_water_mb():.1f} {before:.1f}")


def scaling(frames: list[Path], sizes: list[tuple[int, int]], stage: str, repeats: int, vtracer=None) -> None:
    print("\n### Scaling on game frames (centre crops; tiled above the frame size)\n")
    print("| size | pixels | median s | µs/pixel | per stage ms (sim+cross / cells / splines / opt / svg) "
          "| peak RSS MB (after imports) |")
    print("|---|---:|---:|---:|---|---:|")
    loaded = [load_image(p) for p in frames]
    per_pixel: dict[tuple[int, int], float] = {}
    theirs: dict[tuple[int, int], float] = {}
    ratios: dict[tuple[int, int], float] = {}
    for h, w in sizes:
        runs = [timed(crop_or_tile(f, h, w), stage, max(1, repeats if h * w < 128 * 128 else repeats // 2))
                for f in loaded]
        total = statistics.median(r["total"] for r in runs)
        per_pixel[(h, w)] = total / (h * w) * 1e6
        parts = []
        for _, keys in ROWS:
            vals = [row_value(r, keys) for r in runs]
            parts.append("n/a" if None in vals else f"{statistics.median(vals) * 1e3:.1f}")
        rss = [peak_rss_mb(p, h, w, stage) for p in frames]
        peak, base = max(r[0] for r in rss), max(r[1] for r in rss)
        print(f"| {w}×{h} | {h * w} | {total:.3f} | {per_pixel[(h, w)]:.1f} | {' / '.join(parts)} "
              f"| {peak:.0f} ({base:.0f}) |")
        if vtracer is not None:
            theirs[(h, w)] = statistics.median(vtracer_seconds(vtracer, crop_or_tile(f, h, w), repeats) for f in loaded)
            ratios[(h, w)] = total / theirs[(h, w)]
    small, large = min(per_pixel, key=lambda s: s[0] * s[1]), max(per_pixel, key=lambda s: s[0] * s[1])
    if small != large:
        print(f"\nµs/pixel at {large[1]}×{large[0]} / at {small[1]}×{small[0]}: "
              f"{per_pixel[large] / per_pixel[small]:.2f}")
    if ratios:
        print("\nvtracer on the same crops: " + ", ".join(
            f"{w}×{h} {theirs[(h, w)] * 1e3:.1f} ms (depixel {ratios[(h, w)]:.1f}×)" for h, w in ratios))


def convert_command() -> list[str]:
    script = Path(sys.executable).with_name("depixel")
    return [str(script)] if script.exists() else [sys.executable, "-m", "depixel"]


def whole_process(sprite: Path, stage: str, runs: int) -> None:
    print(f"\n### Whole process: `depixel convert {sprite.name} -o out.svg --stage {stage}`\n")
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "out.svg"
        commands = {
            "python -c pass": [sys.executable, "-c", "pass"],
            "python -c 'import numpy, PIL.Image'": [sys.executable, "-c", "import numpy, PIL.Image"],
            "python -c 'import depixel'": [sys.executable, "-c", "import depixel"],
            "depixel convert": convert_command() + ["convert", str(sprite), "-o", str(out), "--stage", stage],
        }
        for cmd in commands.values():  # warm the file cache and write the bytecode
            subprocess.run(cmd, check=True, capture_output=True, env=env)
        times: dict[str, list[float]] = {label: [] for label in commands}
        for _ in range(runs):  # interleaved, so a change of load hits every command alike
            for label, cmd in commands.items():
                t = time.perf_counter()
                subprocess.run(cmd, check=True, capture_output=True, env=env)
                times[label].append(time.perf_counter() - t)
        print("| command | median s | min s | max s |")
        print("|---|---:|---:|---:|")
        for label, values in times.items():
            print(f"| {label} | {statistics.median(values):.3f} | {min(values):.3f} | {max(values):.3f} |")
        ours, floor = times["depixel convert"], times["python -c 'import numpy, PIL.Image'"]
        ratio = statistics.median(ours) / statistics.median(floor)
        print(f"\n`depixel convert` / `import numpy, PIL.Image`: {ratio:.2f}× (medians; minimums "
              f"{min(ours) / min(floor):.2f}×)")


def machine() -> str:
    cpu = "unknown CPU"
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return (f"{time.strftime('%Y-%m-%d')}, {cpu}, nproc {os.cpu_count()}, Python {platform.python_version()}, "
            f"numpy {np.__version__}, depixel {depixel.__version__}, single thread")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--stage", choices=depixel.STAGES, default="optimized")
    parser.add_argument("--corpus", type=Path, default=DEFAULT_CORPUS, help="folder with paper/ and frames/")
    parser.add_argument("--repeats", type=int, default=5, help="timed runs per image (median kept)")
    parser.add_argument("--per-image", choices=("median", "min"), default="median",
                        help="statistic over the repeats of one image; min resists a busy machine")
    parser.add_argument("--sizes", default=DEFAULT_SIZES, help=f"scaling sizes WxH (default {DEFAULT_SIZES})")
    parser.add_argument("--convert-runs", type=int, default=7)
    parser.add_argument("--sprite", type=Path, help="sprite for the whole-process run "
                        "(default: paper/smw_yoshi.png, else fixtures/ghost.png)")
    parser.add_argument("--skip", action="append", default=[], choices=("table", "scaling", "convert"),
                        help="leave out a section (repeatable)")
    parser.add_argument("--probe-memory", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    global PER_IMAGE
    PER_IMAGE = statistics.median if args.per_image == "median" else (lambda values: min(values))
    if args.probe_memory:
        probe_memory(args.probe_memory, args.stage)
        return 0

    paper = sorted((args.corpus / "paper").glob("*.png"))
    frames = sorted((args.corpus / "frames").glob("*.png"))
    if not paper and "table" not in args.skip:
        parser.error(f"no PNGs in {args.corpus / 'paper'} (use --corpus)")
    try:
        depixelize(np.zeros((2, 2, 4), np.uint8), stage=args.stage)
    except ImportError as exc:
        parser.error(f"stage {args.stage} is not available yet ({exc}); try --stage cells")

    print(f"# depixel benchmark, stage {args.stage}\n\n{machine()}")
    vtracer = vtracer_module()
    if "table" not in args.skip:
        per_image = [timed(load_image(p), args.stage, args.repeats) for p in paper]
        print_table(f"Paper corpus: {len(paper)} images, {args.per_image} of {args.repeats} runs each", per_image)
        if vtracer is not None:
            ours = np.array([t["total"] for t in per_image]) * 1e3
            theirs = np.array([vtracer_seconds(vtracer, load_image(p), args.repeats) for p in paper]) * 1e3
            print(f"\nvtracer on the same sprites: median {np.median(theirs):.2f} ms, max {theirs.max():.2f} ms; "
                  f"depixel / vtracer: median {np.median(ours) / np.median(theirs):.1f}×, "
                  f"max {ours.max() / theirs.max():.1f}×")
    if "scaling" not in args.skip and frames:
        scaling(frames, parse_sizes(args.sizes), args.stage, args.repeats, vtracer)
    if "convert" not in args.skip:
        sprite = args.sprite or next((p for p in paper if p.name == "smw_yoshi.png"), ROOT / "fixtures" / "ghost.png")
        whole_process(sprite, args.stage, args.convert_runs)
    return 0


if __name__ == "__main__":
    sys.exit(main())
