"""The §3.4 optimizer's figures of issue 31: energies, equivariance, locality, and speed against
the C++ peer.

    python benchmarks/bench_optimizer.py                       # all four sections
    python benchmarks/bench_optimizer.py energy --base TREE    # against another source tree
    python benchmarks/bench_optimizer.py equivariance locality speed

energy        per paper sprite the energy E_s + E_p before relaxing, after it, and of the output
              (after the fidelity guards put moves back); with ``--base TREE`` (a checkout, e.g. a
              worktree of the commit before issue 31, whose relaxation drew random trials) the
              same from that tree in a child process, and how many sprites are no higher.
equivariance  for each sprite of ``--sprites`` (default the eight of issue 31), the mirrored (x,
              y) and quarter-turned image converted at ``--simplify 0``, mapped back: the largest
              difference of the optimized control points where the cells agree (px), and the
              share of pixels of an 8x rendering that differ by more than 64 levels; then the
              sprite against its own mirror image.
locality      ``--edits`` seeded one-pixel edits on each of five sprites: rendered pixels (8x)
              that changed farther than 4 source pixels from the edit (the count of
              ``shape_checks.py locality``), and curved edges farther than 4.5 px drawn with other
              numbers at the SVG's 0.01 px.
speed         per paper sprite the CPU time of ``depixel.convert(array)`` (min of ``--repeats``),
              alternated image by image with the peer's CPU time (libdepixelize's ``splines-opt``
              through ``--peer``, default /tmp/ldpx-harness/ldpx_harness, its median of 3 calls'
              process CPU; see ../shared/tools/libdepixelize/README.md); the medians and their
              ratio; a 256x224 frame; the CPU time of the whole ``depixel convert`` process against
              ``python -c "import numpy, PIL.Image"`` (median of ``--runs``).
batch         the paper sprites as one folder (``depixel convert DIR --out-dir OUT -j 1``): CPU ms
              a sprite, all of it counted (decode, write, stamps) less one process start, against
              the peer's tracing CPU a sprite; ``--rounds`` rounds alternated with the peer.

Needs ../shared/corpus (``--corpus``); the renders use cairosvg.
"""
from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse  # noqa: E402
import io  # noqa: E402
import json  # noqa: E402
import resource  # noqa: E402
import shutil  # noqa: E402
import statistics  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

import depixel  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_CORPUS = ROOT.parent / "shared" / "corpus"
EIGHT = ["smw_boo", "sma_toad", "win31_386", "mana_rabite", "smw_yoshi", "gaxe_skeleton", "invaders_01", "invaders_03"]
FIVE = ["smw_boo", "sma_toad", "win31_386", "mana_rabite", "smw_yoshi"]
SCALE = 8


def energies(paths: list[str]) -> dict[str, tuple[float, float, float]]:
    """Per image (name: before, after relaxing, of the output): E_s + E_p of the curves."""
    from depixel.optimize.corners import excluded_halves  # noqa: PLC0415
    from depixel.optimize.energy import Energy  # noqa: PLC0415

    out = {}
    for path in paths:
        opt = depixel.depixelize(depixel.load_image(path)).optimized
        splines = opt.splines
        model = Energy(splines, excluded_halves(splines, opt.corners.nodes))
        final = model.total(splines.controls_for(opt.positions), splines.controls_for(opt.initial))
        out[Path(path).stem] = (opt.energy_before, opt.energy_after, final)
    return out


def energy_section(corpus: Path, base: str | None) -> None:
    paths = [str(p) for p in sorted((corpus / "paper").glob("*.png"))]
    mine = energies(paths)
    rows = {"this tree": mine}
    if base:
        code = (f"import json, sys; sys.path.insert(0, {str(ROOT / 'benchmarks')!r}); "
                f"from bench_optimizer import energies; print(json.dumps(energies({paths!r})))")
        env = dict(os.environ, PYTHONPATH=os.pathsep.join([base, str(Path(base) / "cli")]))
        with tempfile.TemporaryDirectory() as tmp:  # not this tree's folder first on the path
            run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, check=True,
                                 cwd=tmp)
        rows["base " + base] = {k: tuple(v) for k, v in json.loads(run.stdout.splitlines()[-1]).items()}
    print(f"\n== energy E_s + E_p, {len(paths)} paper sprites (mean)")
    print(f"{'tree':<40} {'before':>9} {'relaxed':>9} {'output':>9}")
    for label, table in rows.items():
        print(f"{label:<40}", *(f"{statistics.fmean(v[i] for v in table.values()):9.3f}" for i in range(3)))
    if base:
        theirs = rows["base " + base]
        for i, what in ((1, "relaxed"), (2, "output")):
            lower = sum(mine[k][i] <= theirs[k][i] for k in mine)
            worse = sorted(k for k in mine if mine[k][i] > theirs[k][i])
            print(f"{what}: this tree no higher on {lower} of {len(mine)}; higher: {', '.join(worse) or '-'}")


def render(svg: str) -> np.ndarray:
    import cairosvg  # noqa: PLC0415
    from PIL import Image  # noqa: PLC0415

    png = cairosvg.svg2png(bytestring=svg.encode(), scale=SCALE)
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGBA")).astype(np.int16)


def differ(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.abs(a - b).max(-1) > 64


TRANSFORMS = (("mirror_x", lambda a: a[:, ::-1], lambda x: x[:, ::-1], lambda p, w, h: (w - p[:, 0], p[:, 1])),
              ("mirror_y", lambda a: a[::-1], lambda x: x[::-1], lambda p, w, h: (p[:, 0], h - p[:, 1])),
              ("turn", np.rot90, lambda x: np.rot90(x, -1), lambda p, w, h: (w - p[:, 1], p[:, 0])))


def control_point_difference(rgba: np.ndarray, image: np.ndarray, back) -> float | None:
    """Largest difference (px) of the optimized positions of ``image`` mapped back by ``back``
    from those of ``rgba``; None where the cells differ."""
    h, w = rgba.shape[:2]
    runs = [depixel.depixelize(np.ascontiguousarray(a)).optimized for a in (rgba, image)]
    nodes = [r.splines.cells.nodes.astype(np.int64) for r in runs]
    mapped = np.stack(back(nodes[1], 4 * w, 4 * h), axis=1)
    order = [np.lexsort((q[:, 1], q[:, 0])) for q in (nodes[0], mapped)]
    if nodes[0].shape != mapped.shape or not np.array_equal(nodes[0][order[0]], mapped[order[1]]):
        return None
    theirs = np.stack(back(runs[1].positions, w, h), axis=1)
    return float(np.abs(runs[0].positions[order[0]] - theirs[order[1]]).max())


def equivariance_section(corpus: Path, names: list[str]) -> None:
    print("\n== equivariance at --simplify 0: control points (max px; '-' where the cells differ) "
          "and rendered pixels (8x, share differing)")
    print(f"{'sprite':<16}" + "".join(f"{t[0]:>22}" for t in TRANSFORMS) + f"{'self mirror':>13}")
    for name in names:
        rgba = depixel.load_image(corpus / "paper" / f"{name}.png")
        rendered = render(depixel.convert(rgba, simplify=0))
        cells = [f"{name:<16}"]
        for _, image_of, back_render, back_points in TRANSFORMS:
            image = np.ascontiguousarray(image_of(rgba))
            share = float(differ(rendered, back_render(render(depixel.convert(image, simplify=0)))).mean())
            points = control_point_difference(rgba, image, back_points)
            cells.append(f"{'-' if points is None else f'{points:.1e}':>10} {share:10.4%}")
        cells.append(f"{float(differ(rendered, rendered[:, ::-1]).mean()):13.4%}")
        print("".join(cells))


def edited(rgba: np.ndarray, x: int, y: int) -> np.ndarray:
    """``shape_checks.py locality``'s edit: pixel (x, y) takes the colour below it, or its inverse."""
    out = rgba.copy()
    below = rgba[min(y + 1, rgba.shape[0] - 1), x, :3]
    out[y, x, :3] = below if (rgba[y, x, :3] != below).any() else 255 - rgba[y, x, :3]
    return out


def far_edges(a: depixel.VectorImage, b: depixel.VectorImage, x: int, y: int) -> int:
    """Curved edges of ``a`` with both nodes farther than 4.5 px from pixel (x, y)'s centre
    that ``b`` draws with other numbers at 0.01 px (or not at all)."""
    def table(v: depixel.VectorImage) -> dict[tuple, np.ndarray]:
        nodes = v.cells.nodes.astype(np.int64)
        out = {}
        for e in np.flatnonzero(v.curved):
            u, w = v.cells.edges[e]
            key = tuple(sorted([tuple(nodes[u]), tuple(nodes[w])]))
            out[key] = np.round(np.concatenate([v.points[[u, w]].ravel(), v.controls[e].ravel()]), 2)
        return out
    mine, theirs = table(a), table(b)
    return sum(1 for key, numbers in mine.items()
               if (np.abs(np.array(key) / 4.0 - [x + 0.5, y + 0.5]).max(axis=1) > 4.5).all()
               and (key not in theirs or not np.array_equal(theirs[key], numbers)))


def locality_section(corpus: Path, names: list[str], edits: int) -> None:
    print(f"\n== locality at --simplify 0: {edits} seeded one-pixel edits a sprite "
          "(rendered pixels > 4 px away; curved edges > 4.5 px away drawn otherwise)")
    rng = np.random.default_rng(20261203)  # shape_checks.py's seed: the same edits
    total_pixels = total_edges = 0
    for name in names:
        rgba = depixel.load_image(corpus / "paper" / f"{name}.png")
        vector = depixel.depixelize(rgba).vector
        rendered = render(depixel.to_svg(vector, simplify=0))
        opaque = np.argwhere(rgba[..., 3] == 255)
        pixels, edges = [], []
        for _ in range(edits):
            y, x = opaque[rng.integers(len(opaque))]
            other = depixel.depixelize(edited(rgba, x, y)).vector
            yy, xx = np.nonzero(differ(rendered, render(depixel.to_svg(other, simplify=0))))
            pixels.append(int(((np.abs(yy / SCALE - (y + 0.5)) > 4.5) | (np.abs(xx / SCALE - (x + 0.5)) > 4.5)).sum()))
            edges.append(far_edges(vector, other, int(x), int(y)))
        total_pixels, total_edges = total_pixels + sum(pixels), total_edges + sum(edges)
        print(f"{name:<16} far pixels {pixels}  far edges {edges}")
    print(f"{'all':<16} far pixels {total_pixels}  far edges {total_edges}")


def peer_ms(peer: str, path: Path, out: Path) -> float:
    """The peer's tracing CPU time (ms) of one image: the median of 3 calls, the process CPU
    time its harness reports (the last two columns: median, min), not the wall time, which
    counts the other jobs of a shared machine too."""
    line = subprocess.run([peer, "splines-opt", str(path), str(out), "3"], capture_output=True, text=True,
                          check=True).stdout.split("\t")
    return float(line[-2])


def child_cpu(command: list[str], env: dict[str, str] | None = None) -> float:
    """CPU seconds (user + system) of running ``command`` to its end."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run(command, check=True, env=env, capture_output=True)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime


def depixel_ms(rgba: np.ndarray, repeats: int) -> float:
    best = float("inf")
    for _ in range(repeats):
        start = time.process_time()
        depixel.convert(rgba)
        best = min(best, time.process_time() - start)
    return best * 1e3


def speed_section(corpus: Path, peer: str, repeats: int, runs: int) -> None:
    paths = sorted((corpus / "paper").glob("*.png"))
    print(f"\n== speed: CPU ms a sprite (min of {repeats}), alternated with the peer (median of 3)")
    have_peer = Path(peer).is_file()
    ours, theirs = [], []
    with tempfile.TemporaryDirectory() as tmp:
        for i, path in enumerate(paths):
            rgba = depixel.load_image(path)
            depixel.convert(rgba)  # warm
            first_ours = i % 2 == 0 or not have_peer
            if not first_ours:
                theirs.append(peer_ms(peer, path, Path(tmp) / "peer.svg"))
            ours.append(depixel_ms(rgba, repeats))
            if first_ours and have_peer:
                theirs.append(peer_ms(peer, path, Path(tmp) / "peer.svg"))
    line = f"depixel median {statistics.median(ours):.1f} ms (max {max(ours):.1f})"
    if have_peer:
        ratio = statistics.median(a / b for a, b in zip(ours, theirs))
        line += f"; peer median {statistics.median(theirs):.1f} ms; per-sprite ratio median {ratio:.2f}"
    else:
        line += f"; no peer at {peer} (build it: ../shared/tools/libdepixelize/README.md)"
    print(line)
    frames = sorted((corpus / "frames").glob("*.png"))
    if frames:
        frame = depixel.load_image(frames[0])
        print(f"frame {frames[0].name} {frame.shape[1]}x{frame.shape[0]}: {depixel_ms(frame, 3) / 1e3:.3f} s")
    with tempfile.TemporaryDirectory() as tmp:
        env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
        commands = {"depixel convert": [sys.executable, "-m", "depixel", "convert", str(paths[0]), "-o",
                                        str(Path(tmp) / "o.svg"), "-q"],
                    "import numpy, PIL.Image": [sys.executable, "-c", "import numpy, PIL.Image"]}
        seconds: dict[str, list[float]] = {k: [] for k in commands}
        for _ in range(runs):
            for label, command in commands.items():
                seconds[label].append(child_cpu(command, env))
    convert, floor = (statistics.median(seconds[k]) for k in commands)
    print(f"whole process {paths[0].name}: {convert * 1e3:.0f} ms CPU against {floor * 1e3:.0f} ms "
          f"(ratio {convert / floor:.2f})")


def batch_section(corpus: Path, peer: str, rounds: int) -> None:
    """The paper sprites as one folder, ``depixel convert DIR --out-dir OUT -j 1``: the CPU time
    of the whole process (decode, conversion, writing, stamps) less one process start (the
    CPU of ``python -c "import depixel_cli.main, ..."``: the interpreter, numpy, Pillow, depixel and
    the command's modules), per sprite; against the peer's tracing CPU per sprite (the harness's
    median of 3 calls a sprite; their mean, the batch's like, and median). Rounds alternate."""
    paths = sorted((corpus / "paper").glob("*.png"))
    print(f"\n== batch: {len(paths)} paper sprites as one folder, -j 1, CPU ms a sprite (one start subtracted)")
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    start_command = [sys.executable, "-c", "import depixel_cli.main, depixel_cli.convert.command"]
    have_peer = Path(peer).is_file()
    ours, starts, peer_mean, peer_median = [], [], [], []
    with tempfile.TemporaryDirectory() as tmp:
        for _ in range(rounds):
            out = Path(tmp) / "out"
            shutil.rmtree(out, ignore_errors=True)
            ours.append(child_cpu([sys.executable, "-m", "depixel", "convert", str(corpus / "paper"), "--out-dir",
                                   str(out), "-j", "1", "-q"], env))
            starts.append(child_cpu(start_command, env))
            if have_peer:
                each = [peer_ms(peer, path, Path(tmp) / "peer.svg") for path in paths]
                peer_mean.append(statistics.fmean(each))
                peer_median.append(statistics.median(each))
    start = statistics.median(starts)
    per_sprite = [(cpu - start) / len(paths) * 1e3 for cpu in ours]
    each_round = ", ".join(f"{x:.1f}" for x in per_sprite)
    line = (f"depixel {statistics.median(per_sprite):.1f} ms a sprite (rounds {each_round}; "
            f"batch {statistics.median(ours):.2f} s, start {start * 1e3:.0f} ms)")
    if have_peer:
        mean, median = statistics.median(peer_mean), statistics.median(peer_median)
        ratio = statistics.median(a / b for a, b in zip(per_sprite, peer_mean))
        line += (f"; peer {mean:.1f} ms a sprite (mean; median {median:.1f}); ratio to the mean {ratio:.2f}, "
                 f"to the median {statistics.median(per_sprite) / median:.2f}")
    print(line)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("sections", nargs="*", choices=["energy", "equivariance", "locality", "speed", "batch"],
                        default=["energy", "equivariance", "locality", "speed", "batch"])
    parser.add_argument("--corpus", type=Path, default=DEFAULT_CORPUS)
    parser.add_argument("--base", help="another source tree to compare the energies with")
    parser.add_argument("--sprites", default=",".join(EIGHT), help="sprites of the equivariance section")
    parser.add_argument("--edits", type=int, default=3)
    parser.add_argument("--peer", default="/tmp/ldpx-harness/ldpx_harness")
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--runs", type=int, default=11)
    parser.add_argument("--rounds", type=int, default=3, help="rounds of the batch section")
    args = parser.parse_args()
    if not (args.corpus / "paper").is_dir():
        parser.error(f"no corpus at {args.corpus} (--corpus DIR with paper/ and frames/)")
    if "energy" in args.sections:
        energy_section(args.corpus, args.base)
    if "equivariance" in args.sections:
        equivariance_section(args.corpus, args.sprites.split(","))
    if "locality" in args.sections:
        locality_section(args.corpus, FIVE, args.edits)
    if "speed" in args.sections:
        speed_section(args.corpus, args.peer, args.repeats, args.runs)
    if "batch" in args.sections:
        batch_section(args.corpus, args.peer, args.rounds)
    return 0


if __name__ == "__main__":
    sys.exit(main())
