"""`ugpcl-view` in a real window: Xvfb for the screen, xdotool for the keys and the mouse (Debian xvfb + xdotool;
`make` installs them). The window reports every frame it draws and every key and mouse event it handles to a trace
file (``UGPCL_VIEW_TRACE``, viewer/app.py): each step of a test waits for the line that says the window got it and
for the frames that show it, never for a fixed time, so a test takes as long as the window needs and no longer."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import time
from collections import Counter
from contextlib import contextmanager
from pathlib import Path

import imageio.v3 as iio
import numpy as np
import pytest
from helpers import foreground
from PIL import Image
from ugpcl.viewer.views import view_class

from ugpcl.registry import scenes


@pytest.fixture(scope="module")
def display():
    """One Xvfb screen for the module's windows (each test opens and closes its own)."""
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


XDOTOOL_KEYS = {"tab": "Tab", "esc": "Escape", "up": "Up", "down": "Down", "left": "Left", "right": "Right"}
XDOTOOL_KEYS |= {"f9": "F9", "f10": "F10"}
XDOTOOL_KEYS |= {"[": "bracketleft", "]": "bracketright", "+": "plus", "-": "minus", ",": "comma", ".": "period"}
"""xdotool's names for the keys the viewer's tables name otherwise."""

WAIT_SECONDS = 60.0
"""How long a window may take to report a frame, a key or a mouse event before the test fails (a busy machine)."""


class Window:
    """``ugpcl-view`` running on a display, driven through xdotool and watched through its trace file
    (``UGPCL_VIEW_TRACE``: one line per frame drawn, key handled, mouse event): every step waits for the line that
    says the window got it, then for frames that show it, never for a fixed time."""

    def __init__(self, env: dict, cwd: Path, app: subprocess.Popen, trace: Path):
        self.env, self.cwd, self.app, self.trace = env, cwd, app, trace
        self.lines: list[str] = []
        self.counts: Counter[str] = Counter()  # how often each line came (keys: "key s"; mouse events by kind)
        self.frame, self.sim_time = 0, 0.0  # the number of the last frame drawn, the simulated time it showed
        self._offset = 0
        self.id = ""

    def _read(self) -> None:
        if not self.trace.exists():
            return
        with self.trace.open("rb") as file:
            file.seek(self._offset)
            data = file.read()
        whole = data[: data.rfind(b"\n") + 1]  # a line being written waits for the next read
        self._offset += len(whole)
        for line in whole.decode().splitlines():
            self.lines.append(line)
            kind, _, rest = line.partition(" ")
            if kind == "frame":
                number, sim_time = rest.split()
                self.frame, self.sim_time = int(number), float(sim_time)
            else:
                self.counts[line] += 1
                if rest:  # a mouse event: counted by kind too
                    self.counts[kind] += 1

    def wait(self, until, what: str) -> None:
        """Poll the trace until ``until()`` holds; fail naming ``what`` if the window quits or takes too long."""
        deadline = time.monotonic() + WAIT_SECONDS
        while True:
            self._read()
            if until():
                return
            if self.app.poll() is not None:
                err = self.app.stderr.read()[-3000:]
                pytest.fail(f"the window quit (exit {self.app.returncode}) while waiting for {what}; stderr:\n{err}")
            if time.monotonic() > deadline:
                pytest.fail(f"no {what} within {WAIT_SECONDS:.0f} s; the trace ends {self.lines[-5:]}")
            time.sleep(0.02)

    def count(self, line: str) -> int:
        """How often the trace holds ``line`` (or, for a mouse event's kind, how many of that kind)."""
        self._read()
        return self.counts[line]

    def wait_frames(self, n: int = 1) -> None:
        """Wait until ``n`` more frames are drawn (what an event changed is on screen)."""
        self._read()
        target = self.frame + n
        self.wait(lambda: self.frame >= target, f"frame {target}")

    def open(self) -> None:
        """Wait for the window and its first frame, focus it, and make sure it takes keys (a window still starting
        up drops them): an unbound key (F12) is pressed until the window reports one."""
        self.wait(lambda: self.frame >= 1, "the first frame")
        self.id = xdotool(self.env, "search", "--sync", "--onlyvisible", "--name", "ugpcl").splitlines()[0]
        xdotool(self.env, "windowfocus", "--sync", self.id)
        deadline = time.monotonic() + WAIT_SECONDS
        while self.count("key None") == 0:
            assert time.monotonic() < deadline, f"the window took no key in {WAIT_SECONDS:.0f} s"
            xdotool(self.env, "key", "F12")
            self.wait_frames(2)

    def key(self, name: str, frames: int = 1) -> None:
        """Press the viewer's key ``name`` (its key-table name), wait until the window has handled it and drawn
        ``frames`` frames after it."""
        self.keys([name], frames)

    def keys(self, names: list[str], frames: int = 1) -> None:
        """Press the keys ``names`` in one burst (the window handles them between two frames, as it would a
        person's quick presses; a scene whose frames are slow in some mode draws it once, not once per key), wait
        until the window has handled every one, then for ``frames`` frames."""
        wanted = {name: self.count(f"key {name}") + names.count(name) for name in names}
        xdotool(self.env, "key", "--delay", "0", *(XDOTOOL_KEYS.get(name, name) for name in names))

        self.wait(lambda: all(self.counts[f"key {k}"] >= n for k, n in wanted.items()), f"keys {names}")
        self.wait_frames(frames)

    def mouse(self, *args, event: str, frames: int = 3) -> None:
        """xdotool ``ARGS`` (a mousemove in window pixels, a click, a button down or up), then wait for the window's
        next mouse ``event`` line (move, drag, press, release) and ``frames`` frames. ImGui takes one button event
        per frame and the panel acts after the scene is drawn: a click (press and release before one frame) is
        pressed in the first frame, released (acting) in the second and shown in the third."""
        seen = self.count(event)
        xdotool(self.env, *(self.id if a == "WINDOW" else a for a in args))
        self.wait(lambda: self.counts[event] > seen, f"a mouse {event}")
        self.wait_frames(frames)

    def screenshot(self, scene: str) -> np.ndarray:
        """Press S: the picture the window wrote to out/<scene>-<time>.png (written before the key is reported)."""
        before = set((self.cwd / "out").glob(f"{scene}-*.png"))
        self.key("s", frames=0)
        shots = sorted(set((self.cwd / "out").glob(f"{scene}-*.png")) - before)
        assert len(shots) == 1, f"the S key wrote {len(shots)} screenshots"
        return np.asarray(Image.open(shots[0]).convert("RGB"))

    def quit(self) -> None:
        xdotool(self.env, "key", "Escape")
        assert self.app.wait(timeout=WAIT_SECONDS) == 0, "Esc did not close the window cleanly"


@contextmanager
def viewer_app(display, cwd, *args):
    """``ugpcl-view ARGS`` on ``display``, opened (first frame drawn, focused, taking keys); on leaving, killed if
    still open, its stderr in ``window.err``."""
    viewer = Path(sys.executable).parent / "ugpcl-view"
    trace = cwd / "trace.txt"
    env = {**os.environ, "DISPLAY": display, "UGPCL_VIEW_TRACE": str(trace)}
    app = subprocess.Popen([str(viewer), *args], cwd=cwd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                           text=True)  # fmt: skip
    window = Window(env, cwd, app, trace)
    try:
        window.open()
        yield window
    finally:
        if app.poll() is None:
            app.kill()
        window.err = app.communicate()[1]


@pytest.mark.gl
def test_view_opens_a_window_and_obeys_keys(display, tmp_path):
    with viewer_app(display, tmp_path, "boids", "--set", "max_object_num=512", "--size", "320x240") as window:
        window.key("h")  # help overlay
        window.key("space")  # pause
        pixels = window.screenshot("boids")
        window.quit()
    err = window.err
    assert pixels.shape == (240, 320, 3)
    assert foreground(pixels, (0.192, 0.302, 0.475)).mean() > 0.05, "the screenshot shows no boids or overlay"
    assert "wrote out/boids-" in err
    assert " - INFO - " not in err, "moderngl-window's INFO lines without -v"


@pytest.mark.gl
def test_the_window_flags_reach_moderngl_window(display, tmp_path):
    """--samples (and the other window flags) are moderngl-window's; -v shows its INFO lines (the GL context)."""
    with viewer_app(display, tmp_path, "boids", "--set", "max_object_num=256", "--size", "320x240", "--samples",
                    "2", "-v") as window:  # fmt: skip
        window.quit()
    assert " - INFO - " in window.err and "ModernGL" in window.err


@pytest.mark.gl
@pytest.mark.parametrize("name", sorted(scenes()))
def test_every_scene_opens_and_takes_every_key(display, tmp_path, name):
    """Each scene's window opens, handles every key of its table (then H and N) and draws a frame after them, and
    closes on Esc. A screenshot before the keys shows the window is live; one after, that it still is."""
    view_keys = [binding.key for binding in view_class(scenes()[name]).keys]
    with viewer_app(display, tmp_path, name, "--size", "320x240") as window:
        window.screenshot(name)
        window.keys([*view_keys, "h", "n"])
        window.screenshot(name)
        window.quit()
    err = window.err
    assert "Traceback" not in err, err
    shots = sorted((tmp_path / "out").glob(f"{name}-*.png"))
    assert len(shots) == 2, f"the S key wrote {len(shots)} screenshot(s), not 2; stderr:\n{err}"
    pixels = np.asarray(Image.open(shots[-1]).convert("RGB")).reshape(-1, 3)
    assert len(np.unique(pixels, axis=0)) > 8, "the screenshot after the keys is a flat colour"


@pytest.mark.gl
def test_view_pauses_with_a_message_when_the_state_diverges(display, tmp_path):
    """cloth at stiffness=1e20 turns NaN in a few steps: the window stops stepping, draws no NaN geometry, shows
    the message in the overlay and prints it once."""
    with viewer_app(display, tmp_path, "cloth", "--set", "res=16,16", "stiffness=1e20", "--size", "320x240") as window:
        # the watch reads the state back every CHECK_SECONDS (2 s)
        window.wait(lambda: window.counts["diverged"], "the divergence")
        window.wait_frames(2)
        shot = window.screenshot("cloth")
        window.wait_frames(5)  # frames drawn while paused: the message is not printed again
        window.quit()
    err = window.err
    lines = [line for line in err.splitlines() if "diverged" in line]
    assert len(lines) == 1 and "pos" in lines[0] and "stiffness=1e+20" in lines[0], err
    assert window.count("diverged") == 1, "the window found the divergence more than once"
    drawn = foreground(shot, view_class(scenes()["cloth"]).background)
    assert drawn[:120, :200].mean() > 0.5, "no message panel at the top left"
    assert drawn[170:].mean() < 0.02, "something besides the message was drawn"


@pytest.mark.gl
def test_ear_clipping_draws_a_ring_with_left_clicks_and_closes_it_with_a_right_click(display, tmp_path):
    """The sample's DrawTest: left clicks add vertices, a right click (press and release, no drag) closes the ring,
    which is then triangulated and filled."""
    with viewer_app(display, tmp_path, "ear_clipping", "--set", "preset=draw", "--size", "320x240") as window:
        for x, y in ((80, 180), (160, 60), (240, 180)):  # a triangle, in window pixels
            window.mouse("mousemove", "--window", "WINDOW", str(x), str(y), "click", "1", event="release")
        window.mouse("mousemove", "--window", "WINDOW", "160", "200", "click", "3", event="release")
        shot = window.screenshot("ear_clipping")
        window.quit()
    inside = foreground(shot[130:160, 145:175], (0.0, 0.0, 0.0))  # around the triangle's centroid (160, 140)
    assert inside.mean() > 0.9, "the closed ring was not filled"


SLIDER_GRAB = (61, 133, 224)
"""Dear ImGui's default slider grab colour (style SliderGrab 0.24, 0.52, 0.88): how the test finds the sliders."""


@pytest.mark.gl
def test_panel_opens_and_dragged_sliders_change_the_simulation(display, tmp_path):
    """H opens the panel (its sliders appear at the right). Dragging max_speed (live) to its left end applies it at
    once; dragging max_object_num (not live) to 1 waits, and "reset to apply" then leaves one boid on screen."""

    def drag(x0: int, x1: int, y: int) -> None:
        """Onto a slider's grab, press, a little left, then to x1, release: each event seen and drawn."""
        window.mouse("mousemove", "--window", "WINDOW", str(x0), str(y), event="move")
        window.mouse("mousedown", "1", event="press")
        window.mouse("mousemove", "--window", "WINDOW", str(x0 - 20), str(y), event="drag")
        window.mouse("mousemove", "--window", "WINDOW", str(x1), str(y), event="drag")
        window.mouse("mouseup", "1", event="release")

    with viewer_app(display, tmp_path, "boids", "--set", "max_object_num=512", "--size", "900x600") as window:
        # seen from outside the box (the wall box hidden), the 512 boids cover about 1 to 2 % of the scene's part of
        # the window, one boid a few hundredths of that; the max_speed drag below nearly stops them
        window.key("b")
        window.wait(lambda: window.sim_time >= 2.0, "2 s of simulated time")
        closed = window.screenshot("boids")
        window.key("h", frames=2)
        opened = window.screenshot("boids")
        grab = np.abs(opened.astype(int) - SLIDER_GRAB).sum(axis=-1) <= 6
        rows = np.flatnonzero(grab.any(axis=1))
        starts = rows[np.r_[True, np.diff(rows) > 1]]  # the first row of each slider's grab, top to bottom
        centre = [(int(np.flatnonzero(grab[y + 4]).mean()), int(y) + 4) for y in starts]
        # sliders in field order: max_object_num, 3 neighbourhood radii, then max_speed
        drag(centre[4][0], 505, centre[4][1])
        drag(centre[0][0], 505, centre[0][1])
        many = window.screenshot("boids")
        # "reset to apply" sits left in the row above the "parameters" header, which is above the first slider
        window.mouse("mousemove", "--window", "WINDOW", "530", str(centre[0][1] - 46), "click", "1", event="release")
        one = window.screenshot("boids")
        window.quit()
    err = window.err
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
    assert before > 0.005 and after < before / 20, f"{before:.4f} -> {after:.4f} of the scene covered by boids"


RECORDED_FRAMES = 6
"""Frames each recording runs for at least: enough for the boids to move between its first and last."""


@pytest.mark.gl
def test_record_keys_write_an_mp4_and_a_png_sequence_of_the_window(display, tmp_path):
    """F9 records the window to out/boids-<time>.mp4 until pressed again; F10 the same as PNGs."""
    with viewer_app(display, tmp_path, "boids", "--size", "320x240") as window:
        for key in ("f9", "f10"):
            window.key(key, frames=RECORDED_FRAMES)
            window.key(key, frames=0)
        window.quit()
    err = window.err
    assert "Traceback" not in err, err
    assert "max_object_num=2048" in err, "on a CPU device boids start at the interactive size"
    written = [line.split()[2:] for line in err.splitlines() if line.startswith("ugpcl-view: wrote out/")]
    assert len(written) == 2, err
    (video, video_count), (folder, folder_count) = [(tmp_path / w[0], int(w[1].strip("("))) for w in written]
    frames = iio.imread(video)
    assert video.suffix == ".mp4" and frames.shape == (video_count, 240, 320, 3) and video_count >= RECORDED_FRAMES
    pngs = sorted(folder.glob("frame-*.png"))
    assert len(pngs) == folder_count >= RECORDED_FRAMES
    first, last = (np.asarray(Image.open(p).convert("RGB")) for p in (pngs[0], pngs[-1]))
    background = view_class(scenes()["boids"]).background
    assert foreground(last, background, 40).mean() > 0.01, "the recorded frame shows no boids"
    assert (first != last).any(), "the boids did not move while recording"


@pytest.mark.gl
def test_esc_closes_an_open_dropdown_first_and_r_applies_pending_edits(display, tmp_path):
    """Esc with the preset dropdown open closes the dropdown and the window stays; R then applies a pending edit
    (a non-live parameter changed in the panel) as "reset to apply" does; a second Esc quits."""
    with viewer_app(display, tmp_path, "ear_clipping", "--size", "1100x700") as window:  # wide: the panel is open
        window.wait(lambda: any(line.startswith("widget preset ") for line in window.lines), "the preset dropdown")
        x0, y0, x1, y1 = map(int, next(line for line in window.lines if line.startswith("widget preset ")).split()[2:])
        window.mouse("mousemove", "--window", "WINDOW", str((x0 + x1) // 2), str((y0 + y1) // 2), "click", "1",
                     event="release")  # fmt: skip
        window.wait(lambda: window.count("popup open") >= 1, "the dropdown to open")
        window.key("esc", frames=3)
        window.wait(lambda: window.count("popup closed") >= 1, "the dropdown to close")
        assert window.app.poll() is None, "Esc with a dropdown open closed the window"
        # text_size is not live: typed into the panel it waits; R applies it
        x0, y0, x1, y1 = map(
            int, next(line for line in window.lines if line.startswith("widget text_size ")).split()[2:]
        )
        window.mouse("mousemove", "--window", "WINDOW", str((x0 + x1) // 2), str((y0 + y1) // 2), event="move")
        xdotool(window.env, "keydown", "ctrl")
        window.mouse("click", "1", event="release")
        xdotool(window.env, "keyup", "ctrl")
        xdotool(window.env, "key", "ctrl+a")
        window.wait(lambda: window.count("typing on") >= 1, "the text field to take the keys")
        xdotool(window.env, "type", "6")
        xdotool(window.env, "key", "Return")
        window.wait(lambda: window.count("typing off") >= 1, "the text field to give the keys back")
        window.key("r", frames=3)
        window.quit()
    err = window.err
    assert "ugpcl-view: text_size = 6 (pending: reset to apply)" in err, err
    assert "ugpcl-view: reset with text_size=6" in err, err


@pytest.mark.gl
@pytest.mark.parametrize("name", ["boids", "stable_fluids_2d", "ear_clipping"])
def test_with_the_panel_open_the_subject_is_whole_beside_it(display, tmp_path, name):
    """A window wide enough opens with its panel: the scene is drawn in the rest of the window, so its subject
    (the box of boids, the ink stroke, the nested rings) lies whole left of the panel, clear of its edge."""
    with viewer_app(display, tmp_path, name, "--size", "1100x650") as window:
        window.wait(lambda: window.sim_time >= 3.0, "3 s of simulated time")  # the stroke has drawn its ink
        pixels = window.screenshot(name)
        window.quit()
    scene_width = 1100 - 400  # the panel is 400 pixels wide
    background = view_class(scenes()[name]).background
    subject = foreground(pixels[:, :scene_width], background, 40)
    subject[:70] = False  # the status lines at the top left
    columns = np.flatnonzero(subject.any(axis=0))
    assert len(columns) > 100, f"{name}: almost nothing drawn left of the panel"
    assert columns.max() < scene_width - 20, f"{name}: the subject runs under the panel (to column {columns.max()})"
    assert columns.min() > 20, f"{name}: the subject is cut at the left edge"
