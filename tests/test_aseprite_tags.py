"""Aseprite tags played as animations (issue 42, item 5): ``--animate --tag NAME`` writes one
animated SVG (or APNG) of the tag's frames in the order and the number of times Aseprite plays
it, each with its duration; ``--animate`` alone writes a file per tag; the stamp holds the
tag. The files are written by tests/aseprite_writer.py; fixtures/aseprite/tags3.aseprite is a
real one (Aseprite's own tests)."""
from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
from aseprite_writer import FrameSpec, LayerSpec, aseprite_bytes, rgba_cel, tags_chunk
from conftest import FIXTURES
from PIL import Image
from test_animate_cli import timing
from test_sheet_cli import hero_frames, run, unstamped  # noqa: F401 (run: the fixture)

import depixel
from depixel.files import convert as files
from depixel.options import ConvertOptions
from depixel.prepare.aseprite import Tag, tag_playback
from depixel_cli.options import Exit

#: each frame's own duration, so a layer's label says which frame it is
DURATIONS = (110, 120, 130, 140)
#: (name, first, last, direction: 0 forward, 1 reverse, 2 ping-pong, 3 ping-pong reverse, repeat)
TAGS = [("walk", 0, 1, 0, 0), ("back", 1, 3, 1, 2), ("bounce", 0, 2, 2, 0), ("bounce3", 1, 3, 2, 3),
        ("hop", 2, 3, 3, 1)]
#: what each tag plays: the frames in order and the plays (0: for ever), as Aseprite plays it
PLAYED = {"walk": ([0, 1], 0), "back": ([3, 2, 1], 2), "bounce": ([0, 1, 2, 1], 0),
          "bounce3": ([1, 2, 3, 2, 1, 2, 3], 1), "hop": ([3, 2], 1)}


def hero_file(tags=TAGS) -> bytes:
    """The four frames of :func:`test_sheet_cli.hero_frames`, 110 to 140 ms, with ``tags``."""
    return aseprite_bytes(22, 16, [LayerSpec("body")], [FrameSpec([rgba_cel(0, f)], duration=d)
                                                        for f, d in zip(hero_frames(), DURATIONS)],
                          first_chunks=[tags_chunk(tags)])


def by_hand(tag: str) -> str:
    """The animated SVG of ``tag`` made from its frames picked by hand (PLAYED), not by a tag."""
    order, plays = PLAYED[tag]
    frames = hero_frames()
    animation = depixel.Animation(tuple(frames[i] for i in order), tuple(DURATIONS[i] for i in order), plays)
    return depixel.convert(animation, animate=True, title="hero.aseprite")


def test_a_tag_plays_as_aseprite_plays_it():
    """Cases of Aseprite's src/doc/playback_tests.cpp (SimplePingPong2, SimplePingPong3Repeats,
    FourTags): a ping-pong's repeat counts passes one way, each turning without showing the
    end twice; a forward or reverse tag's counts plays; 0 (not given) loops for ever."""
    cases = [(Tag("a", 0, 1, "pingpong", 2), [0, 1, 0], 1),
             (Tag("a", 0, 2, "pingpong", 3), [0, 1, 2, 1, 0, 1, 2], 1),
             (Tag("c", 6, 8, "pingpong", 3), [6, 7, 8, 7, 6, 7, 8], 1),
             (Tag("d", 10, 12, "pingpong reverse", 2), [12, 11, 10, 11, 12], 1),
             (Tag("b", 3, 5, "reverse", 2), [5, 4, 3], 2),
             (Tag("a", 1, 2, "forward", 0), [1, 2], 0),
             (Tag("p", 8, 11, "pingpong", 0), [8, 9, 10, 11, 10, 9], 0),  # looped: there and back
             (Tag("one", 4, 4, "pingpong", 3), [4], 3)]
    for tag, order, plays in cases:
        assert tag_playback([tag], tag.name) == (order, plays), tag


def test_animate_tag_writes_the_tags_frames_in_its_order_and_repeat_count(run):
    Path("hero.aseprite").write_bytes(hero_file())
    for tag in PLAYED:
        code, err = run("hero.aseprite", "--animate", "--tag", tag, "-o", f"{tag}.svg")
        assert (code, err) == (Exit.OK, ""), tag
        assert unstamped(Path(f"{tag}.svg").read_text()) == unstamped(by_hand(tag)), tag
    got = timing(Path("back.svg"))
    assert [g["label"] for g in got] == ["frame 1 (140 ms)", "frame 2 (130 ms)", "frame 3 (120 ms)"]
    assert {(g["dur"], g["repeatCount"], g.get("fill")) for g in got} == {("390ms", "2", "freeze")}
    assert {g["repeatCount"] for g in timing(Path("bounce.svg"))} == {"indefinite"}


def test_animate_tag_as_an_apng_of_the_tags_renders(run):
    Path("hero.aseprite").write_bytes(hero_file())
    assert run("hero.aseprite", "--animate", "--tag", "back", "-o", "back.png", "--scale", "2")[0] == Exit.OK
    with Image.open("back.png") as apng:
        assert (apng.n_frames, apng.info["loop"]) == (3, 2)
        shown = []
        for n in range(3):
            apng.seek(n)
            shown.append((apng.info["duration"], np.asarray(apng.convert("RGBA"))))
    for (duration, pixels), frame in zip(shown, (3, 2, 1)):
        assert run("hero.aseprite", "--frames", str(frame), "-o", f"f{frame}.png", "--scale", "2")[0] == Exit.OK
        assert duration == DURATIONS[frame]
        with Image.open(f"f{frame}.png") as still:
            np.testing.assert_array_equal(pixels, np.asarray(still.convert("RGBA")))


def test_animate_without_tag_writes_a_file_per_tag_each_the_file_tag_writes(run):
    Path("hero.aseprite").write_bytes(hero_file())
    code, err = run("hero.aseprite", "--animate", "--out-dir", "out")
    assert code == Exit.OK and "1 converted" in err
    assert sorted(p.name for p in Path("out").iterdir()) == sorted(f"hero-{tag}.svg" for tag in PLAYED)
    for tag in PLAYED:  # the very file --tag writes: same options, same stamp, same bytes
        assert run("hero.aseprite", "--animate", "--tag", tag, "-o", f"{tag}.svg")[0] == Exit.OK
        assert Path(f"out/hero-{tag}.svg").read_bytes() == Path(f"{tag}.svg").read_bytes(), tag
    # so each run leaves the other's outputs up to date
    assert "0 converted, 1 up to date" in run("hero.aseprite", "--animate", "--tag", "hop", "--out-dir", "out")[1]
    assert "0 converted, 1 up to date" in run("hero.aseprite", "--animate", "--out-dir", "out")[1]
    # -o FILE: FILE-{tag}.svg; --name places {tag} (without it: NAME-{tag}), beside the input too
    assert run("hero.aseprite", "--animate", "-o", "anim.svg")[0] == Exit.OK
    assert Path("anim-back.svg").read_bytes() == Path("back.svg").read_bytes()
    assert not Path("anim.svg").exists()
    assert run("hero.aseprite", "--animate", "--out-dir", "named", "--name", "{tag}.{stem}")[0] == Exit.OK
    assert sorted(p.name for p in Path("named").iterdir()) == sorted(f"{tag}.hero.svg" for tag in PLAYED)
    assert run("hero.aseprite", "--animate", "--format", "svg,png")[0] == Exit.OK
    assert {p.name for p in Path(".").glob("hero-*")} == {f"hero-{tag}.{ext}" for tag in PLAYED
                                                           for ext in ("svg", "png")}


def test_the_stamp_holds_the_tag(run):
    Path("hero.aseprite").write_bytes(hero_file())
    options = {tag: ConvertOptions.build(animate=True, tag=tag) for tag in (None, "walk", "back")}
    digests = {tag: files.file_target("a.svg", made).digest for tag, made in options.items()}
    assert len(set(digests.values())) == 3
    assert digests[None] == files.file_target("a.svg", ConvertOptions.build(animate=True)).digest
    assert run("hero.aseprite", "--animate", "--tag", "back", "--out-dir", "out")[0] == Exit.OK
    # an output of another tag under this one's name is stale (depixel's, unedited): converted again
    shutil.copy("out/hero-back.svg", "out/hero-walk.svg")
    code, err = run("hero.aseprite", "--animate", "--tag", "walk", "--out-dir", "out")
    assert code == Exit.OK and "1 converted, 0 up to date" in err
    assert unstamped(Path("out/hero-walk.svg").read_text()) == unstamped(by_hand("walk"))
    assert "0 converted, 1 up to date" in run("hero.aseprite", "--animate", "--tag", "walk", "--out-dir", "out")[1]


def test_an_unknown_tag_or_a_file_without_tags_is_one_line_and_no_output(run):
    Path("hero.aseprite").write_bytes(hero_file())
    for destination in (["-o", "run.svg"], ["--out-dir", "out"]):
        code, err = run("hero.aseprite", "--animate", "--tag", "run", *destination)
        assert code == Exit.FAILED
        assert ("depixel: error: hero.aseprite: no tag 'run'; its tags: 'walk', 'back', 'bounce', 'bounce3', "
                "'hop'\n") in err
    assert not Path("run.svg").exists() and not list(Path(".").glob("out/*"))
    shutil.copy(FIXTURES / "heart_beat.gif", "beat.gif")
    code, err = run("beat.gif", "--animate", "--tag", "walk", "-o", "beat.svg")
    assert code == Exit.FAILED and "beat.gif: not an Aseprite file, so it has no tags for --tag" in err
    assert not Path("beat.svg").exists()
    # a file without tags plays every frame, in one file, as before tags
    Path("plain.aseprite").write_bytes(hero_file(tags=[]))
    assert run("plain.aseprite", "--animate", "--out-dir", "plain")[0] == Exit.OK
    assert [p.name for p in Path("plain").iterdir()] == ["plain.svg"]
    assert len(timing(Path("plain/plain.svg"))) == 4
    code, err = run("hero.aseprite", "--name", "{tag}", "--out-dir", "x")
    assert code == Exit.USAGE and "--name's {tag} names the outputs of an Aseprite file's tags" in err


def test_two_tags_never_write_one_file(run):
    Path("slash.aseprite").write_bytes(hero_file(tags=[("a/b", 0, 1, 0, 0), ("a_b", 2, 3, 0, 0)]))
    Path("twice.aseprite").write_bytes(hero_file(tags=[("walk", 0, 1, 0, 0), ("walk", 2, 3, 0, 0)]))
    for destination in (["-o", "x.svg"], ["--out-dir", "out"]):
        code, err = run("slash.aseprite", "--animate", *destination)
        assert code == Exit.FAILED and "tags 'a/b' and 'a_b' would both be written to " in err
        code, err = run("twice.aseprite", "--animate", *destination)
        assert code == Exit.FAILED and "twice.aseprite: has two tags named 'walk'" in err
    assert not list(Path(".").glob("x*.svg")) and not list(Path(".").glob("out/*"))
    # one of them by name: the first of two of one name, as Aseprite's --tag
    assert run("twice.aseprite", "--animate", "--tag", "walk", "-o", "walk.svg")[0] == Exit.OK
    assert len(timing(Path("walk.svg"))) == 2
    assert run("slash.aseprite", "--animate", "--tag", "a/b", "--out-dir", "out")[0] == Exit.OK
    assert [p.name for p in Path("out").iterdir()] == ["slash-a_b.svg"]


def test_a_real_files_tags_animate(run):
    """tags3.aseprite (fixtures/aseprite/LICENSE.txt): 12 frames of 100 ms, tags forward 0-3,
    reverse 4-7, pingpong 8-11, none with a repeat count."""
    source = FIXTURES / "aseprite" / "tags3.aseprite"
    assert run(source, "--animate", "--out-dir", "out")[0] == Exit.OK
    whole = depixel.read_animation(source)
    for tag, order in (("forward", [0, 1, 2, 3]), ("reverse", [7, 6, 5, 4]), ("pingpong", [8, 9, 10, 11, 10, 9])):
        expected = depixel.convert(whole.select(order), animate=True, title="tags3.aseprite")
        assert unstamped(Path(f"out/tags3-{tag}.svg").read_text()) == unstamped(expected), tag
        assert {g["repeatCount"] for g in timing(Path(f"out/tags3-{tag}.svg"))} == {"indefinite"}
    code, err = run(source, "--animate", "-o", "-")
    assert code == Exit.OK and "has tags ('forward', 'reverse', 'pingpong'); -o - plays every frame" in err


def test_the_api_plays_a_tag(tmp_path):
    source = tmp_path / "hero.aseprite"
    source.write_bytes(hero_file())
    whole = depixel.read_animation(source)
    assert [t.name for t in whole.tags] == list(PLAYED) and depixel.read_animation(FIXTURES / "chip.png").tags == ()
    back = depixel.read_animation(source, tag="back")
    assert (len(back.frames), back.durations, back.plays, back.tags) == (3, (140.0, 130.0, 120.0), 2, ())
    assert depixel.convert(whole, animate=True, tag="back", title="hero.aseprite") == by_hand("back")
    assert depixel.convert(back, animate=True, title="hero.aseprite") == by_hand("back")
    png = depixel.convert_bytes(whole, "png", animate=True, tag="back")
    assert png == depixel.convert_bytes(back, "png", animate=True)
    depixel.convert_file(source, tmp_path / "back.svg", animate=True, tag="back")
    assert unstamped((tmp_path / "back.svg").read_text()) == unstamped(by_hand("back"))
    with pytest.raises(depixel.ParameterError, match="tag plays an Aseprite tag's frames as one animation: give "
                                                     "animate=True too"):
        depixel.convert_file(source, tmp_path / "x.svg", tag="back")
    with pytest.raises(depixel.ParameterError, match=r"give the Animation depixel.read_animation\(path\) reads"):
        depixel.convert(hero_frames()[0], animate=True, tag="back")
    with pytest.raises(depixel.InputError, match="^<animation>: no tag 'run'; its tags: 'walk', "):
        whole.tagged("run")
    with pytest.raises(depixel.ParameterError, match="give frames or tag, not both"):
        depixel.read_animation(source, frames=[0], tag="back")
