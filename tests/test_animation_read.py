"""Reading an animation with its timing (depixel/prepare/animation.py, gif.py, apng.py): each
frame as a browser shows it, the durations browsers play and the number of plays, on GIF, APNG,
WebP and Aseprite files written by the tests (tests/animfiles.py, tests/aseprite_writer.py);
the one-frame readers (load_image, load_frames) give the same frames."""
from __future__ import annotations

import io

import numpy as np
import pytest
from animfiles import GifImage, PngFrame, apng, gif
from aseprite_writer import FrameSpec, LayerSpec, aseprite_bytes, rgba_cel
from conftest import FIXTURES, art

from depixel.errors import InputError
from depixel.prepare.animation import Animation, gif_plays, played_duration, read_animation
from depixel.prepare.image import frame_count, load_frames, load_image

PALETTE = [(0, 0, 0), (255, 0, 0), (0, 255, 0), (0, 0, 255), (255, 255, 255)]
SHOWN = {"R": (255, 0, 0, 255), "G": (0, 255, 0, 255), "B": (0, 0, 255, 255), "W": (255, 255, 255, 255),
         "P": (50, 60, 70, 255), ".": (0, 0, 0, 0), "K": (0, 0, 0, 255)}
FULL = [[1, 1, 1, 1], [1, 2, 2, 1], [1, 2, 2, 1], [1, 1, 1, 1]]


def shown(text: str) -> np.ndarray:
    return art(text, SHOWN)


def disposal_gif(loop: int | None = None) -> bytes:
    """Five frames: a full one; a 2×2 with a transparent index, disposed to background; a 1×1
    with no disposal given; a 1×2 with its own palette, restored to previous; a 1×1."""
    return gif((4, 4), PALETTE, [
        GifImage(FULL, delay=20),
        GifImage([[3, 0], [0, 3]], x=1, y=1, transparent=0, delay=0, disposal=2),
        GifImage([[4]], delay=5),
        GifImage([[4, 4]], x=2, y=3, delay=30, disposal=3,
                 palette=[(9, 9, 9), (1, 2, 3), (0, 0, 0), (0, 0, 0), (50, 60, 70)]),
        GifImage([[2]], x=3, y=0, delay=1),
    ], loop=loop)


def test_gif_frames_are_what_a_browser_shows():
    # Pillow 13 gives frame 2 an opaque black square (it fills "restore to background" with
    # the background colour) and frame 3 a black corner (frame 2 inherits disposal 2)
    frames = read_animation(disposal_gif()).frames
    expected = ["RRRR RGGR RGGR RRRR", "RRRR RBGR RGBR RRRR", "WRRR R..R R..R RRRR", "WRRR R..R R..R RRPP",
                "WRRG R..R R..R RRRR"]
    assert len(frames) == len(expected)
    for n, (frame, rows) in enumerate(zip(frames, expected)):
        np.testing.assert_array_equal(frame, shown(rows.replace(" ", "\n")), err_msg=f"frame {n}")


def test_gif_durations_as_browsers_play_them():
    # hundredths 20, 0, 5, 30, 1: 10 ms or less plays as 100 ms
    assert read_animation(disposal_gif()).durations == (200.0, 100.0, 50.0, 300.0, 100.0)
    assert [played_duration(ms) for ms in (None, 0, 10, 11, 20)] == [100.0, 100.0, 100.0, 11.0, 20.0]


def test_a_gif_frame_without_control_block_plays_100_ms_and_keeps_what_it_covers():
    data = gif((2, 1), PALETTE, [GifImage([[1, 2]], delay=7, disposal=2), GifImage([[3]], control=False)])
    animation = read_animation(data)
    assert animation.durations == (70.0, 100.0)
    np.testing.assert_array_equal(animation.frames[1], shown("B."))


@pytest.mark.parametrize(("loop", "plays"), [(None, 1), (0, 0), (1, 2), (3, 4)])
def test_gif_loop_block_counts_repeats(loop, plays):
    assert gif_plays(loop) == plays
    assert read_animation(disposal_gif(loop)).plays == plays


def test_gif_frames_agree_with_pillow_where_pillow_composites_as_browsers():
    # full frames and disposal "none": what --frames all converts is what --animate converts
    data = gif((4, 4), PALETTE, [GifImage(FULL, disposal=1), GifImage([[3, 0], [0, 3]], x=1, y=1, transparent=0,
                                                                       disposal=1, palette=PALETTE[::-1])])
    for source in (data, FIXTURES / "heart_beat.gif"):
        ours = read_animation(source).frames
        pillows = [rgba for _, rgba in load_frames(source)]
        assert len(ours) == len(pillows) == 2
        for a, b in zip(ours, pillows):
            np.testing.assert_array_equal(a, b)


def test_gif_limits_count_every_frame():
    data = disposal_gif()  # five frames of 4×4
    with pytest.raises(InputError, match="over the limit of 4") as refused:
        read_animation(data, max_frames=4)
    assert refused.value.parameter == "max_frames"
    with pytest.raises(InputError, match="80 pixels in all") as refused:
        read_animation(data, max_pixels=79)
    assert refused.value.parameter == "max_pixels"
    assert len(read_animation(data, max_pixels=80, max_frames=5).frames) == 5


def test_a_truncated_gif_is_one_line_and_a_missing_trailer_is_not_an_error():
    data = disposal_gif()
    with pytest.raises(InputError, match="truncated or corrupt"):
        read_animation(data[: len(data) - 20], name="walk.gif")
    assert len(read_animation(data[:-1]).frames) == 5  # the trailer ";" left out
    with pytest.raises(InputError, match="truncated or corrupt"):
        read_animation(data[:-1] + b"\x99")


BLUE_HALF = (0, 0, 255, 128)


def disposal_apng(plays: int = 0, default: np.ndarray | None = None) -> bytes:
    """Four frames on 4×4: opaque red; a half-transparent blue 2×2 blended over it, disposed to
    background; a green pixel replacing, restored to previous; a white pixel."""
    def block(h, w, colour):
        return np.full((h, w, 4), colour, np.uint8)

    return apng((4, 4), [
        PngFrame(block(4, 4, SHOWN["R"]), delay=(1, 10)),
        PngFrame(block(2, 2, BLUE_HALF), x=1, y=1, delay=(1, 30), dispose=1, blend=1),
        PngFrame(block(1, 1, SHOWN["G"]), delay=(0, 10), dispose=2),
        PngFrame(block(1, 1, SHOWN["W"]), x=3, y=3, delay=(3, 0)),
    ], plays=plays, default=default)


def test_apng_frames_apply_blending_and_disposal():
    frames = read_animation(disposal_apng()).frames
    over = np.array([127, 0, 128, 255])  # half blue over red
    second = shown("RRRR RRRR RRRR RRRR".replace(" ", "\n")).astype(int)
    second[1:3, 1:3] = over
    assert np.abs(frames[1].astype(int) - second).max() <= 1
    np.testing.assert_array_equal(frames[2], shown("GRRR\nR..R\nR..R\nRRRR"))
    np.testing.assert_array_equal(frames[3], shown("RRRR\nR..R\nR..R\nRRRW"))


def test_apng_durations_and_plays():
    animation = read_animation(disposal_apng(plays=3))
    # 1/10 s, 1/30 s, 0 (plays as 100 ms), 3/100 s (a denominator of 0 means hundredths)
    assert animation.durations == pytest.approx((100.0, 1000 / 30, 100.0, 30.0))
    assert animation.plays == 3
    assert read_animation(disposal_apng(plays=0)).plays == 0


def test_an_apng_default_image_outside_the_animation_is_left_out():
    grey = np.full((4, 4, 4), 128, np.uint8)
    animation = read_animation(disposal_apng(default=grey))
    assert len(animation.frames) == 4
    np.testing.assert_array_equal(animation.frames[0], shown("RRRR\nRRRR\nRRRR\nRRRR"))


def test_animated_webp_frames_durations_and_plays():
    from PIL import Image, features

    if not features.check("webp"):
        pytest.skip("Pillow without WebP")
    frames = [shown(t) for t in ("RG\nB.", "GG\nB.", "RW\nWW")]
    buffer = io.BytesIO()
    images = [Image.fromarray(f, "RGBA") for f in frames]
    images[0].save(buffer, format="WEBP", save_all=True, append_images=images[1:], duration=[80, 5, 300],
                   loop=2, lossless=True)
    animation = read_animation(buffer.getvalue())
    assert animation.durations == (80.0, 100.0, 300.0)
    assert animation.plays == 2
    for got, want in zip(animation.frames, frames):
        np.testing.assert_array_equal(got[want[..., 3] > 0], want[want[..., 3] > 0])


def test_a_still_image_is_one_frame_played_once():
    animation = read_animation(FIXTURES / "heart.png")
    assert len(animation.frames) == 1 and animation.plays == 1


def test_animation_checks_what_it_holds():
    frame = np.zeros((2, 3, 4), np.uint8)
    with pytest.raises(InputError, match="one size"):
        Animation((frame, np.zeros((3, 2, 4), np.uint8)), (100.0, 100.0))
    with pytest.raises(InputError, match="positive"):
        Animation((frame,), (0.0,))
    with pytest.raises(InputError, match="2 frames but 1 durations"):
        Animation((frame, frame), (100.0,))
    with pytest.raises(InputError, match="plays"):
        Animation((frame,), (100.0,), -1)
    with pytest.raises(InputError, match="positive"):
        Animation((frame,), ("100",))
    animation = Animation([frame], [np.float32(100)])
    assert np.shares_memory(animation.frames[0], frame) and frame.flags.writeable
    assert animation.durations == (100.0,)
    assert type(animation.durations[0]) is float
    assert not animation.frames[0].flags.writeable
    assert "uint8[2, 3, 4]" in repr(animation)


@pytest.mark.parametrize("data", [disposal_gif(), disposal_apng(default=np.full((4, 4, 4), 128, np.uint8))],
                         ids=["gif", "apng"])
def test_every_frame_reader_gives_the_frames_a_browser_shows(data):
    # --frames N and --frames all read what --animate reads, even where Pillow composites otherwise
    # (the GIF's disposal, the APNG's blending and its default image outside the animation)
    frames = read_animation(data).frames
    assert frame_count(data) == len(frames)
    assert [i for i, _ in load_frames(data)] == list(range(len(frames)))
    for (_, got), want in zip(load_frames(data), frames):
        np.testing.assert_array_equal(got, want)
    for n, want in enumerate(frames):
        np.testing.assert_array_equal(load_image(data, frame=n), want, err_msg=f"frame {n}")
    with pytest.raises(InputError, match=f"has {len(frames)} frame"):
        load_image(data, frame=len(frames))


def test_one_frame_is_read_whatever_the_frames_in_all():
    # frame 0 of 6 frames whose pixels in all are over the limit: one frame is decoded, allowed
    data = gif((4, 4), PALETTE, [GifImage(FULL)] * 6)
    with pytest.raises(InputError, match="6 frames are 96 pixels in all"):
        read_animation(data, max_pixels=90)
    assert load_image(data, max_pixels=90).shape == (4, 4, 4)
    with pytest.raises(InputError, match="frame 5 is past the limit of 5 frames"):
        load_image(data, frame=5, max_frames=5)


def test_select_plays_the_frames_given_in_their_order():
    animation = read_animation(disposal_gif(loop=0))
    pingpong = animation.select([1, 2, 3, 2])
    assert pingpong.durations == (100.0, 50.0, 300.0, 50.0) and pingpong.plays == 0
    for got, want in zip(pingpong.frames, [animation.frames[i] for i in (1, 2, 3, 2)]):
        np.testing.assert_array_equal(got, want)
    assert read_animation(disposal_gif(), frames=[4, 0]).durations == (100.0, 200.0)
    for bad in ([], [5], [-1], [1.0]):
        with pytest.raises(InputError, match="indices 0 to 4"):
            animation.select(bad)


def test_an_aseprite_file_plays_for_ever_in_its_own_durations():
    red, blue = (np.full((2, 2, 4), c, np.uint8) for c in ((255, 0, 0, 255), (0, 0, 255, 255)))
    data = aseprite_bytes(2, 2, [LayerSpec("Layer 1")], [FrameSpec([rgba_cel(0, red)], duration=5),
                                                         FrameSpec([rgba_cel(0, blue)], duration=250)])
    animation = read_animation(data)
    assert animation.durations == (5.0, 250.0) and animation.plays == 0
    np.testing.assert_array_equal(animation.frames[1], blue)
