"""Recording frames to an MP4 or a PNG sequence: the viewer's record keys and ``ugpcl run --video/--frames`` share it.

The MP4 goes through imageio-ffmpeg, whose wheel ships an ffmpeg binary (a fresh machine needs no system ffmpeg).
Every file is written whole (``ugpcl.cli.written_whole``): the video under a temporary name renamed when the
recording stops, each PNG on its own; a recording that fails leaves no half-written video behind.
"""

from __future__ import annotations

from contextlib import ExitStack
from pathlib import Path

import numpy as np
from PIL import Image

from ugpcl.cli import written_whole

from .gl import save_png

VIDEO_FPS = 30
"""Playback rate: one rendered frame (one step, or K steps headless) per 1/30 s of video."""
VIDEO_QUALITY = 8
"""imageio-ffmpeg's quality scale (0-10): high enough that thin lines and small boids survive compression."""


class Recorder:
    """Frames to ``path``: an ``.mp4`` file, or else a folder of ``frame-000000.png`` ... (made if missing)."""

    def __init__(self, path, fps: int = VIDEO_FPS):
        self.path, self.fps, self.frames = Path(path), fps, 0
        self.video = self.path.suffix.lower() == ".mp4"
        self._files = ExitStack()
        self._writer = None
        if not self.video:
            self.path.mkdir(parents=True, exist_ok=True)

    def add(self, pixels: np.ndarray) -> None:
        """Append one (H, W, 3) uint8 frame, top row first. H.264 (yuv420p) needs even sides: an odd last row or
        column is dropped."""
        if self.video:
            h, w = pixels.shape[0] // 2 * 2, pixels.shape[1] // 2 * 2
            if self._writer is None:
                self._open(w, h)
            pixels = pixels[:h, :w]
            if (w, h) != self.size:  # the window was resized while recording: a video keeps its first size
                pixels = np.asarray(Image.fromarray(pixels).resize(self.size))
            self._writer.append_data(np.ascontiguousarray(pixels))
        else:
            with written_whole(self.path / f"frame-{self.frames:06d}.png") as partial:
                save_png(pixels, partial)
        self.frames += 1

    def _open(self, width: int, height: int) -> None:
        import imageio.v2 as imageio

        self.size = (width, height)
        partial = self._files.enter_context(written_whole(self.path))
        # macro_block_size=2: keep the frame's size (imageio would rescale it to a multiple of 16); yuv420p plays
        # everywhere
        self._writer = imageio.get_writer(
            partial,
            format="FFMPEG",
            mode="I",
            fps=self.fps,
            codec="libx264",
            quality=VIDEO_QUALITY,
            pixelformat="yuv420p",
            macro_block_size=2,
        )
        self._files.callback(self._writer.close)  # runs before the rename (an ExitStack unwinds last-in first)

    def close(self) -> int:
        """Finish the file(s); the number of frames written."""
        self._files.close()
        return self.frames

    def abort(self) -> None:
        """Stop and remove a video that is not complete (PNGs already written stay)."""
        self._files.__exit__(RuntimeError, RuntimeError("recording aborted"), None)

    def __enter__(self) -> Recorder:
        return self

    def __exit__(self, kind, err, tb) -> None:
        if kind is None:
            self.close()
        else:
            self.abort()
