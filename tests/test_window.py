"""`ugpcl-view` in a real window: Xvfb for the screen, xdotool for the keys (Debian xvfb + xdotool; `make`
installs them)."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import time
from contextlib import contextmanager
from pathlib import Path

import imageio.v3 as iio
import numpy as np
import pytest
from helpers import foreground
from PIL import Image
from ugpcl.viewer.views import view_class

from ugpcl.registry import scenes


@pytest.fixture
def display():
    missing = [tool for tool in ("Xvfb", "xdotool") if shutil.which(tool) is None]
    if missing:
        pytest.fail(f"{' and '.join(missing)} not installed: `make system-deps` (Debian: apt-get install xvfb xdotool)")
    read_fd, write_fd = os.pipe()
    server = subprocess.Popen(
        ["Xvfb", "-displayfd", str(write_fd), "-screen", "0", "1024x768x24", "-nolisten", "tcp"],
        pass_fds=[write_fd],
        stderr=subprocess.DEVNULL,
    )
    os.close(write_fd)
    with os.fdopen(read_fd) as pipe:
        number = pipe.readline().strip()
    yield f":{number}"
    server.terminate()
    server.wait(timeout=10)


def xdotool(env, *args) -> str:
    return subprocess.run(["xdotool", *args], env=env, capture_output=True, text=True, timeout=30).stdout.strip()


def screenshot(env, tmp_path, scene: str) -> np.ndarray:
    """Press S and read the screenshot the window writes to out/<scene>-<time>.png (waiting for it)."""
    xdotool(env, "key", "s")
    shots = wait_for((tmp_path / "out", f"{scene}-*.png"))
    assert shots, "the S key wrote no screenshot"
    return np.asarray(Image.open(shots[-1]).convert("RGB"))


@contextmanager
def viewer_app(env, cwd, *args):
    """``ugpcl-view ARGS`` on the display of ``env``; on leaving, killed if still open, its stderr in ``app.err``."""
    viewer = Path(sys.executable).parent / "ugpcl-view"
    app = subprocess.Popen([str(viewer), *args], cwd=cwd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                           text=True)  # fmt: skip
    try:
        yield app
    finally:
        if app.poll() is None:
            app.kill()
        app.err = app.communicate()[1]


def quit_cleanly(env, app) -> None:
    xdotool(env, "key", "Escape")
    assert app.wait(timeout=30) == 0, "Esc did not close the window cleanly"


@pytest.mark.gl
def test_view_opens_a_window_and_obeys_keys(display, tmp_path):
    env = {**os.environ, "DISPLAY": display}
    with viewer_app(env, tmp_path, "boids", "--set", "max_object_num=512", "--size", "320x240") as app:
        window = xdotool(env, "search", "--sync", "--onlyvisible", "--name", "ugpcl")
        assert window, "no ugpcl window appeared"
        window = window.splitlines()[0]
        xdotool(env, "windowfocus", "--sync", window)
        xdotool(env, "key", "h")  # help overlay
        xdotool(env, "key", "space")  # pause
        time.sleep(1.0)
        pixels = screenshot(env, tmp_path, "boids")
        quit_cleanly(env, app)
    err = app.err
    assert pixels.shape == (240, 320, 3)
    assert foreground(pixels, (0.192, 0.302, 0.475)).mean() > 0.05, "the screenshot shows no boids or overlay"
    assert "wrote out/boids-" in err


XDOTOOL_KEYS = {"tab": "Tab", "esc": "Escape", "up": "Up", "down": "Down", "left": "Left", "right": "Right"}
XDOTOOL_KEYS |= {"[": "bracketleft", "]": "bracketright", "+": "plus", "-": "minus", ",": "comma", ".": "period"}


@pytest.mark.gl
@pytest.mark.parametrize("name", sorted(scenes()))
def test_every_scene_opens_and_takes_every_key(display, tmp_path, name):
    """Each scene's window opens, survives every key of its table (then H and N) and closes on Esc. A screenshot
    before the keys shows the window is live (keys sent before its first frame are lost); one after, that it still
    is."""
    view_keys = [binding.key for binding in view_class(scenes()[name]).keys]
    env = {**os.environ, "DISPLAY": display}

    def screenshot(count: int) -> None:
        """Press S every 2 s until ``count`` pictures exist (a window still starting up drops key presses)."""
        deadline = time.time() + 60
        while time.time() < deadline and len(list((tmp_path / "out").glob(f"{name}-*.png"))) < count:
            xdotool(env, "key", "s")
            time.sleep(2.0)

    with viewer_app(env, tmp_path, name, "--size", "320x240") as app:
        window = xdotool(env, "search", "--sync", "--onlyvisible", "--name", "ugpcl")
        assert window, "no ugpcl window appeared"
        xdotool(env, "windowfocus", "--sync", window.splitlines()[0])
        screenshot(1)
        for key in [*view_keys, "h", "n"]:
            xdotool(env, "key", "--delay", "50", XDOTOOL_KEYS.get(key, key))
        screenshot(2)
        xdotool(env, "key", "Escape")
        assert app.wait(timeout=60) == 0, "Esc did not close the window cleanly"
    err = app.err
    assert "Traceback" not in err, err
    shots = sorted((tmp_path / "out").glob(f"{name}-*.png"))
    assert len(shots) >= 2, f"the S key wrote {len(shots)} screenshot(s), not 2; stderr:\n{err}"
    pixels = np.asarray(Image.open(shots[-1]).convert("RGB")).reshape(-1, 3)
    assert len(np.unique(pixels, axis=0)) > 8, "the screenshot after the keys is a flat colour"


@pytest.mark.gl
def test_view_pauses_with_a_message_when_the_state_diverges(display, tmp_path):
    """cloth at stiffness=1e20 turns NaN in a few steps: the window stops stepping, draws no NaN geometry, shows
    the message in the overlay and prints it once."""
    env = {**os.environ, "DISPLAY": display}
    with viewer_app(env, tmp_path, "cloth", "--set", "res=16,16", "stiffness=1e20", "--size", "320x240") as app:
        window = xdotool(env, "search", "--sync", "--onlyvisible", "--name", "ugpcl").splitlines()[0]
        xdotool(env, "windowfocus", "--sync", window)
        time.sleep(4.0)  # the watch reads the state back every CHECK_SECONDS (2 s)
        shot = screenshot(env, tmp_path, "cloth")
        quit_cleanly(env, app)
    err = app.err
    lines = [line for line in err.splitlines() if "diverged" in line]
    assert len(lines) == 1 and "pos" in lines[0] and "stiffness=1e+20" in lines[0], err
    drawn = foreground(shot, view_class(scenes()["cloth"]).background)
    assert drawn[:120, :200].mean() > 0.5, "no message panel at the top left"
    assert drawn[170:].mean() < 0.02, "something besides the message was drawn"


@pytest.mark.gl
def test_ear_clipping_draws_a_ring_with_left_clicks_and_closes_it_with_a_right_click(display, tmp_path):
    """The sample's DrawTest: left clicks add vertices, a right click (press and release, no drag) closes the ring,
    which is then triangulated and filled."""
    env = {**os.environ, "DISPLAY": display}
    with viewer_app(env, tmp_path, "ear_clipping", "--set", "preset=draw", "--size", "320x240") as app:
        window = xdotool(env, "search", "--sync", "--onlyvisible", "--name", "ugpcl").splitlines()[0]
        xdotool(env, "windowfocus", "--sync", window)
        time.sleep(1.0)
        for x, y in ((80, 180), (160, 60), (240, 180)):  # a triangle, in window pixels
            xdotool(env, "mousemove", "--window", window, str(x), str(y), "click", "1")
            time.sleep(0.3)
        xdotool(env, "mousemove", "--window", window, "160", "200", "click", "3")
        time.sleep(1.0)
        shot = screenshot(env, tmp_path, "ear_clipping")
        quit_cleanly(env, app)
    inside = foreground(shot[130:160, 145:175], (0.0, 0.0, 0.0))  # around the triangle's centroid (160, 140)
    assert inside.mean() > 0.9, "the closed ring was not filled"


SLIDER_GRAB = (61, 133, 224)
"""Dear ImGui's default slider grab colour (style SliderGrab 0.24, 0.52, 0.88): how the test finds the sliders."""


def wait_for(paths, count: int = 1, seconds: float = 30.0) -> list:
    """The files matching the glob ``paths`` (folder, pattern) once ``count`` exist (or after ``seconds``)."""
    folder, pattern = paths
    deadline = time.time() + seconds
    while time.time() < deadline and len(list(folder.glob(pattern))) < count:
        time.sleep(0.2)
    return sorted(folder.glob(pattern))


@pytest.mark.gl
def test_panel_opens_and_dragged_sliders_change_the_simulation(display, tmp_path):
    """H opens the panel (its sliders appear at the right). Dragging max_speed (live) to its left end applies it at
    once; dragging max_object_num (not live) to 1 waits, and "reset to apply" then leaves one boid on screen."""
    env = {**os.environ, "DISPLAY": display}
    shots = (tmp_path / "out", "boids-*.png")

    def screenshot() -> np.ndarray:
        count = len(list(shots[0].glob(shots[1]))) + 1
        xdotool(env, "key", "s")
        return np.asarray(Image.open(wait_for(shots, count)[-1]).convert("RGB"))

    def drag(x0: int, x1: int, y: int) -> None:
        xdotool(env, "mousemove", "--window", window, str(x0), str(y))
        time.sleep(0.5)
        xdotool(env, "mousedown", "1")
        time.sleep(1.0)
        xdotool(env, "mousemove", "--window", window, str(x0 - 20), str(y))
        time.sleep(0.5)
        xdotool(env, "mousemove", "--window", window, str(x1), str(y))
        time.sleep(1.0)
        xdotool(env, "mouseup", "1")
        time.sleep(1.0)

    with viewer_app(env, tmp_path, "boids", "--set", "max_object_num=512", "--size", "900x600") as app:
        window = xdotool(env, "search", "--sync", "--onlyvisible", "--name", "ugpcl").splitlines()[0]
        xdotool(env, "windowfocus", "--sync", window)
        time.sleep(2.0)
        closed = screenshot()
        xdotool(env, "key", "h")
        time.sleep(1.5)
        opened = screenshot()
        grab = np.abs(opened.astype(int) - SLIDER_GRAB).sum(axis=-1) <= 6
        rows = np.flatnonzero(grab.any(axis=1))
        starts = rows[np.r_[True, np.diff(rows) > 1]]  # the first row of each slider's grab, top to bottom
        centre = [(int(np.flatnonzero(grab[y + 4]).mean()), int(y) + 4) for y in starts]
        # sliders in field order: max_object_num, 3 neighbourhood radii, then max_speed
        drag(centre[4][0], 505, centre[4][1])
        drag(centre[0][0], 505, centre[0][1])
        many = screenshot()
        # "reset to apply" sits left in the row above the "parameters" header, which is above the first slider
        xdotool(env, "mousemove", "--window", window, "530", str(centre[0][1] - 46), "click", "1")
        time.sleep(2.0)
        one = screenshot()
        quit_cleanly(env, app)
    err = app.err
    assert "Traceback" not in err, err
    assert not (np.abs(closed.astype(int) - SLIDER_GRAB).sum(axis=-1) <= 6).any(), "a slider showed before H"
    assert len(starts) >= 5 and grab[:, 500:].any() and not grab[:, :500].any(), "no panel at the right after H"
    lines = [line for line in err.splitlines() if line.startswith("ugpcl-view: max_")]
    speed = [line for line in lines if line.startswith("ugpcl-view: max_speed = ")]
    assert speed and speed[-1].endswith("(live)") and float(speed[-1].split()[3]) < 0.02, err
    assert "ugpcl-view: max_object_num = 1 (pending: reset to apply)" in lines, err
    assert "ugpcl-view: reset with max_object_num=1" in err, err
    scene = np.s_[40:, :500]  # left of the panel, below the status line
    background = view_class(scenes()["boids"]).background
    before, after = (foreground(shot[scene], background, 40).mean() for shot in (many, one))
    assert before > 0.02 and after < before / 20, f"{before:.4f} -> {after:.4f} of the scene covered by boids"


@pytest.mark.gl
def test_record_keys_write_an_mp4_and_a_png_sequence_of_the_window(display, tmp_path):
    """F9 records the window to out/boids-<time>.mp4 until pressed again; F10 the same as PNGs."""
    env = {**os.environ, "DISPLAY": display}
    with viewer_app(env, tmp_path, "boids", "--size", "320x240") as app:
        window = xdotool(env, "search", "--sync", "--onlyvisible", "--name", "ugpcl").splitlines()[0]
        xdotool(env, "windowfocus", "--sync", window)
        time.sleep(2.0)
        for key in ("F9", "F10"):
            xdotool(env, "key", key)
            time.sleep(3.0)
            xdotool(env, "key", key)
            time.sleep(1.0)
        quit_cleanly(env, app)
    err = app.err
    assert "Traceback" not in err, err
    assert "max_object_num=2048" in err, "on a CPU device boids start at the interactive size"
    written = [line.split()[2:] for line in err.splitlines() if line.startswith("ugpcl-view: wrote out/")]
    assert len(written) == 2, err
    (video, video_count), (folder, folder_count) = [(tmp_path / w[0], int(w[1].strip("("))) for w in written]
    frames = iio.imread(video)
    assert video.suffix == ".mp4" and frames.shape == (video_count, 240, 320, 3) and video_count >= 2
    pngs = sorted(folder.glob("frame-*.png"))
    assert len(pngs) == folder_count >= 2
    first, last = (np.asarray(Image.open(p).convert("RGB")) for p in (pngs[0], pngs[-1]))
    background = view_class(scenes()["boids"]).background
    assert foreground(last, background, 40).mean() > 0.01, "the recorded frame shows no boids"
    assert (first != last).any(), "the boids did not move while recording"
