"""Count the numpy calls a conversion makes, per depixel module (issue 44: the fixed cost a sprite).

    python benchmarks/count_calls.py                     # the 54 paper sprites, mean per sprite
    python benchmarks/count_calls.py a.png b.png --top 30
    python benchmarks/count_calls.py --functions         # per function instead of per module
    python benchmarks/count_calls.py --packed 16         # as a batch runs them: 16 pipelines a pass

A numpy call is counted where depixel's code calls into numpy: a ufunc, a numpy function (C or
Python; the calls numpy makes inside it are not counted again) or an array method, each charged
to the depixel module (or function) that made it (a helper's, ``arrays`` and the like, to its
caller). Array operators and indexing (``a + b``,
``a[i]``) raise no profiler event and are not counted, so the counts are a lower bound of the
calls that pay numpy's fixed cost; they move the same way when a stage makes fewer, larger calls.
What is converted is ``depixel.convert(array)`` with the default options (the SVG text).
"""
from __future__ import annotations

import argparse
import sys
from collections import Counter
from pathlib import Path

import numpy as np

import depixel

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_CORPUS = ROOT.parent / "shared" / "corpus"
NUMPY_DIR = str(Path(np.__file__).parent)
DEPIXEL_DIR = str(Path(depixel.__file__).parent)
#: ground-floor modules whose calls are charged to the module that called them
HELPERS = frozenset({"arrays", "frozen", "curves/bspline", "graph/components"})


def _is_numpy(func) -> bool:
    """A C callable of numpy's: a ufunc, a numpy builtin function or an array's method."""
    if isinstance(func, np.ufunc):
        return True
    owner = getattr(func, "__self__", None)
    if isinstance(owner, (np.ndarray, np.generic)):
        return True
    return str(getattr(func, "__module__", None) or "").startswith("numpy")


def count(images: list[np.ndarray], by_function: bool = False, packed: int = 0) -> Counter[str]:
    """numpy calls made by depixel's code while converting ``images``, keyed by module or function;
    with ``packed``, that many images at a time in one pass (:func:`depixel.api.passes`, as a
    folder batch runs them: their pipelines and their outlines' simplification together)."""
    counts: Counter[str] = Counter()
    cut = len(DEPIXEL_DIR) + 1

    def key(frame) -> str:
        while frame.f_code.co_filename[cut:-3] in HELPERS and frame.f_back is not None \
                and frame.f_back.f_code.co_filename.startswith(DEPIXEL_DIR):
            frame = frame.f_back  # a helper's calls are its caller's
        name = frame.f_code.co_filename[cut:-3]
        return f"{name}:{frame.f_code.co_name}" if by_function else name

    def hook(frame, event, arg) -> None:
        if event == "c_call":
            if frame.f_code.co_filename.startswith(DEPIXEL_DIR) and _is_numpy(arg):
                counts[key(frame)] += 1
        elif event == "call" and frame.f_code.co_filename.startswith(NUMPY_DIR):
            caller = frame.f_back
            if caller is not None and caller.f_code.co_filename.startswith(DEPIXEL_DIR):
                counts[key(caller)] += 1

    if packed:
        from depixel.options import ConvertOptions

        for first in range(0, len(images), packed):
            sys.setprofile(hook)
            try:
                with depixel.api.passes(images[first:first + packed], ConvertOptions(), ["svg"]):
                    for image in images[first:first + packed]:
                        depixel.convert(image)
            finally:
                sys.setprofile(None)
        return counts
    for image in images:
        sys.setprofile(hook)
        try:
            depixel.convert(image)
        finally:
            sys.setprofile(None)
    return counts


STAGES = (("prepare", ("prepare/", "api", "validate", "limits")), ("graph", ("graph/",)),
          ("curves", ("curves/",)), ("corners", ("optimize/corners",)),
          ("relaxation", ("optimize/relax", "optimize/energy", "optimize/trials", "optimize/junctions")),
          ("harmonic", ("optimize/harmonic",)), ("fidelity", ("optimize/fidelity",)),
          ("simplification", ("svg/simplify", "svg/breaks", "svg/curvefit", "svg/reference")),
          ("svg other", ("svg/",)))


def stage_of(module: str) -> str:
    """The stage row a module's calls are added to."""
    for stage, prefixes in STAGES:
        if module.startswith(prefixes):
            return stage
    return "other"


def main() -> None:
    """Print the mean counts per sprite: per stage, then the largest modules or functions."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("images", nargs="*", help="PNG files (default: the paper corpus)")
    parser.add_argument("--corpus", type=Path, default=DEFAULT_CORPUS)
    parser.add_argument("--functions", action="store_true", help="per function, not per module")
    parser.add_argument("--top", type=int, default=25)
    parser.add_argument("--packed", type=int, default=0, metavar="N",
                        help="the pipelines of N images at a time in one pass (the calls a sprite in a batch)")
    args = parser.parse_args()
    paths = [Path(p) for p in args.images] or sorted((args.corpus / "paper").glob("*.png"))
    if not paths:
        sys.exit("no images (give PNG files or --corpus with paper/*.png)")
    images = [depixel.api.load(str(p)) for p in paths]
    depixel.convert(images[0])  # imports and first-call set-up outside the counts
    counts = count(images, args.functions, args.packed)
    n = len(images)
    stages: Counter[str] = Counter()
    for name, calls in counts.items():
        stages[stage_of(name.split(":")[0])] += calls
    print(f"numpy calls per sprite (mean of {n}): {sum(counts.values()) / n:,.0f}")
    for stage, _ in (*STAGES, ("other", ())):
        if stages[stage]:
            print(f"  {stage:<16}{stages[stage] / n:>9,.0f}")
    print(f"largest {'functions' if args.functions else 'modules'}:")
    for name, calls in counts.most_common(args.top):
        print(f"  {name:<48}{calls / n:>9,.1f}")


if __name__ == "__main__":
    main()
