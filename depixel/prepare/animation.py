"""Input — an animated image → :class:`Animation`: its frames as a viewer shows them, how long
each shows and how many times the whole plays.

An :class:`Animation` is what every animated output is made from (:mod:`depixel.svg.animation`,
:mod:`depixel.render.animation`); any reader can make one (GIF, APNG, animated WebP and
Aseprite files here). Timing follows what browsers do, so the SVG plays as the file did:

* a frame of 10 ms or less plays as 100 ms (Chromium and Firefox, for every format: files
  that ask for 0 ms mean "as fast as the viewer likes");
* a GIF's NETSCAPE2.0 block counts *repeats*: none plays once, 0 forever, N plays N + 1 times;
  APNG's ``num_plays`` and WebP's loop count count *plays*: 0 forever, N plays N times;
* an Aseprite file plays for ever, each frame for its own duration (Aseprite plays 1 ms as 1 ms);
  one of its tags (:meth:`Animation.tagged`) plays its frames in its direction, its repeat
  count of times (none given: for ever, as Aseprite loops a tag).

GIF and APNG frames are composited by :mod:`.gif` and :mod:`.apng` (Pillow's own compositing
departs from browsers' and from the APNG specification there; :func:`~.image.load_frames` reads
the same frames), WebP frames by Pillow (libwebp's animation decoder), Aseprite frames by
:mod:`.aseprite_compose`. An APNG's default image that is not part of the animation is
left out, as browsers do.
"""
from __future__ import annotations

import dataclasses
import math
import numbers
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from ..errors import InputError, ParameterError
from ..frozen import compact_repr, freeze
from ..limits import DEFAULT_MAX_FRAMES, DEFAULT_MAX_PIXELS
from . import gif
from .image import ImageSource, _describe, _frames, _is_aseprite, composite, parse_animated, read_source

if TYPE_CHECKING:
    from .aseprite_format import Tag

#: a frame shown this long or shorter (ms) plays as SHORT_FRAME_PLAYS_AS
SHORT_FRAME_MS = 10.0
SHORT_FRAME_PLAYS_AS = 100.0


@dataclasses.dataclass(frozen=True, eq=False, repr=False)
class Animation:
    """Frames of one size with their timing.

    ``frames``: ``(H, W, 4) uint8`` RGBA each, read-only, as a viewer shows them;
    ``durations``: milliseconds each frame shows (> 0); ``plays``: how many times the whole
    sequence plays, 0 for ever; ``tags``: an Aseprite file's tags (:meth:`tagged` plays
    one), none for other files. A still image is one frame (its duration and plays matter
    to nobody)."""

    frames: tuple[np.ndarray, ...]
    durations: tuple[float, ...]
    plays: int = 0
    tags: tuple[Tag, ...] = ()

    def __post_init__(self) -> None:
        # read-only views: the caller's arrays stay writable, this product's are not
        object.__setattr__(self, "frames", tuple(np.asarray(f).view() for f in self.frames))
        if not all(isinstance(d, numbers.Real) and not isinstance(d, bool) for d in self.durations):
            raise InputError(f"frame durations must be positive milliseconds, not {list(self.durations)}")
        object.__setattr__(self, "durations", tuple(float(d) for d in self.durations))
        if not self.frames:
            raise InputError("an animation needs at least one frame")
        shape = self.frames[0].shape
        if any(f.shape != shape or f.dtype != np.uint8 for f in self.frames) or len(shape) != 3 or shape[2] != 4:
            raise InputError("animation frames must all be (H, W, 4) uint8 RGBA of one size, "
                             f"not {sorted({(f.shape, str(f.dtype)) for f in self.frames})}")
        if len(self.durations) != len(self.frames):
            raise InputError(f"{len(self.frames)} frames but {len(self.durations)} durations")
        if not all(math.isfinite(d) and d > 0 for d in self.durations):
            raise InputError(f"frame durations must be positive milliseconds, not {list(self.durations)}")
        if isinstance(self.plays, bool) or not isinstance(self.plays, int) or self.plays < 0:
            raise InputError(f"plays must be a whole number >= 0 (0: for ever), not {self.plays!r}")
        object.__setattr__(self, "tags", tuple(self.tags))
        if any(not 0 <= tag.first <= tag.last < len(self.frames) for tag in self.tags):
            raise InputError(f"tags must name frames 0 to {len(self.frames) - 1}, not {list(self.tags)}")
        freeze(self)

    __repr__ = compact_repr

    @property
    def cycle(self) -> float:
        """Milliseconds of one play of all frames."""
        return float(sum(self.durations))

    def select(self, frames: Sequence[int]) -> Animation:
        """The animation of the frames at the indices ``frames``, played in that order (a frame
        may come more than once: a ping-pong), each with its own duration; plays as this one."""
        indices = list(frames)
        if not indices or not all(isinstance(i, numbers.Integral) and 0 <= i < len(self.frames) for i in indices):
            raise InputError(f"frames to play must be indices 0 to {len(self.frames) - 1}, not {indices}")
        return Animation(tuple(self.frames[i] for i in indices), tuple(self.durations[i] for i in indices), self.plays)

    def tagged(self, tag: str, *, name: str = "<animation>") -> Animation:
        """The animation of the tag ``tag`` (of :attr:`tags`) as Aseprite plays it: its frames
        in the order of its direction, each with its own duration, as many times as its
        repeat count says (:func:`depixel.prepare.aseprite.tag_playback`). An unknown tag is
        one :class:`InputError` line naming the tags there are (``name`` names the file)."""
        from .aseprite import tag_playback  # noqa: PLC0415 (the Aseprite modules only for a tag)

        order, plays = tag_playback(self.tags, tag, name=name)
        return Animation(tuple(self.frames[i] for i in order), tuple(self.durations[i] for i in order), plays)

    @classmethod
    def still(cls, rgba: np.ndarray) -> Animation:
        """One frame shown once (``--animate`` on a still image)."""
        return cls((rgba,), (SHORT_FRAME_PLAYS_AS,), 1)


def played_duration(ms: float | None) -> float:
    """How long a browser shows a frame that asks for ``ms`` milliseconds (None: none given)."""
    ms = float(ms or 0.0)
    return SHORT_FRAME_PLAYS_AS if not math.isfinite(ms) or ms <= SHORT_FRAME_MS else ms


def gif_plays(loop: int | None) -> int:
    """Plays of a GIF whose NETSCAPE2.0 block says ``loop`` (None: no block): a GIF plays once,
    then repeats ``loop`` times (0: for ever)."""
    if loop is None:
        return 1
    return 0 if loop == 0 else loop + 1


def read_animation(source: ImageSource, max_pixels: int | None = DEFAULT_MAX_PIXELS, *,
                   max_frames: int | None = DEFAULT_MAX_FRAMES, name: str | None = None,
                   frames: Sequence[int] | None = None, tag: str | None = None) -> Animation:
    """Every frame of a GIF, APNG, animated WebP or Aseprite file (or any image: a still is one
    frame) with its timing (module docstring), and an Aseprite file's tags. The limits are
    those of :func:`depixel.prepare.image.load_frames`: the frames within ``max_frames`` and
    their pixels in all within ``max_pixels``, checked before a frame is decoded. ``frames``:
    the indices of the frames to play, in their order, :meth:`Animation.select`; ``tag``: the
    Aseprite tag to play, :meth:`Animation.tagged`; None: all, as the file plays them."""
    from ..validate import limit  # noqa: PLC0415

    if frames is not None and tag is not None:
        raise ParameterError("give frames or tag, not both (a tag's frames are its own)", parameter="tag")
    max_pixels, max_frames = limit("max_pixels", max_pixels), limit("max_frames", max_frames)
    name = _describe(source, name)
    data = read_source(source)  # read once: a stream cannot be read twice
    parsed = parse_animated(data, name, max_pixels, max_frames)
    if parsed is not None:
        plays = gif_plays(parsed.loop) if isinstance(parsed, gif.GifFile) else parsed.plays
        whole = Animation(tuple(composite(parsed, name)), tuple(played_duration(f.delay) for f in parsed.frames),
                          plays)
        return _played(whole, frames, tag, name)
    pictures, durations, plays, tags = [], [], 1, ()
    aseprite = _is_aseprite(data)
    for _, rgba, info in _frames(data, max_pixels, None, max_frames, name):
        pictures.append(rgba)
        # Aseprite's own durations are played as they are, and its animations loop
        durations.append(float(info["duration"]) if aseprite else played_duration(info.get("duration")))
        plays = 0 if aseprite else int(info.get("loop", 1))
        tags = info.get("tags", ())
    if len({f.shape for f in pictures}) > 1:
        raise InputError(f"{name}: its frames (pages) differ in size; they cannot be one animation")
    return _played(Animation(tuple(pictures), tuple(durations), plays, tags), frames, tag, name)


def _played(whole: Animation, frames: Sequence[int] | None, tag: str | None, name: str) -> Animation:
    """``whole``, or the frames of it to play: ``frames`` selected, or the tag ``tag``."""
    if tag is not None:
        return whole.tagged(tag, name=name)
    return whole if frames is None else whole.select(frames)
