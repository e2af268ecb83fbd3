"""Recording frames to an MP4, an animated WebP or a PNG sequence: the viewer's record keys, ``ugpcl run
--video/--frames`` and the chapter pages' animations (``python -m ugpcl.docs animations``) share it.

The MP4 goes through imageio-ffmpeg, whose wheel ships an ffmpeg binary (a fresh machine needs no system ffmpeg).
The WebP (Pillow) is a looping animation for web pages: its frames are kept in memory and encoded when the
recording stops, so it suits short clips. Every file is written whole (``ugpcl.io.written_whole``): the video
under a temporary name renamed when the recording stops, each PNG on its own; a recording that fails leaves no
half-written video behind.
"""

from __future__ import annotations

from contextlib import ExitStack
from pathlib import Path

import numpy as np
from PIL import Image

from ugpcl.io import written_whole

from .gl import save_png

VIDEO_FPS = 30
"""Playback rate: one rendered frame (one step, or K steps headless) per 1/30 s of video."""
VIDEO_QUALITY = 8
"""imageio-ffmpeg's quality scale (0-10): high enough that thin lines and small boids survive compression."""
WEBP_QUALITY = 70
"""Pillow's lossy WebP quality (0-100): a 3 s loop at 480x270 stays within a few hundred KB."""
WEBP_METHOD = 6
"""libwebp's effort (0 fast - 6 slowest, smallest): the clips are short, so spend the time on size."""


class Recorder:
    """Frames to ``path``: an ``.mp4`` file, a ``.webp`` animation that loops, or else a folder of
    ``frame-000000.png`` ... (made if missing). ``webp_quality`` trades a WebP's size for detail."""

    def __init__(self, path, fps: int = VIDEO_FPS, webp_quality: int = WEBP_QUALITY):
        self.path, self.fps, self.frames = Path(path), fps, 0
        self.webp_quality = webp_quality
        suffix = self.path.suffix.lower()
        self.video, self.webp = suffix == ".mp4", suffix == ".webp"
        self._files = ExitStack()
        self._writer = None
        self._images: list[Image.Image] = []
        if not (self.video or self.webp):
            self.path.mkdir(parents=True, exist_ok=True)

    def add(self, pixels: np.ndarray) -> None:
        """Append one (H, W, 3) uint8 frame, top row first. H.264 (yuv420p) needs even sides: an odd last row or
        column is dropped from an MP4 (a WebP keeps every pixel)."""
        if self.webp:
            image = Image.fromarray(np.ascontiguousarray(pixels))
            if self._images and image.size != self._images[0].size:  # resized while recording: keep the first size
                image = image.resize(self._images[0].size)
            self._images.append(image)
        elif self.video:
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

    def _write_webp(self) -> None:
        first, *rest = self._images
        # loop=0: repeat forever; duration per frame in whole milliseconds (the format's unit). libwebp folds a
        # frame equal to the one before into it (one frame shown twice as long), so a still scene reads as 1 frame
        with written_whole(self.path) as partial:
            first.save(
                partial,
                format="WEBP",
                save_all=True,
                append_images=rest,
                loop=0,
                duration=round(1000 / self.fps),
                quality=self.webp_quality,
                method=WEBP_METHOD,
            )

    def close(self) -> int:
        """Finish the file(s); the number of frames written."""
        if self.webp and self._images:
            self._write_webp()
            self._images.clear()
        self._files.close()
        return self.frames

    def abort(self) -> None:
        """Stop and remove a video that is not complete (PNGs already written stay)."""
        self._images.clear()
        self._files.__exit__(RuntimeError, RuntimeError("recording aborted"), None)

    def __enter__(self) -> Recorder:
        return self

    def __exit__(self, kind, err, tb) -> None:
        if kind is None:
            self.close()
        else:
            self.abort()
