"""Batches in one pass (issue 44): many images' pipelines run together give each image the
bytes it gets alone, and a failing image fails alone."""
from __future__ import annotations

import contextlib
import shutil

import numpy as np
import pytest
from conftest import CORPUS, FIXTURES, art, corpus_pngs, fixture_pngs, needs_corpus

import depixel
import depixel.pipeline as pipeline
from depixel.files.convert import convert_file
from depixel.optimize import pack
from depixel_cli.main import main
from depixel_cli.options import Exit


def _folder_against_single(tmp_path, sources, monkeypatch) -> None:
    """``depixel convert DIR --out-dir OUT -j 1`` writes, for every file, the bytes of that file
    converted alone, and the batch's pipelines did run in packs."""
    src = tmp_path / "in"
    src.mkdir()
    for path in sources:
        shutil.copy(path, src / path.name)
    packs = []
    many = pipeline.depixelize_many
    monkeypatch.setattr(pipeline, "depixelize_many",
                        lambda images, *a, **k: packs.append(len(images)) or many(images, *a, **k))
    assert main(["convert", str(src), "--out-dir", str(tmp_path / "batch"), "-j", "1", "-q"]) == Exit.OK
    assert sum(packs) >= len(sources) - 1 and max(packs) > 1
    (tmp_path / "alone").mkdir()
    for path in sorted(src.iterdir()):
        alone = convert_file(path, tmp_path / "alone" / f"{path.stem}.svg")
        assert (tmp_path / "batch" / alone.name).read_bytes() == alone.read_bytes(), path.name


def test_a_folder_of_fixtures_gives_the_bytes_of_each_file_alone(tmp_path, monkeypatch):
    _folder_against_single(tmp_path, fixture_pngs(), monkeypatch)


@needs_corpus
def test_the_paper_corpus_as_a_folder_gives_the_bytes_of_each_sprite_alone(tmp_path, monkeypatch):
    _folder_against_single(tmp_path, corpus_pngs(), monkeypatch)


def _images() -> list[np.ndarray]:
    return [depixel.load_image(path) for path in fixture_pngs()] + \
        ([depixel.load_image(path) for path in sorted(CORPUS.glob("*.png"))[:12]] if CORPUS.is_dir() else [])


def test_any_grouping_gives_the_results_of_one_image_at_a_time():
    images = _images()
    alone = [depixel.to_svg(depixel.depixelize(image).vector) for image in images]
    for size in (2, 5, 64):
        for first in range(0, len(images), size):
            results = pipeline.depixelize_many(images[first:first + size])
            for i, result in enumerate(results, first):
                assert isinstance(result, depixel.Result)
                assert depixel.to_svg(result.vector) == alone[i], (size, i)


def test_a_pass_places_every_node_and_draws_every_curve_as_alone_to_the_last_bit():
    """The harmonic map's linear systems solved as one (each image's its own part) and the
    walk-back over the pass's record: positions and drawings equal, not merely their SVG
    (whose 0.01 px rounding would hide a different last bit)."""
    alone = [depixel.depixelize(image).optimized for image in _images()]
    items = [(result.splines, result.corners) for result in alone if result is not None]
    for first in range(0, len(items), 16):
        for one, joined in zip(alone[first:first + 16], pack.optimize_many(items[first:first + 16])):
            assert one is not None
            assert np.array_equal(joined.initial, one.initial)
            assert np.array_equal(joined.positions, one.positions)
            for field in ("points", "edges", "controls", "ctrl"):
                assert np.array_equal(getattr(joined.drawing, field), getattr(one.drawing, field)), field


@needs_corpus
def test_images_whose_rounds_stop_at_different_rounds_stop_where_they_would_alone():
    """The corpus's relaxations run all ten rounds; with forty, the invaders stop after 22 to
    39 while the others go on: each must sit the rounds after its own last one out."""
    params = depixel.Params(iterations=40, snap_passes=1)
    images = [depixel.load_image(path) for path in corpus_pngs()[:16]]
    alone = [depixel.to_svg(depixel.depixelize(image, params).vector) for image in images]
    results = pipeline.depixelize_many(images, params)
    for i, result in enumerate(results):
        assert isinstance(result, depixel.Result)
        assert depixel.to_svg(result.vector) == alone[i]


def test_an_image_that_fails_fails_alone(monkeypatch):
    images = [art(".#.\n###\n.#."), art("##\n#."), depixel.load_image(FIXTURES / "heart.png")]
    build = pipeline.build_similarity_graph

    def failing(rgba, params):
        if rgba.shape[:2] == (2, 2):
            raise RuntimeError("this one")
        return build(rgba, params)

    monkeypatch.setattr(pipeline, "build_similarity_graph", failing)
    results = pipeline.depixelize_many(images)
    assert isinstance(results[1], RuntimeError)
    for i in (0, 2):
        assert depixel.to_svg(results[i].vector) == depixel.to_svg(depixel.depixelize(images[i]).vector)


def test_when_the_pass_fails_each_image_is_optimized_alone(monkeypatch):
    images = [depixel.load_image(FIXTURES / name) for name in ("heart.png", "ghost.png", "leaf.png")]
    expected = [depixel.to_svg(depixel.depixelize(image).vector) for image in images]
    joined = pack.join

    def refuse_three(curves, *rest):
        if len(curves) > 1:
            raise MemoryError
        return joined(curves, *rest)

    monkeypatch.setattr(pack, "join", refuse_three)
    assert [depixel.to_svg(r.vector) for r in pipeline.depixelize_many(images)] == expected


def test_results_ahead_are_taken_once_and_only_for_the_same_pixels():
    heart, ghost = (depixel.load_image(FIXTURES / name) for name in ("heart.png", "ghost.png"))
    with pipeline.ahead([heart, ghost]):
        first = depixel.depixelize(heart)
        assert depixel.depixelize(heart) is not first  # taken once: computed again
        other = heart.copy()
        other[0, 0] = 255 - other[0, 0]
        assert depixel.depixelize(other).vector is not None  # other pixels: computed, no error
        assert depixel.depixelize(ghost, stage="cells").optimized is None  # another stage: computed
    assert not pipeline._AHEAD  # dropped at the end of the block


def _passes(monkeypatch) -> list[int]:
    """The sizes of the passes of depixelize_many from now on."""
    sizes: list[int] = []
    many = pipeline.depixelize_many
    monkeypatch.setattr(pipeline, "depixelize_many",
                        lambda images, *a, **k: sizes.append(len(images)) or many(images, *a, **k))
    return sizes


def _no_passes(monkeypatch) -> None:
    import depixel.api

    monkeypatch.setattr(depixel.api, "_in_passes", lambda *a, **k: contextlib.nullcontext())


def test_a_sheets_sprites_run_in_one_pass_with_the_same_bytes(monkeypatch):
    from depixel.files.sheet import convert_sheet
    from depixel.prepare.sheet import find_sprites

    images = [depixel.load_image(FIXTURES / name) for name in ("ghost_rgba.png", "potion_rgba.png", "orb.png")]
    board = np.zeros((max(i.shape[0] for i in images), sum(i.shape[1] + 2 for i in images), 4), np.uint8)
    x = 0
    for image in images:
        board[:image.shape[0], x:x + image.shape[1]] = image
        x += image.shape[1] + 2
    sprites = find_sprites(board).sprites
    passes = _passes(monkeypatch)
    together = convert_sheet(board, sprites, layout="cutout")
    assert passes == [3]
    _no_passes(monkeypatch)
    assert convert_sheet(board, sprites, layout="cutout") == together and passes == [3]


def test_an_animations_frames_run_in_passes_with_the_same_bytes(monkeypatch):
    from depixel.prepare.animation import Animation

    base = depixel.load_image(FIXTURES / "chip.png")
    y, x = base.shape[0] // 2 - 1, base.shape[1] // 2 - 1
    frames = [base]
    for k in range(19):  # 20 frames: a light in the chip's middle, blinking in 19 colours
        frame = base.copy()
        frame[y:y + 2, x:x + 2] = (12 * k, 240 - 12 * k, 90, 255)
        frames.append(frame)
    animation = Animation(tuple(frames), (100.0,) * len(frames), 0)
    passes = _passes(monkeypatch)
    together = depixel.convert(animation, animate=True, simplify=0)
    assert sum(passes) == len({f.tobytes() for f in frames}) and max(passes) == 16
    _no_passes(monkeypatch)
    assert depixel.convert(animation, animate=True, simplify=0) == together


def test_workers_take_packs_and_a_file_that_kills_its_worker_fails_alone(tmp_path, monkeypatch):
    """-j 2: the workers convert packs of files (the bytes of each file alone); a pack whose
    worker dies on every try is converted again file by file, so only the file that kills
    its worker fails."""
    import os

    from depixel.options import ConvertOptions
    from depixel_cli import pool
    from depixel_cli.convert import batch, packs
    from depixel_cli.convert import run as batch_run

    names = [p.name for p in fixture_pngs() if p.suffix == ".png"]
    options = batch.Options(ConvertOptions(), ("svg",), "first", force=False)
    (tmp_path / "out").mkdir()
    jobs = [batch.Job(FIXTURES / name, tmp_path / "out" / f"{name}.svg", options) for name in names]
    poison = jobs[3].source

    alive = packs.run_pack

    def run_pack(pack):
        if any(job.source == poison for job in pack):
            os._exit(9)
        return alive(pack)

    def run_job(job):
        if job.source == poison:
            os._exit(9)
        return batch.run_job(job)

    monkeypatch.setattr(packs, "run_pack", run_pack)
    monkeypatch.setattr(batch_run, "run_job", run_job)
    with pool.Signals(raising=False) as signals:
        outcomes = batch_run.run(jobs, 2, lambda outcome: None, signals)
    assert len(packs.packs(len(jobs), 2)) < len(jobs)
    for job, outcome in zip(jobs, outcomes):
        if job.source == poison:
            assert "worker process died" in outcome.error and not outcome.written
        else:
            assert outcome.error is None and outcome.written == [job.output]
            alone = convert_file(job.source, tmp_path / "alone.svg")
            assert job.output.read_bytes() == alone.read_bytes(), job.source.name


def test_auto_jobs_counts_a_packs_pass_not_one_small_image(tmp_path):
    """A worker holds a pass of up to PASS_IMAGES images at once: -j auto plans its memory for
    that many of the largest image (up to PASS_PIXELS), not for one."""
    from PIL import Image

    from depixel.limits import PEAK_BYTES_PER_PIXEL, WORKER_BASELINE_BYTES
    from depixel.pipeline import PASS_IMAGES, PASS_PIXELS
    from depixel_cli.convert import batch
    from depixel_cli.convert import run as batch_run

    if batch_run.cores() < 2:
        pytest.skip("one core: -j auto is 1 whatever the memory")
    w, h = Image.open(FIXTURES / "heart.png").size
    jobs = [batch.Job(FIXTURES / "heart.png", tmp_path / f"{i}.svg", None) for i in range(8)]
    one = WORKER_BASELINE_BYTES + PEAK_BYTES_PER_PIXEL * w * h
    a_pass = WORKER_BASELINE_BYTES + PEAK_BYTES_PER_PIXEL * min(PASS_PIXELS, PASS_IMAGES * w * h)
    assert a_pass > one
    assert batch_run.auto_jobs(jobs, memory=2 * one, asked=2)[0] == 1  # two single images fit, not two passes
    assert batch_run.auto_jobs(jobs, memory=2 * a_pass, asked=2)[0] == 2


def test_outlines_simplified_together_give_each_image_its_own_svg(monkeypatch):
    """Within api.passes the SVG writer takes each image's outlines begun in its pass (the
    pieces of the pass's images simplified as one set); each SVG is the image's alone, at the
    default tolerance, another layout and tolerance, and with no simplification."""
    import depixel.svg.outlines as outlines
    from depixel.api import passes
    from depixel.options import ConvertOptions

    images = _images()
    taken = []
    begun = outlines.begun
    monkeypatch.setattr(outlines, "begun", lambda *a: taken.append(r := begun(*a)) or r)
    for keywords in ({}, {"layout": "cutout", "simplify": 0.1}, {"simplify": 0}):
        alone = [depixel.convert(image, **keywords) for image in images]
        taken.clear()
        with passes(images, ConvertOptions.build(**keywords), ["svg"]):
            together = [depixel.convert(image, **keywords) for image in images]
        assert together == alone
        assert all(r is not None for r in taken) and len(taken) == len(images)
