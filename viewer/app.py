"""``ugpcl-view SCENE``: the interactive window (moderngl-window) with the keys every scene shares.

Shared keys live in SHARED_KEYS; a scene's own keys in its View's ``keys`` table. The panel's "keys" section and
``ugpcl-view --keys SCENE`` (the README tables) are both generated from those two tables.

The panel (H) is Dear ImGui through imgui-bundle: the HUD (frame rate, where the time goes, device, steps), one
widget per parameter (``viewer.panel``, generated from the scene's Params) and the keys. On a CPU device the scene
starts at its ``Scene.interactive`` sizes, so that it runs at interactive rates; ``--set`` still wins.
"""

from __future__ import annotations

import ctypes
import logging
import os
import sys
import time
import warnings
from pathlib import Path

import moderngl
import moderngl_window as mglw
from imgui_bundle import imgui

from ugpcl import resources
from ugpcl.io import UsageError, written_whole
from ugpcl.options import ArgumentParser, HelpFormatter, parse_sets, parse_size, quiet_broken_pipe, scene_named
from ugpcl.run import Diverged, Watch
from ugpcl.runtime import BuildError, DeviceError, Runtime
from ugpcl.scene import ParameterIgnored, ParameterReset, show_value

from .gl import TextOverlay, read_pixels, save_png
from .imgui_renderer import ImguiRenderer
from .panel import Panel, draw_widget
from .record import Recorder
from .views import Key, View, create_view, view_class

SHARED_KEYS = (
    Key("space", "pause / run", "toggle_pause"),
    Key("n", "single step (while paused)", "single_step"),
    Key("r", "reset (re-seed), with the panel's pending edits applied", "reset"),
    Key("s", "screenshot to out/<scene>-<time>.png", "screenshot"),
    Key("h", "panel on/off: HUD, parameters (ctrl+click a slider to type), keys", "toggle_panel"),
    Key("f9", "record the window to out/<scene>-<time>.mp4 (again: stop)", "toggle_video"),
    Key("f10", "record the window as PNGs to out/<scene>-<time>/ (again: stop)", "toggle_frames"),
    Key("esc", "quit", "quit"),
)
PANEL_WIDTH = 400
PANEL_OPEN_FROM = 960
"""The panel starts open in a window at least this wide (it leaves most of the scene in view); H toggles it."""
SMOOTHING = 0.05
"""Weight of the newest frame in the HUD's running averages."""
MOUSE_HELP = "mouse: left drag = orbit (3D) or the scene's brush (2D), right drag = orbit, wheel = zoom"
TRACE_ENV = "UGPCL_VIEW_TRACE"
"""A file the window appends one line to for each frame it drew (``frame N SIM_TIME``), key it handled
(``key NAME``, after the key's action; NAME is None for an unbound key), mouse event it got (``press BUTTON X Y``,
``release ...``, ``move X Y``, ``drag X Y``) and divergence it found (``diverged``): tests/test_window.py drives a
real window by waiting for these lines, not by sleeping."""


def key_rows(scene) -> list[tuple[str, str]]:
    """(key, help) for the shared keys and the scene's own, in overlay order."""
    return [(k.key, k.help) for k in SHARED_KEYS] + [(k.key, k.help) for k in view_class(scene).keys]


def keys_markdown(scene) -> str:
    lines = ["| key | action |", "|---|---|"]
    for key, text in key_rows(scene):
        text = text.replace("|", r"\|")  # a literal | would end the table cell
        lines.append(f"| `{key}` | {text} |")
    return "\n".join(lines)


class FrameTimes:
    """The HUD's running averages (one exponential weight, SMOOTHING) of a frame's time and of the simulation's and
    the drawing's share of it. Each sample is one whole frame, from its start to the next frame's start, with the
    parts measured inside it, so the averaged parts never add up to more than the averaged whole."""

    def __init__(self):
        self.frame = self.sim = self.draw = 0.0  # seconds
        self.samples = 0
        self._start: float | None = None
        self._parts: tuple[float, float] | None = None

    def start(self, now: float) -> None:
        """A frame starts at ``now``: the one before it is complete."""
        if self._start is not None and self._parts is not None:
            weight = 1.0 if self.samples == 0 else SMOOTHING
            for name, value in zip(("frame", "sim", "draw"), (now - self._start, *self._parts), strict=True):
                setattr(self, name, getattr(self, name) + weight * (value - getattr(self, name)))
            self.samples += 1
        self._start, self._parts = now, None

    def parts(self, sim: float, draw: float) -> None:
        """The current frame's simulation and drawing time."""
        self._parts = (sim, draw)


class ViewerWindow(mglw.WindowConfig):
    """One scene in a window. ``launch`` (scene, params, seed) is set by ``main`` before the window opens."""

    gl_version = (4, 3)
    title = "ugpcl"
    window_size = (1280, 720)
    aspect_ratio = None
    resizable = True
    vsync = True
    samples = 4
    launch: dict = {}

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        launch = type(self).launch
        self.scene = launch["scene"]
        self.runtime = launch["runtime"]
        self.sim = self.scene.simulation(self.runtime, launch["params"], launch["seed"])
        self.sized = launch.get("sized", {})  # the CPU-sized overrides in effect (the HUD says so)
        self.view: View = create_view(self.scene, self.ctx, self.sim)
        self.camera = self.view.make_camera()
        self.camera.aspect = self.wnd.aspect_ratio
        self.paused, self.step_once = False, False
        self.right_click = False  # the right button is down and has not moved
        self.in_panel = False  # the mouse button went down on the panel
        self.watch, self.diverged = Watch(self.sim), None  # diverged: the message while the state holds NaN/inf
        self.overlay = TextOverlay(self.ctx)
        self.wnd.title = f"ugpcl - {self.view.title or self.scene.name}  (H: panel)"
        self.key_names = self._key_names()
        self.wnd.exit_key = None  # Esc is the shared key table's "quit", which an open dropdown takes first
        imgui.create_context()
        imgui.get_io().set_ini_filename("")  # no imgui.ini left in the user's folder
        self.imgui = ImguiRenderer(self.wnd)
        self.panel = Panel(self.sim, launch["params"])
        self.show_panel = self.wnd.size[0] >= PANEL_OPEN_FROM
        self.times = FrameTimes()  # the HUD's split of a frame
        self.recorder: Recorder | None = None
        trace = os.environ.get(TRACE_ENV)
        self.trace_file = open(trace, "a", buffering=1) if trace else None  # noqa: SIM115 (open until the window closes)
        self.frames = 0
        self.popup_open, self.close_popups = False, False  # a panel dropdown is open; Esc asked to close it
        self.typing = False  # a panel text field has the keys
        self.traced_widgets: dict[str, tuple] = {}  # where each widget was last said to be (the trace)
        sized = f"; sized for the CPU: {_assignments(self.sized)} (--set wins)" if self.sized else ""
        print(f"ugpcl-view: {self.scene.name} on {self.runtime.label}{sized}; H shows the panel", file=sys.stderr)

    def _key_names(self) -> dict:
        keys = self.wnd.keys
        names = {
            keys.SPACE: "space",
            keys.TAB: "tab",
            keys.ESCAPE: "esc",
            keys.LEFT_BRACKET: "[",
            keys.RIGHT_BRACKET: "]",
            keys.MINUS: "-",
            keys.EQUAL: "+",
            keys.UP: "up",
            keys.DOWN: "down",
            keys.LEFT: "left",
            keys.RIGHT: "right",
            keys.COMMA: ",",
            keys.PERIOD: ".",
        }
        names.update({getattr(keys, f"NUMBER_{d}"): str(d) for d in range(10)})
        names.update({keys.F9: "f9", keys.F10: "f10"})
        names.update({getattr(keys, c.upper()): c for c in "abcdefghijklmnopqrstuvwxyz"})
        # pyglet's own codes where moderngl-window's constants differ ([ and ] are ASCII there, + and keypad +/-)
        names.update({ord("["): "[", ord("]"): "]", ord("+"): "+"})
        for attr, name in (("NUMPAD_ADD", "+"), ("NUMPAD_SUBTRACT", "-"), ("NUM_ADD", "+"), ("NUM_SUBTRACT", "-")):
            if hasattr(keys, attr):
                names[getattr(keys, attr)] = name
        return names

    # {{{ frame

    def on_render(self, time_: float, frame_time: float) -> None:
        start = time.perf_counter()
        self.times.start(start)
        if not self.paused or self.step_once:
            dt = self.sim.default_dt
            if self.view.max_frame_dt is not None and frame_time > 0:
                dt = min(frame_time, self.view.max_frame_dt)
            for _ in range(self.view.steps_per_frame):
                self.sim.step(dt)
            self.step_once = False
            if self.watch.due() or self.paused:
                self.check_divergence()
        if self.show_panel:  # the HUD splits the frame: wait for the device only while it is shown
            self.runtime.queue.finish()
        stepped = time.perf_counter()
        self.ctx.enable(moderngl.DEPTH_TEST)
        self.ctx.clear(*self.view.background, 1.0, depth=1.0)
        width, height = self.scene_size()
        self.camera.aspect = width / max(height, 1)
        scale = self.wnd.buffer_size[0] / max(self.wnd.size[0], 1)
        self.ctx.viewport = (0, 0, round(width * scale), self.wnd.buffer_size[1])  # the scene beside the panel
        if not self.diverged:  # a NaN state is not drawn: the message says what happened
            self.view.upload()
            self.view.draw(self.camera)
        self.ctx.viewport = (0, 0, *self.wnd.buffer_size)
        if self.recorder:  # the scene alone: the overlay and the panel come after
            self.recorder.add(read_pixels(self.wnd.fbo))
        if self.show_panel:
            self.ctx.finish()
        self.times.parts(stepped - start, time.perf_counter() - stepped)
        self.overlay.set_lines(self._overlay_lines())
        self.overlay.draw(self.wnd.buffer_size)
        if self.show_panel:
            self.draw_panel()
        self.frames += 1
        self.trace(f"frame {self.frames} {self.sim.time:.6f}")

    def trace(self, line: str) -> None:
        """One line to the UGPCL_VIEW_TRACE file, if there is one."""
        if self.trace_file:
            self.trace_file.write(line + "\n")

    def hud_lines(self) -> list[str]:
        """Frame rate, where a frame's time goes, the device, steps and simulated time."""
        t = self.times
        fps = 1.0 / t.frame if t.frame > 0 else 0.0
        other = max(t.frame - t.sim - t.draw, 0.0)
        lines = [
            f"{fps:5.1f} fps  {1e3 * t.frame:6.1f} ms/frame: sim {1e3 * t.sim:.1f}, draw {1e3 * t.draw:.1f}, "
            f"other {1e3 * other:.1f}",
            f"device: {self.runtime.label}",
            f"step {self.sim.steps}  sim time {self.sim.time:.2f} s",
        ]
        if self.sized:
            book = self.scene.params()
            sizes = ", ".join(
                f"{k}={show_value(v)} (book {show_value(getattr(book, k))})" for k, v in self.sized.items()
            )
            lines.append(f"sized for the CPU: {sizes}")
        return lines

    def draw_panel(self) -> None:
        """The ImGui window at the right: HUD, apply buttons, one widget per parameter, keys."""
        width, height = self.wnd.size
        imgui.get_io().delta_time = max(self.times.frame, 1e-3)
        imgui.new_frame()
        if self.close_popups:  # Esc while a dropdown was open: it closes, the window stays
            imgui.internal.close_popups_except_modals()
            self.close_popups = False
        panel_width = min(PANEL_WIDTH, width)
        imgui.set_next_window_pos((width - panel_width, 0), imgui.Cond_.always)
        imgui.set_next_window_size((panel_width, height), imgui.Cond_.always)
        imgui.set_next_window_bg_alpha(0.8)
        imgui.begin(self.view.title or self.scene.name, flags=imgui.WindowFlags_.no_move)
        for line in self.hud_lines():
            imgui.text_wrapped(line)
        if self.recorder:
            imgui.text_colored((1.0, 0.3, 0.3, 1.0), f"recording {self.recorder.path}: {self.recorder.frames} frames")
        imgui.separator()
        self._draw_apply_buttons()
        if imgui.collapsing_header("parameters", imgui.TreeNodeFlags_.default_open):
            longest = max(imgui.calc_text_size(w.name).x for w in self.panel.widgets)
            imgui.push_item_width(-longest - 2 * imgui.get_style().item_inner_spacing.x)  # every name whole
            for widget in self.panel.widgets:
                changed, value = draw_widget(imgui, widget, self.panel.value(widget.name))
                if self.trace_file:  # where the widget is, for the window tests' clicks
                    rect = (*map(int, imgui.get_item_rect_min()), *map(int, imgui.get_item_rect_max()))
                    if self.traced_widgets.get(widget.name) != rect:
                        self.traced_widgets[widget.name] = rect
                        self.trace(f"widget {widget.name} {' '.join(map(str, rect))}")
                if widget.name in self.panel.pending:
                    imgui.same_line()
                    imgui.text_colored((1.0, 0.8, 0.2, 1.0), "*")
                if changed:
                    self.set_param(widget, value)
            imgui.pop_item_width()
        if imgui.collapsing_header("keys"):
            for key, text in key_rows(self.scene):
                imgui.text_wrapped(f"{key:>6s}  {text}")
            imgui.text_wrapped(MOUSE_HELP)
        imgui.end()
        popup = imgui.is_popup_open("", imgui.PopupFlags_.any_popup_id | imgui.PopupFlags_.any_popup_level)
        if popup != self.popup_open:
            self.popup_open = popup
            self.trace(f"popup {'open' if popup else 'closed'}")
        typing = imgui.get_io().want_text_input  # keys go to a text field, not to the shortcuts
        if typing != self.typing:
            self.typing = typing
            self.trace(f"typing {'on' if typing else 'off'}")
        imgui.render()
        self.imgui.render(imgui.get_draw_data())

    def _draw_apply_buttons(self) -> None:
        pending = len(self.panel.pending)
        imgui.begin_disabled(not pending)
        if imgui.button(f"reset to apply ({pending})" if pending else "reset to apply"):
            self.apply_params()
        imgui.same_line()
        if imgui.button("revert"):
            self.panel.revert()
        imgui.end_disabled()
        imgui.same_line()
        if imgui.button("defaults"):
            self.panel.restore_defaults()
            self.watch, self.diverged = Watch(self.sim), None
        if self.panel.error:
            imgui.text_colored((1.0, 0.4, 0.4, 1.0), self.panel.error)

    def set_param(self, widget, value) -> None:
        """A widget changed: the panel validates it, applies it (live) or keeps it pending; stderr says which."""
        if self.panel.set(widget, value):
            how = "live" if widget.live else "pending: reset to apply"
            print(f"ugpcl-view: {widget.name} = {show_value(self.panel.value(widget.name))} ({how})", file=sys.stderr)

    def apply_params(self) -> None:
        changes = _assignments(self.panel.pending)
        if self.panel.apply():
            self.watch, self.diverged = Watch(self.sim), None
            print(f"ugpcl-view: reset with {changes}", file=sys.stderr)

    def check_divergence(self) -> None:
        """Pause with the message ``ugpcl run`` would print when the state has turned NaN/inf."""
        try:
            self.watch.check()
        except Diverged as err:
            defaults = self.scene.params().to_dict()
            changed = [f"{k}={v}" for k, v in self.sim.params.to_dict().items() if defaults.get(k) != v]
            self.diverged = [*str(err).split(": "), "parameters changed:", *(changed or ["none"])]
            self.paused = True
            print(f"ugpcl-view: {err}; parameters changed: {' '.join(changed) or 'none'}; paused", file=sys.stderr)
            self.trace("diverged")

    def _overlay_lines(self) -> list[str]:
        if self.diverged:  # short lines: the window may be small
            return ["DIVERGED: paused", "r resets, esc quits", *self.diverged]
        lines = self.view.status() + (["PAUSED (space: run, n: step)"] if self.paused else [])
        if self.recorder and not self.show_panel:
            lines.append(f"REC {self.recorder.frames} frames (F9/F10: stop)")
        return lines

    def on_resize(self, width: int, height: int) -> None:
        self.camera.aspect = self.scene_size()[0] / max(height, 1)
        self.imgui.resize(width, height)

    def scene_size(self) -> tuple[int, int]:
        """The part of the window the scene is drawn in (window pixels, from the left): all of it, or what the
        open panel leaves, so the scene is whole and centred beside the panel."""
        width, height = self.wnd.size
        if self.show_panel:
            width = max(width - min(PANEL_WIDTH, width), 1)
        return width, height

    # }}}

    # {{{ input

    def on_key_event(self, key, action, modifiers) -> None:
        io = imgui.get_io()
        keys = self.wnd.keys
        for mod, held, own in (
            (imgui.Key.mod_ctrl, modifiers.ctrl, "CTRL"),
            (imgui.Key.mod_shift, modifiers.shift, "SHIFT"),
        ):
            # ctrl+click types a slider's value; the modifier key's own event carries the state before it
            if key in (getattr(keys, f"LEFT_{own}", None), getattr(keys, f"RIGHT_{own}", None)):
                held = action == keys.ACTION_PRESS
            io.add_key_event(mod, bool(held))
        if self.show_panel and io.want_text_input:  # typing into a field: keys are text, not shortcuts
            self.imgui.key_event(key, action, modifiers)
        # otherwise ImGui never sees the keys: Tab would move its focus into a slider's text field, and the
        # scenes' own Tab, arrows and space are theirs
        elif action == self.wnd.keys.ACTION_PRESS:
            if self.key_names.get(key) == "esc" and self.show_panel and self.popup_open:
                self.close_popups = True  # Esc closes the open dropdown first, not the window
            else:
                self.press(self.key_names.get(key))
        if action == self.wnd.keys.ACTION_PRESS:
            self.trace(f"key {self.key_names.get(key)}")

    def on_unicode_char_entered(self, char: str) -> None:
        self.imgui.unicode_char_entered(char)

    def _panel_has_mouse(self) -> bool:
        return self.show_panel and imgui.get_io().want_capture_mouse

    def on_mouse_position_event(self, x: int, y: int, dx: int, dy: int) -> None:
        self.imgui.mouse_position_event(x, y, dx, dy)
        self.trace(f"move {x} {y}")

    def press(self, name: str | None) -> None:
        """Run the action bound to key ``name`` (shared keys first, then the view's)."""
        for binding in SHARED_KEYS:
            if binding.key == name:
                getattr(self, binding.action)()
                return
        for binding in self.view.keys:
            if binding.key == name:
                try:
                    getattr(self.view, binding.action)()
                except ValueError as err:  # a parameter pushed out of its range: say so, keep running
                    print(f"ugpcl-view: {err}", file=sys.stderr)
                return

    def on_mouse_press_event(self, x: int, y: int, button: int) -> None:
        self.trace(f"press {button} {x} {y}")
        self.imgui.mouse_press_event(x, y, button)
        self.in_panel = self._panel_has_mouse()  # a press on the panel is the panel's until released
        if self.in_panel:
            return
        self.right_click = button == 2  # until the mouse moves: a right drag orbits instead
        if button == 1:  # a click without a move already paints/emits/pushes in the 2D scenes
            w, h = self.scene_size()
            self.view.on_drag(self.camera, x / w, 1.0 - y / h, 0.0, 0.0)

    def on_mouse_drag_event(self, x: int, y: int, dx: int, dy: int) -> None:
        self.trace(f"drag {x} {y}")
        self.imgui.mouse_drag_event(x, y, dx, dy)
        if self.in_panel:
            return
        w, h = self.scene_size()
        self.right_click = False
        if self.wnd.mouse_states.left:
            self.view.on_drag(self.camera, x / w, 1.0 - y / h, dx / w, -dy / h)
        else:  # right (or middle) drag always orbits, so a scene whose left drag paints can still be turned
            self.camera.drag(dx / w * 600, -dy / h * 600)

    def on_mouse_release_event(self, x: int, y: int, button: int) -> None:
        self.trace(f"release {button} {x} {y}")
        self.imgui.mouse_release_event(x, y, button)
        if self.in_panel:
            self.in_panel = False
            return
        if button == 2 and self.right_click:
            w, h = self.scene_size()
            self.view.on_right_click(self.camera, x / w, 1.0 - y / h)
        self.view.on_release(self.camera)

    def on_mouse_scroll_event(self, x_offset: float, y_offset: float) -> None:
        self.imgui.mouse_scroll_event(x_offset, y_offset)
        if not self._panel_has_mouse():
            self.camera.zoom(y_offset)

    # }}}

    # {{{ shared key actions

    def toggle_pause(self) -> None:
        self.paused = not self.paused or self.diverged is not None

    def single_step(self) -> None:
        self.paused, self.step_once = True, self.diverged is None

    def reset(self) -> None:
        """R: the run starts again, with the panel's pending edits applied (as "reset to apply" does); edits the
        device cannot hold stay pending, the panel saying why."""
        if self.panel.pending:
            self.apply_params()
        self.sim.reset()
        self.watch, self.diverged = Watch(self.sim), None

    def screenshot(self) -> None:
        path = Path("out") / f"{self.scene.name}-{_stamp()}.png"
        with written_whole(path) as partial:  # a reader polling out/ never sees half a PNG
            save_png(read_pixels(self.wnd.fbo), partial)
        print(f"ugpcl-view: wrote {path}", file=sys.stderr)

    def toggle_panel(self) -> None:
        self.show_panel = not self.show_panel

    def toggle_video(self) -> None:
        self._toggle_recording(".mp4")

    def toggle_frames(self) -> None:
        self._toggle_recording("")

    def _toggle_recording(self, suffix: str) -> None:
        """Start recording to out/<scene>-<time><suffix>, or stop the recording under way (either key stops it)."""
        if self.recorder:
            self.stop_recording()
            return
        self.recorder = Recorder(Path("out") / f"{self.scene.name}-{_stamp()}{suffix}")
        print(f"ugpcl-view: recording to {self.recorder.path}", file=sys.stderr)

    def stop_recording(self) -> None:
        recorder, self.recorder = self.recorder, None
        frames = recorder.close()
        print(f"ugpcl-view: wrote {recorder.path} ({frames} frames)", file=sys.stderr)

    def on_close(self) -> None:
        if self.recorder:  # closing the window finishes the recording under way
            self.stop_recording()
        if self.trace_file:
            self.trace_file.close()
            self.trace_file = None

    def quit(self) -> None:
        self.wnd.close()

    # }}}


def window_flags(args) -> list[str]:
    """ugpcl-view's window options as moderngl-window's own flags."""
    flags = ["--fullscreen"] if args.fullscreen else []
    if args.vsync is not None:
        flags += ["--vsync", args.vsync]
    if args.samples is not None:
        if not 0 <= args.samples <= 16:
            raise UsageError(f"--samples must be in [0, 16], got {args.samples}")
        flags += ["--samples", str(args.samples)]
    if args.hidden:
        flags += ["--hidden", "true"]
    if args.backend:
        flags += ["--backend", args.backend]
    return flags


def main(argv: list[str] | None = None) -> int:
    parser = ArgumentParser(
        prog="ugpcl-view", description="Watch a scene in a window.", formatter_class=HelpFormatter, allow_abbrev=False
    )
    parser.add_argument("scene")
    parser.add_argument("--seed", type=int, default=0, help="random seed")
    parser.add_argument("--set", action="extend", nargs="+", metavar="NAME=VALUE", help="override parameters")
    parser.add_argument("--size", default="1280x720", help="window size WxH")
    parser.add_argument("--device", default=None, metavar="NAME", help="OpenCL device (as ugpcl run --device)")
    parser.add_argument("--keys", action="store_true", help="print the scene's key table (Markdown) and exit")
    parser.add_argument("-v", "--verbose", action="store_true", help="moderngl-window's INFO lines (GL context)")
    window = parser.add_argument_group("window (moderngl-window's own flags, passed on)")
    window.add_argument("--fullscreen", action="store_true", help="open fullscreen")
    window.add_argument("--vsync", choices=("true", "false"), default=None, help="wait for the display's refresh")
    window.add_argument("--samples", type=int, default=None, help="multisampling samples of the window")
    window.add_argument("--hidden", action="store_true", help="start the window hidden")
    window.add_argument("--backend", default=None, help="context backend (egl: headless)")
    args = parser.parse_args(argv)
    warnings.filterwarnings("ignore", category=ParameterReset)  # the window resets on purpose (the panel says so)
    warnings.filterwarnings("ignore", category=ParameterIgnored)  # keys set fields on purpose; the panel's tooltips
    # say when a field is ignored, and a --set one is said below
    try:
        scene = scene_named(args.scene)
        if args.keys:
            print(keys_markdown(scene))
            sys.stdout.flush()
            return 0
        sets = parse_sets(scene, args.set or [])
        width, height = parse_size(args.size, "--size")
        problem = _display_problem()
        if problem:
            raise NoDisplay(
                f"no display to open a window on ({problem}): run it in a desktop session or "
                f"under xvfb-run, or render pictures with `ugpcl run {scene.name} --png out.png`"
            )
        runtime = Runtime(args.device)  # OpenCL before the GL window: see ugpcl.runtime.all_devices
        sized = {} if runtime.is_gpu else {k: v for k, v in scene.interactive.items() if k not in sets}
        params = scene.params(**sized, **sets)
        resources.check(scene.simulation, params, runtime.device)  # ResourceError is a ValueError: exit 2
        for line in params.ignored(sets):  # a --set that changes nothing is said, and the window opens
            print(f"ugpcl-view: warning: {line}", file=sys.stderr)
        launch = {"scene": scene, "params": params, "seed": args.seed, "runtime": runtime, "sized": sized}
        ViewerWindow.launch = launch
        # moderngl-window parses its own flags from sys.argv unless given a (non-empty) list of them
        ViewerWindow.log_level = logging.INFO if args.verbose else logging.WARNING
        mglw.run_window_config(ViewerWindow, args=["--size", f"{width}x{height}", *window_flags(args)])
    except (UsageError, ValueError) as err:
        print(f"ugpcl-view: error: {err}", file=sys.stderr)
        return 2
    except BrokenPipeError:
        return quiet_broken_pipe()
    except (NoDisplay, DeviceError, BuildError) as err:
        print(f"ugpcl-view: {err}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        return 130
    return 0


def _display_problem() -> str:
    """Why no window can open here ('' when one can, or when this cannot be told): on Linux, no DISPLAY and no
    WAYLAND_DISPLAY, or an X display that does not answer (asked through Xlib, which pyglet would use)."""
    if not sys.platform.startswith("linux"):
        return ""
    display = os.environ.get("DISPLAY")
    if not display:
        return "" if os.environ.get("WAYLAND_DISPLAY") else "DISPLAY is not set"
    try:
        xlib = ctypes.CDLL("libX11.so.6")
    except OSError:
        return ""  # no Xlib to ask: let the window library try
    xlib.XOpenDisplay.restype = ctypes.c_void_p
    xlib.XCloseDisplay.argtypes = [ctypes.c_void_p]
    connection = xlib.XOpenDisplay(None)
    if not connection:
        return f"the X server of DISPLAY={display} does not answer"
    xlib.XCloseDisplay(connection)
    return ""


def _stamp() -> str:
    """Local time with milliseconds, for file names: two presses in one second keep both files."""
    now = time.time()
    return time.strftime("%Y%m%d-%H%M%S", time.localtime(now)) + f"-{int(now * 1000) % 1000:03d}"


def _assignments(values: dict) -> str:
    return " ".join(f"{k}={show_value(v)}" for k, v in values.items())


class NoDisplay(RuntimeError):
    """There is no screen to open a window on."""


if __name__ == "__main__":
    sys.exit(main())
