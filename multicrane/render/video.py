"""Episode videos: the site's ``rgb_array`` pictures, one per reset and step, to .mp4 or .gif.

    with EpisodeVideo("ep.mp4", fps=4) as video:
        run_episode(env, policy, seed, on_reset=video.on_reset, on_step=video.on_step)

An .mp4 (or any other container ffmpeg knows) is encoded as the frames come, through
imageio-ffmpeg and the ffmpeg it ships, H.264 at the frames' exact size (no rescaling); a
.gif is kept in memory and written at the end with Pillow. Both come with the ``video``
extra (``pip install 'multicrane[video]'``, which also brings moviepy for Gymnasium's
``RecordVideo``); without it ``require_video`` raises an ``ImportError`` naming the extra.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from multicrane.render.image import SiteImage

EXTRA_HINT = "episode videos need the 'video' extra: pip install 'multicrane[video]'"


def require_video(path: str | Path) -> None:
    """Fail now, naming the extra, when the writer of ``path``'s format is not installed."""
    module = "PIL" if Path(path).suffix.lower() == ".gif" else "imageio_ffmpeg"
    try:
        __import__(module)
    except ImportError as exc:
        raise ImportError(EXTRA_HINT, name=module) from exc


class EpisodeVideo:
    """A video file fed with frames: ``add(frame)`` or, as an episode's listener,
    ``on_reset(env)`` and ``on_step(env, ...)`` (the site drawn as ``rgb_array`` draws it).
    ``close()`` (or leaving the ``with`` block) finishes the file; ``frames`` counts them."""

    def __init__(self, path: str | Path, fps: float = 4) -> None:
        require_video(path)
        self.path, self.fps = Path(path), fps
        self.frames = 0
        self._gif: list[np.ndarray] | None = [] if self.path.suffix.lower() == ".gif" else None
        self._encoder = None
        self._image: SiteImage | None = None

    def on_reset(self, env) -> None:
        sim = env.unwrapped.sim
        if self._image is None:
            self._image = SiteImage(sim)
        self.add(self._image.draw(sim))

    def on_step(self, env, *_) -> None:
        self.add(self._image.draw(env.unwrapped.sim))

    def add(self, frame: np.ndarray) -> None:
        """Append one (H, W, 3) uint8 frame; every frame of a video has the first one's size."""
        if self._gif is not None:
            self._gif.append(frame)
        else:
            if self._encoder is None:
                self._encoder = self._open(frame.shape)
            self._encoder.send(np.ascontiguousarray(frame))
        self.frames += 1

    def _open(self, shape: tuple[int, ...]):
        import imageio_ffmpeg

        height, width = shape[:2]
        even = height % 2 == 0 and width % 2 == 0  # yuv420p (what players expect) needs it
        encoder = imageio_ffmpeg.write_frames(
            str(self.path), (width, height), fps=self.fps, macro_block_size=1,
            pix_fmt_out="yuv420p" if even else "yuv444p", quality=8,
        )  # fmt: skip
        encoder.send(None)  # start ffmpeg
        return encoder

    def close(self) -> None:
        if self._encoder is not None:
            self._encoder.close()
            self._encoder = None
        if self._gif:
            from PIL import Image

            first, *rest = (Image.fromarray(f) for f in self._gif)
            duration = round(1000 / self.fps)
            first.save(self.path, save_all=True, append_images=rest, duration=duration, loop=0)
            self._gif = []

    def __enter__(self) -> EpisodeVideo:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


__all__ = ["EpisodeVideo", "require_video"]
