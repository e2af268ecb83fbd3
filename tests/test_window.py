"""`ugpcl-view` in a real window: Xvfb for the screen, xdotool for the keys (Debian xvfb + xdotool; `make`
installs them)."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from helpers import foreground
from PIL import Image
from ugpcl.viewer.views import view_class

from ugpcl.scenes import scenes


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


@pytest.mark.gl
def test_view_opens_a_window_and_obeys_keys(display, tmp_path):
    env = {**os.environ, "DISPLAY": display}
    viewer = Path(sys.executable).parent / "ugpcl-view"
    app = subprocess.Popen(
        [str(viewer), "boids", "--set", "max_object_num=512", "--size", "320x240"],
        cwd=tmp_path,
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        window = xdotool(env, "search", "--sync", "--onlyvisible", "--name", "ugpcl")
        assert window, "no ugpcl window appeared"
        window = window.splitlines()[0]
        xdotool(env, "windowfocus", "--sync", window)
        xdotool(env, "key", "h")  # help overlay
        xdotool(env, "key", "space")  # pause
        time.sleep(1.0)
        xdotool(env, "key", "s")  # screenshot
        deadline = time.time() + 30
        while time.time() < deadline and not list((tmp_path / "out").glob("boids-*.png")):
            time.sleep(0.2)
        shots = list((tmp_path / "out").glob("boids-*.png"))
        assert shots, "the S key wrote no screenshot"
        xdotool(env, "key", "Escape")
        assert app.wait(timeout=30) == 0, "Esc did not close the window cleanly"
    finally:
        if app.poll() is None:
            app.kill()
        _, err = app.communicate()
    pixels = np.asarray(Image.open(shots[0]).convert("RGB"))
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
    viewer = Path(sys.executable).parent / "ugpcl-view"
    app = subprocess.Popen(
        [str(viewer), name, "--size", "320x240"], cwd=tmp_path, env=env, stderr=subprocess.PIPE, text=True
    )

    def screenshot(count: int) -> None:
        """Press S every 2 s until ``count`` pictures exist (a window still starting up drops key presses)."""
        deadline = time.time() + 60
        while time.time() < deadline and len(list((tmp_path / "out").glob(f"{name}-*.png"))) < count:
            xdotool(env, "key", "s")
            time.sleep(2.0)

    try:
        window = xdotool(env, "search", "--sync", "--onlyvisible", "--name", "ugpcl")
        assert window, "no ugpcl window appeared"
        xdotool(env, "windowfocus", "--sync", window.splitlines()[0])
        screenshot(1)
        for key in [*view_keys, "h", "n"]:
            xdotool(env, "key", "--delay", "50", XDOTOOL_KEYS.get(key, key))
        screenshot(2)
        xdotool(env, "key", "Escape")
        assert app.wait(timeout=60) == 0, "Esc did not close the window cleanly"
    finally:
        if app.poll() is None:
            app.kill()
        _, err = app.communicate()
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
    viewer = Path(sys.executable).parent / "ugpcl-view"
    argv = [str(viewer), "cloth", "--set", "res=16,16", "stiffness=1e20", "--size", "320x240"]
    app = subprocess.Popen(argv, cwd=tmp_path, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        window = xdotool(env, "search", "--sync", "--onlyvisible", "--name", "ugpcl").splitlines()[0]
        xdotool(env, "windowfocus", "--sync", window)
        time.sleep(4.0)  # the watch reads the state back every CHECK_SECONDS (2 s)
        xdotool(env, "key", "s")
        deadline = time.time() + 30
        while time.time() < deadline and not list((tmp_path / "out").glob("cloth-*.png")):
            time.sleep(0.2)
        xdotool(env, "key", "Escape")
        assert app.wait(timeout=30) == 0
    finally:
        if app.poll() is None:
            app.kill()
        _, err = app.communicate()
    lines = [line for line in err.splitlines() if "diverged" in line]
    assert len(lines) == 1 and "pos" in lines[0] and "stiffness=1e+20" in lines[0], err
    shot = np.asarray(Image.open(next((tmp_path / "out").glob("cloth-*.png"))).convert("RGB"))
    drawn = foreground(shot, view_class(scenes()["cloth"]).background)
    assert drawn[:120, :200].mean() > 0.5, "no message panel at the top left"
    assert drawn[170:].mean() < 0.02, "something besides the message was drawn"


@pytest.mark.gl
def test_ear_clipping_draws_a_ring_with_left_clicks_and_closes_it_with_a_right_click(display, tmp_path):
    """The sample's DrawTest: left clicks add vertices, a right click (press and release, no drag) closes the ring,
    which is then triangulated and filled."""
    env = {**os.environ, "DISPLAY": display}
    viewer = Path(sys.executable).parent / "ugpcl-view"
    argv = [str(viewer), "ear_clipping", "--set", "preset=draw", "--size", "320x240"]
    app = subprocess.Popen(argv, cwd=tmp_path, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        window = xdotool(env, "search", "--sync", "--onlyvisible", "--name", "ugpcl").splitlines()[0]
        xdotool(env, "windowfocus", "--sync", window)
        time.sleep(1.0)
        for x, y in ((80, 180), (160, 60), (240, 180)):  # a triangle, in window pixels
            xdotool(env, "mousemove", "--window", window, str(x), str(y), "click", "1")
            time.sleep(0.3)
        xdotool(env, "mousemove", "--window", window, "160", "200", "click", "3")
        time.sleep(1.0)
        xdotool(env, "key", "s")
        deadline = time.time() + 30
        while time.time() < deadline and not list((tmp_path / "out").glob("ear_clipping-*.png")):
            time.sleep(0.2)
        xdotool(env, "key", "Escape")
        assert app.wait(timeout=30) == 0
    finally:
        if app.poll() is None:
            app.kill()
        app.communicate()
    shot = np.asarray(Image.open(next((tmp_path / "out").glob("ear_clipping-*.png"))).convert("RGB"))
    inside = foreground(shot[130:160, 145:175], (0.0, 0.0, 0.0))  # around the triangle's centroid (160, 140)
    assert inside.mean() > 0.9, "the closed ring was not filled"
