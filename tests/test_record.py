"""Recording (viewer/record.py): MP4 through imageio-ffmpeg, looping WebP through Pillow and PNG sequences, from
frames and from ``ugpcl run --video/--frames`` (offscreen); the files read back with imageio and Pillow."""

from __future__ import annotations

import imageio.v3 as iio
import numpy as np
import pytest
from helpers import foreground, run_cli
from PIL import Image
from ugpcl.viewer.record import Recorder
from ugpcl.viewer.views import view_class

from ugpcl.registry import get


def moving_square(i: int, size=(65, 49)) -> np.ndarray:
    """A grey frame with a white square that moves right by 4 pixels a frame (odd sides on purpose)."""
    w, h = size
    pixels = np.full((h, w, 3), 60, np.uint8)
    pixels[16:32, 4 * i : 4 * i + 16] = 255
    return pixels


def test_an_mp4_holds_every_frame_at_its_size(tmp_path):
    path = tmp_path / "clip.mp4"
    with Recorder(path) as recorder:
        for i in range(6):
            recorder.add(moving_square(i))
    assert recorder.frames == 6 and not list(tmp_path.glob(".*partial*"))
    video = iio.imread(path)
    assert video.shape == (6, 48, 64, 3)  # H.264 wants even sides: the odd last row and column are dropped
    for i, frame in enumerate(video):
        expected = moving_square(i)[:48, :64].astype(int)
        assert np.abs(frame.astype(int) - expected).mean() < 4, f"frame {i} does not show the square where it was"


def webp_frames(path) -> tuple[list[np.ndarray], dict]:
    """Every frame of an animated WebP as (H, W, 3) uint8, and the file's info (loop count, ...)."""
    with Image.open(path) as image:
        assert image.format == "WEBP"
        info = dict(image.info)
        frames = []
        for k in range(image.n_frames):
            image.seek(k)
            frames.append(np.asarray(image.convert("RGB")))
            info.setdefault("durations", []).append(image.info.get("duration"))
    return frames, info


def test_a_webp_loops_through_every_frame_at_its_size(tmp_path):
    path = tmp_path / "clip.webp"
    with Recorder(path, fps=15) as recorder:
        for i in range(6):
            recorder.add(moving_square(i))
    assert recorder.frames == 6 and [p.name for p in tmp_path.iterdir()] == ["clip.webp"]  # no partial file left
    frames, info = webp_frames(path)
    assert len(frames) == 6 and info["loop"] == 0, f"{len(frames)} frames, loop {info.get('loop')}"
    for i, frame in enumerate(frames):
        assert frame.shape == (49, 65, 3)  # WebP keeps odd sides (H.264 drops a row and a column)
        # lossy at quality 70: a flat grey and a white square come back within a few levels on average
        assert np.abs(frame.astype(int) - moving_square(i)).mean() < 4, f"frame {i} does not show the square there"
    assert info["durations"][0] in (66, 67), info["durations"]  # 15 fps: 1000/15 ms, whole milliseconds


def test_a_png_sequence_holds_every_frame_exactly(tmp_path):
    with Recorder(tmp_path / "frames") as recorder:
        for i in range(3):
            recorder.add(moving_square(i))
    files = sorted((tmp_path / "frames").iterdir())
    assert [f.name for f in files] == ["frame-000000.png", "frame-000001.png", "frame-000002.png"]
    for i, f in enumerate(files):
        assert np.array_equal(np.asarray(Image.open(f)), moving_square(i))


@pytest.mark.parametrize("name", ["clip.mp4", "clip.webp"])
def test_a_failed_recording_leaves_no_video(tmp_path, name):
    path = tmp_path / name
    with pytest.raises(KeyboardInterrupt), Recorder(path) as recorder:
        recorder.add(moving_square(0))
        raise KeyboardInterrupt
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("suffix", [".mp4", ".webp"])
def test_run_records_a_video_every_k_steps(capsys, tmp_path, suffix):
    """--video x.mp4 (H.264, read back with imageio) or x.webp (looping, read back with Pillow): steps 0, 5 .. 20;
    --every is the .npz's history alone (none asked here)."""
    video = tmp_path / f"boids{suffix}"
    code, text = run_cli(
        capsys, "run", "boids", "--steps", "20", "--video-every", "5", "--video", str(video), "--png-size", "160x120",
        "--set", "max_object_num=256", "--out", str(tmp_path / "boids.npz"), "--quiet",
    )  # fmt: skip
    assert code == 0, text
    assert f"wrote {video} (5 frames)" in text  # steps 0, 5, 10, 15, 20
    with np.load(tmp_path / "boids.npz") as saved:
        assert not any(k.endswith("_history") for k in saved.files)
    if suffix == ".mp4":
        frames = iio.imread(video)
    else:
        frames, info = webp_frames(video)
        assert info["loop"] == 0
    assert len(frames) == 5 and all(f.shape == (120, 160, 3) for f in frames)
    background = view_class(get("boids")).background
    assert all(foreground(f, background, 40).mean() > 0.01 for f in frames), "a frame shows no boids"
    assert np.abs(frames[0].astype(int) - frames[-1]).max() > 40, "the boids did not move between frames"


def test_run_writes_frames_whose_last_is_the_png_of_the_run(capsys, tmp_path):
    folder, png = tmp_path / "frames", tmp_path / "last.png"
    code, text = run_cli(
        capsys, "run", "boids", "--steps", "6", "--video-every", "3", "--frames", str(folder), "--png", str(png),
        "--png-size", "160x120", "--set", "max_object_num=256", "--out", str(tmp_path / "b.npz"), "--quiet",
    )  # fmt: skip
    assert code == 0, text
    files = sorted(folder.glob("frame-*.png"))
    assert len(files) == 3 and not list(folder.glob(".*"))
    assert np.array_equal(np.asarray(Image.open(files[-1]).convert("RGB")), np.asarray(Image.open(png).convert("RGB")))


def test_run_refuses_bad_recording_paths_before_running(capsys, tmp_path):
    code, text = run_cli(capsys, "run", "boids", "--video", str(tmp_path / "x.avi"))
    assert code == 2 and "--video must end in .mp4 or .webp" in text
    (tmp_path / "file").write_text("")
    code, text = run_cli(capsys, "run", "boids", "--frames", str(tmp_path / "file"))
    assert code == 2 and "is a file" in text


def test_the_video_rate_and_a_compressed_npz(capsys, tmp_path):
    """--fps sets the WebP's frame duration; --compress writes the same arrays deflated."""
    video, plain, small = tmp_path / "b.webp", tmp_path / "plain.npz", tmp_path / "small.npz"
    common = ["run", "boids", "--steps", "2", "--set", "max_object_num=256", "--quiet", "--png-size", "80x60"]
    code, text = run_cli(capsys, *common, "--video", str(video), "--fps", "10", "--out", str(plain))
    assert code == 0, text
    frames, info = webp_frames(video)
    assert len(frames) == 3 and info["durations"] == [100, 100, 100]  # ms a frame at 10 fps
    code, text = run_cli(capsys, *common, "--compress", "--out", str(small))
    assert code == 0, text
    with np.load(plain) as a, np.load(small) as b:
        assert sorted(a.files) == sorted(b.files)
        for key in ("position", "velocity"):
            np.testing.assert_array_equal(a[key], b[key])
    assert small.stat().st_size < plain.stat().st_size


@pytest.mark.parametrize(
    "argv, says",
    [
        (["--video-every", "2"], "--video-every: give --video or --frames"),
        (["--fps", "10"], "--fps: give --video"),
        (["--video", "x.webp", "--fps", "0"], "--fps must be in [1, 240], got 0"),
        (["--video", "x.webp", "--video-every", "0"], "--video-every must be in [1, 1073741824], got 0"),
    ],
)
def test_recording_options_are_checked(capsys, tmp_path, argv, says):
    code, text = run_cli(capsys, "run", "boids", "--out", str(tmp_path / "x.npz"), *argv)
    assert code == 2 and says in text, text
