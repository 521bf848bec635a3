"""Quality of the input preparation (issue 14 targets) with ../shared/tools/judge.py.

Every paper sprite is damaged the ways pixel art reaches people, converted with the default
options, and judged against the clean 1× PNG:

  x3       saved 3× with nearest-neighbour (PNG)
  x5crop   saved 5×, then cropped by 2, 3, 1 and 4 pixels at the left, top, right, bottom
  x4q90    saved 4×, then as JPEG quality 90
  q85      saved as JPEG quality 85 (1×; Pillow's default 4:2:0 chroma subsampling)
  q70, q95 the same at quality 70 and 95 (no target: to see that no quality gets worse)
  q85-422  saved as JPEG quality 85 with 4:2:2 subsampling (no target)
  q85-444  the same without chroma subsampling (no target)
  key      --transparent auto (sprites whose corners agree), judged against the sprite
           with that colour at alpha 0 where it reaches the border (4-connected, found with
           scipy.ndimage.label: not the code under test)

The judge renders an SVG at the clean image's size, so it gets the SVG of the prepared 1×
image (``pixel_size=1`` on ``PreparedImage.rgba``): the same shapes as the default output,
whose header only lays them over the input instead (for x5crop its viewBox is the cropped
area, which the judge cannot align with the clean sprite). "cmds" is the judge's count of
path commands relative to the clean sprite's own conversion. Targets (issue 14): centre ≥
0.97 and diag ≥ 0.95 with cmds ≤ 1.5× for the upscaled variants, centre ≥ 0.97 and diag ≥
0.95 for q85, centre ≥ 0.99 for key.

    python benchmarks/judge_inputs.py [--only smw_boo] [--variant x3 --variant key] [--keep DIR]
"""
from __future__ import annotations

import argparse
import io
import json
import shutil
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
from PIL import Image

import depixel
from depixel import load_image
from depixel.prepare.inputs import lossy_format, prepare

SHARED = Path(__file__).resolve().parents[1].parent / "shared"
VARIANTS = ("x3", "x5crop", "x4q90", "q85", "q70", "q95", "q85-422", "q85-444", "key")
#: (centre, diag, cmds ratio) each variant must reach; None: not a target
TARGETS = {"x3": (0.97, 0.95, 1.5), "x5crop": (0.97, 0.95, 1.5), "x4q90": (0.97, 0.95, 1.5),
           "q85": (0.97, 0.95, None), "q70": (None, None, None), "q95": (None, None, None),
           "q85-422": (None, None, None), "q85-444": (None, None, None), "key": (0.99, None, None)}


def damaged(clean: np.ndarray, variant: str) -> tuple[bytes, str] | None:
    """The file bytes of one damaged version of a clean RGBA sprite (None: not applicable)."""
    img = Image.fromarray(clean[..., :3], "RGB")
    w, h = img.size
    buffer = io.BytesIO()
    if variant == "x3":
        img.resize((3 * w, 3 * h), Image.Resampling.NEAREST).save(buffer, "PNG")
    elif variant == "x5crop":
        img.resize((5 * w, 5 * h), Image.Resampling.NEAREST).crop((2, 3, 5 * w - 1, 5 * h - 4)).save(buffer, "PNG")
    elif variant == "x4q90":
        img.resize((4 * w, 4 * h), Image.Resampling.NEAREST).save(buffer, "JPEG", quality=90)
    elif variant in ("q70", "q85", "q95"):
        img.save(buffer, "JPEG", quality=int(variant[1:]))
    elif variant == "q85-422":
        img.save(buffer, "JPEG", quality=85, subsampling=1)
    elif variant == "q85-444":
        img.save(buffer, "JPEG", quality=85, subsampling=0)
    elif variant == "key":
        corners = clean[[0, 0, -1, -1], [0, -1, 0, -1]]
        if not (corners == corners[0]).all():
            return None
        img.save(buffer, "PNG")
    return buffer.getvalue(), ("jpg" if "q" in variant else "png")


def backdrop(clean: np.ndarray) -> np.ndarray:
    """The pixels of the corner colour joined to the border, 4-connected."""
    from scipy import ndimage  # noqa: PLC0415 (the test extra)

    labels, _ = ndimage.label((clean[..., :3] == clean[0, 0, :3]).all(axis=2))
    border = np.unique(np.concatenate([labels[0], labels[-1], labels[:, 0], labels[:, -1]]))
    return np.isin(labels, border[border > 0])


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--shared", type=Path, default=SHARED, help="the shared folder (corpus and judge)")
    parser.add_argument("--variant", action="append", choices=VARIANTS, help="variant(s) to judge (default: all)")
    parser.add_argument("--only", action="append", metavar="NAME", help="sprite(s) to judge (default: all 54)")
    parser.add_argument("--keep", type=Path, help="write the files here instead of a temporary folder")
    args = parser.parse_args()
    corpus, judge = args.shared / "corpus" / "paper", args.shared / "tools" / "judge.py"
    if not corpus.is_dir() or not judge.is_file():
        print(f"judge_inputs: {args.shared} has no corpus/paper or tools/judge.py", file=sys.stderr)
        return 2
    sprites = [p for p in sorted(corpus.glob("*.png")) if not args.only or p.stem in args.only]
    work = args.keep or Path(tempfile.mkdtemp(prefix="depixel-inputs-"))
    work.mkdir(parents=True, exist_ok=True)

    pairs, meta = [], []
    for src in sprites:
        clean = load_image(src)
        reference = work / f"{src.stem}.svg"
        reference.write_text(depixel.convert(clean, pixel_size=1))
        pairs.append(f"{src}\t{reference}")
        meta.append((src.stem, "clean"))
        for variant in args.variant or VARIANTS:
            made = damaged(clean, variant)
            if made is None:
                continue
            data, ext = made
            path = work / f"{src.stem}_{variant}.{ext}"
            path.write_bytes(data)
            if variant == "key":
                prepared = prepare(load_image(path), transparent="auto")
                expected = clean.copy()
                expected[..., 3][backdrop(clean)] = 0
                truth = work / f"{src.stem}_keyed.png"
                Image.fromarray(expected, "RGBA").save(truth)
            else:
                prepared = prepare(load_image(path), lossy=lossy_format(data))
                truth = src
            svg = work / f"{src.stem}_{variant}.svg"
            svg.write_text(depixel.convert(prepared.rgba, pixel_size=1))
            pairs.append(f"{truth}\t{svg}")
            meta.append((src.stem, variant, prepared.pixel_size, prepared.rgba.shape[:2] == clean.shape[:2]))
    listing = work / "pairs.tsv"
    listing.write_text("\n".join(pairs) + "\n")
    out = subprocess.run([sys.executable, str(judge), "--pairs", str(listing)], capture_output=True, text=True,
                         check=False)
    rows = [json.loads(line) for line in out.stdout.splitlines() if line.strip()]
    clean_cmds = {m[0]: r.get("cmds") for m, r in zip(meta, rows) if m[1] == "clean"}

    failures = 0
    print(f"{'variant':8} {'n':>3} {'centre min':>10} {'median':>7} {'diag min':>9} {'median':>7} "
          f"{'cmds max':>8} {'grid ok':>7}  below target")
    for variant in args.variant or VARIANTS:
        got = [(m, r) for m, r in zip(meta, rows) if m[1] == variant]
        if not got:
            continue
        good = [(m, r) for m, r in got if "error" not in r and m[3]]
        centre = [r["centre"] for _, r in good]
        diag = [r["diag"] for _, r in good]
        cmds = [r["cmds"] / clean_cmds[m[0]] for m, r in good]
        c_min, d_min, k_max = TARGETS[variant]
        below = [m[0] for (m, r), ratio in zip(good, cmds)
                 if (c_min and r["centre"] < c_min) or (d_min and r["diag"] < d_min) or (k_max and ratio > k_max)]
        failures += len(below) + len(got) - len(good)
        print(f"{variant:8} {len(got):3} {min(centre):10.4f} {statistics.median(centre):7.4f} {min(diag):9.4f} "
              f"{statistics.median(diag):7.4f} {max(cmds):8.2f} {len(good):4}/{len(got):<3} "
              f"{len(below)}: {' '.join(below[:8])}{' ...' if len(below) > 8 else ''}")
        for m, r in got:
            if len(sprites) <= 3:
                print(f"    {m[0]} {variant}: pixel size {m[2]}, {json.dumps(r)}")
    if not args.keep:
        shutil.rmtree(work)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
