"""The animated SVG in the renderers people open it with: headless Chromium plays it (an inline
SVG paused at a time inside each frame shows that frame), Inkscape and rsvg-convert draw the
first frame as its own conversion; Chromium's decoder gives the GIF and APNG frames depixel
reads. Skipped where the program is not installed (``apt-get
install chromium inkscape librsvg2-bin``)."""
from __future__ import annotations

import shutil
import subprocess
import tempfile
from pathlib import Path

import numpy as np
import pytest
from test_animation import DURATIONS, animate, blinking

import depixel
from depixel.prepare.animation import Animation

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser") or shutil.which("google-chrome")
INKSCAPE = shutil.which("inkscape")
WIDTH = 136  # 17 art pixels × 8


def inline(svg: str, copy: int) -> str:
    """``svg`` for an HTML page holding several: ids made unique to the copy, a fixed width."""
    svg = svg[svg.index("<svg") :]
    for old in (' id="', 'xlink:href="#', "url(#"):
        svg = svg.replace(old, f"{old}c{copy}-")
    return svg.replace("<svg", f'<svg style="display:block;float:left;width:{WIDTH}px;height:auto"', 1)


def screenshots(shots: list[tuple[str, float]], height: int) -> list[np.ndarray]:
    """One Chromium screenshot of the SVGs side by side, each paused at its time (seconds)."""
    from PIL import Image

    times = [t for _, t in shots]
    page = ("<!doctype html><html><body style='margin:0;background:#fff'>"
            + "".join(inline(svg, k) for k, (svg, _) in enumerate(shots))
            + f"<script>document.querySelectorAll('body > svg').forEach((s, i) => "
            f"{{ s.pauseAnimations(); s.setCurrentTime({times}[i]); }});</script></body></html>")
    with tempfile.TemporaryDirectory() as tmp:
        html, png = Path(tmp, "page.html"), Path(tmp, "shot.png")
        html.write_text(page)
        subprocess.run([CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
                        "--no-first-run", f"--user-data-dir={tmp}/profile", "--hide-scrollbars",
                        "--force-device-scale-factor=1", f"--window-size={WIDTH * len(shots)},{height + 200}",
                        f"--screenshot={png}", html.as_uri()], check=True, capture_output=True, timeout=120)
        shot = np.asarray(Image.open(png).convert("RGB")).astype(np.int64)[:height]
    return [shot[:, k * WIDTH : (k + 1) * WIDTH] for k in range(len(shots))]


def written_by_the_command(folder: Path, frames: tuple[np.ndarray, ...]) -> str:
    """The animated SVG ``depixel convert walk.png -o walk.svg --animate`` writes of an APNG of
    ``frames`` in DURATIONS, looping."""
    from depixel.render.animation import encode_apng
    from depixel_cli.main import main

    (folder / "walk.png").write_bytes(encode_apng(frames, DURATIONS, 0))
    assert main(["convert", str(folder / "walk.png"), "-o", str(folder / "walk.svg"), "--animate", "-q"]) == 0
    svg = (folder / "walk.svg").read_text()
    assert svg == animate(Animation(frames, DURATIONS, 0), title="walk.png").replace(
        "<svg", svg[svg.index("<!--") : svg.index("-->") + 4] + "<svg", 1)  # the API's, with the stamp
    return svg


@pytest.mark.skipif(CHROMIUM is None, reason="chromium not installed")
def test_chromium_plays_the_frames_in_their_timing(tmp_path):
    frames = blinking()
    svg = written_by_the_command(tmp_path, frames)
    singles = [depixel.convert(f) for f in frames]
    # inside frames 1, 2, 3 (0-120, 120-160, 160-410 ms), then frame 1 again in the second cycle
    # (0.13 s would be in frame 1 of three equal frames)
    times = [0.06, 0.13, 0.2, 0.45]
    shots = screenshots([(svg, t) for t in times] + [(s, 0.0) for s in singles], height=WIDTH * 15 // 17 + 8)
    played, own = shots[: len(times)], shots[len(times) :]
    patch = (slice(50, 62), slice(58, 70))  # inside the 2×2 patch the frames differ in (rows 6-7, columns 7-8)
    for n, (shot, want) in enumerate(zip(played, [0, 1, 2, 0])):
        assert np.abs(shot - own[want]).mean() < 0.5, n  # the whole frame (Chromium's filters vary a little)
        distances = [np.abs(shot[patch] - o[patch]).mean() for o in own]
        assert distances[want] < 4 and min(d for i, d in enumerate(distances) if i != want) > 40, (n, distances)


@pytest.mark.skipif(INKSCAPE is None, reason="inkscape not installed")
def test_inkscape_exports_the_first_frame(tmp_path):
    from PIL import Image

    frames = blinking()
    written_by_the_command(tmp_path, frames)
    (tmp_path / "first.svg").write_text(depixel.convert(frames[0]))
    for name in ("walk", "first"):
        subprocess.run([INKSCAPE, str(tmp_path / f"{name}.svg"), f"--export-filename={tmp_path / name}.png",
                        f"--export-width={WIDTH}"], check=True, capture_output=True, timeout=120)
    walk, first = (np.asarray(Image.open(tmp_path / f"{n}.png").convert("RGBA")) for n in ("walk", "first"))
    np.testing.assert_array_equal(walk, first)


@pytest.mark.skipif(shutil.which("rsvg-convert") is None, reason="rsvg-convert not installed")
def test_rsvg_draws_the_first_frame(tmp_path):
    from PIL import Image

    frames = blinking()
    (tmp_path / "walk.svg").write_text(animate(Animation(frames, DURATIONS, 0)))
    (tmp_path / "first.svg").write_text(depixel.convert(frames[0]))
    for name in ("walk", "first"):
        subprocess.run(["rsvg-convert", "-w", str(WIDTH), "-o", str(tmp_path / f"{name}.png"),
                        str(tmp_path / f"{name}.svg")], check=True, capture_output=True, timeout=120)
    walk, first = (np.asarray(Image.open(tmp_path / f"{n}.png").convert("RGBA")) for n in ("walk", "first"))
    np.testing.assert_array_equal(walk, first)


DECODE_PAGE = """<!doctype html><html><body><script>
(async () => {
  const bytes = Uint8Array.from(atob("DATA"), c => c.charCodeAt(0));
  const decoder = new ImageDecoder({data: bytes, type: "TYPE"});
  await decoder.tracks.ready;
  const frames = [];
  for (let i = 0; i < decoder.tracks.selectedTrack.frameCount; i++) {
    const image = (await decoder.decode({frameIndex: i})).image;
    const canvas = new OffscreenCanvas(image.displayWidth, image.displayHeight);
    const context = canvas.getContext("2d");
    context.drawImage(image, 0, 0);
    frames.push(Array.from(context.getImageData(0, 0, canvas.width, canvas.height).data));
  }
  const out = document.createElement("pre");
  out.id = "frames";
  out.textContent = JSON.stringify(frames);
  document.body.appendChild(out);
})().catch(e => { document.title = "error " + e; });
</script></body></html>"""


@pytest.mark.skipif(CHROMIUM is None, reason="chromium not installed")
@pytest.mark.parametrize("kind", ["gif", "apng"])
def test_frames_are_those_chromium_decodes(kind, tmp_path):
    """Chromium's own decoder (WebCodecs ImageDecoder, which composites as the browser shows
    an animation) gives the frames depixel reads, on the files that catch Pillow out."""
    import base64
    import json
    import re

    from test_animation_read import disposal_apng, disposal_gif

    from depixel.prepare.animation import read_animation

    data = disposal_gif() if kind == "gif" else disposal_apng()
    page = tmp_path / "decode.html"
    page.write_text(DECODE_PAGE.replace("DATA", base64.b64encode(data).decode())
                    .replace("TYPE", "image/gif" if kind == "gif" else "image/apng"))
    for attempt in range(1, 6):  # the decoding runs beside the page's virtual time: a loaded machine may need
        command = [CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
                   "--no-first-run", f"--user-data-dir={tmp_path}/profile{attempt}",
                   f"--virtual-time-budget={10000 * attempt}", "--dump-dom", page.as_uri()]  # another, longer go
        dom = subprocess.run(command, check=True, capture_output=True, text=True, timeout=120).stdout
        found = re.search(r'<pre id="frames">([^<]*)</pre>', dom)
        if found or "<title>error" in dom:
            break
    assert found, dom[:300]
    decoded = [np.array(f, np.uint8).reshape(4, 4, 4) for f in json.loads(found.group(1))]
    ours = read_animation(data).frames
    assert len(decoded) == len(ours)
    for n, (theirs, mine) in enumerate(zip(decoded, ours)):
        np.testing.assert_array_equal(mine, theirs, err_msg=f"frame {n}")
