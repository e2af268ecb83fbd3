"""``ugpcl-view SCENE``: the interactive window (moderngl-window) with the keys every scene shares.

Shared keys live in SHARED_KEYS; a scene's own keys in its View's ``keys`` table. The help overlay (H) and
``ugpcl-view --keys SCENE`` (the README tables) are both generated from those two tables.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import moderngl
import moderngl_window as mglw

from ugpcl import resources
from ugpcl.cli import Diverged, HelpFormatter, UsageError, Watch, parse_sets, parse_size, quiet_broken_pipe, scene_named
from ugpcl.runtime import BuildError, DeviceError, Runtime

from .gl import TextOverlay, read_pixels, save_png
from .views import Key, View, create_view, view_class

SHARED_KEYS = (
    Key("space", "pause / run", "toggle_pause"),
    Key("n", "single step (while paused)", "single_step"),
    Key("r", "reset (re-seed)", "reset"),
    Key("s", "screenshot to out/<scene>-<time>.png", "screenshot"),
    Key("h", "help overlay on/off", "toggle_help"),
    Key("esc", "quit", "quit"),
)
MOUSE_HELP = "mouse: left drag = orbit (3D) or the scene's brush (2D), right drag = orbit, wheel = zoom"


def key_rows(scene) -> list[tuple[str, str]]:
    """(key, help) for the shared keys and the scene's own, in overlay order."""
    return [(k.key, k.help) for k in SHARED_KEYS] + [(k.key, k.help) for k in view_class(scene).keys]


def keys_markdown(scene) -> str:
    lines = ["| key | action |", "|---|---|"]
    for key, text in key_rows(scene):
        text = text.replace("|", r"\|")  # a literal | would end the table cell
        lines.append(f"| `{key}` | {text} |")
    return "\n".join(lines)


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
        self.view: View = create_view(self.scene, self.ctx, self.sim)
        self.camera = self.view.make_camera()
        self.camera.aspect = self.wnd.aspect_ratio
        self.paused, self.step_once, self.show_help = False, False, False
        self.right_click = False  # the right button is down and has not moved
        self.watch, self.diverged = Watch(self.sim), None  # diverged: the message while the state holds NaN/inf
        self.overlay = TextOverlay(self.ctx)
        self.wnd.title = f"ugpcl - {self.view.title or self.scene.name}  (H: help)"
        self.key_names = self._key_names()
        print(f"ugpcl-view: {self.scene.name} on {self.runtime.label}; H shows the keys", file=sys.stderr)

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
        names.update({getattr(keys, c.upper()): c for c in "abcdefghijklmnopqrstuvwxyz"})
        # pyglet's own codes where moderngl-window's constants differ ([ and ] are ASCII there, + and keypad +/-)
        names.update({ord("["): "[", ord("]"): "]", ord("+"): "+"})
        for attr, name in (("NUMPAD_ADD", "+"), ("NUMPAD_SUBTRACT", "-"), ("NUM_ADD", "+"), ("NUM_SUBTRACT", "-")):
            if hasattr(keys, attr):
                names[getattr(keys, attr)] = name
        return names

    # {{{ frame

    def on_render(self, time_: float, frame_time: float) -> None:
        if not self.paused or self.step_once:
            dt = self.sim.default_dt
            if self.view.max_frame_dt is not None and frame_time > 0:
                dt = min(frame_time, self.view.max_frame_dt)
            for _ in range(self.view.steps_per_frame):
                self.sim.step(dt)
            self.step_once = False
            if self.watch.due() or self.paused:
                self.check_divergence()
        self.ctx.enable(moderngl.DEPTH_TEST)
        self.ctx.clear(*self.view.background, 1.0, depth=1.0)
        if not self.diverged:  # a NaN state is not drawn: the message says what happened
            self.view.upload()
            self.view.draw(self.camera)
        self.overlay.set_lines(self._overlay_lines())
        self.overlay.draw(self.wnd.buffer_size)

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

    def _overlay_lines(self) -> list[str]:
        if self.diverged:  # short lines: the window may be small
            return ["DIVERGED: paused", "r resets, esc quits", *self.diverged]
        lines = self.view.status() + (["PAUSED (space: run, n: step)"] if self.paused else [])
        if self.show_help:
            lines += ["", f"{self.view.title or self.scene.name}: keys"]
            lines += [f"  {key:>6s}  {text}" for key, text in key_rows(self.scene)]
            lines += ["  " + MOUSE_HELP]
        return lines

    def on_resize(self, width: int, height: int) -> None:
        self.camera.aspect = width / max(height, 1)

    # }}}

    # {{{ input

    def on_key_event(self, key, action, modifiers) -> None:
        if action != self.wnd.keys.ACTION_PRESS:
            return
        self.press(self.key_names.get(key))

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
        self.right_click = button == 2  # until the mouse moves: a right drag orbits instead
        if button == 1:  # a click without a move already paints/emits/pushes in the 2D scenes
            w, h = self.wnd.size
            self.view.on_drag(self.camera, x / w, 1.0 - y / h, 0.0, 0.0)

    def on_mouse_drag_event(self, x: int, y: int, dx: int, dy: int) -> None:
        w, h = self.wnd.size
        self.right_click = False
        if self.wnd.mouse_states.left:
            self.view.on_drag(self.camera, x / w, 1.0 - y / h, dx / w, -dy / h)
        else:  # right (or middle) drag always orbits, so a scene whose left drag paints can still be turned
            self.camera.drag(dx / w * 600, -dy / h * 600)

    def on_mouse_release_event(self, x: int, y: int, button: int) -> None:
        if button == 2 and self.right_click:
            w, h = self.wnd.size
            self.view.on_right_click(self.camera, x / w, 1.0 - y / h)
        self.view.on_release(self.camera)

    def on_mouse_scroll_event(self, x_offset: float, y_offset: float) -> None:
        self.camera.zoom(y_offset)

    # }}}

    # {{{ shared key actions

    def toggle_pause(self) -> None:
        self.paused = not self.paused or self.diverged is not None

    def single_step(self) -> None:
        self.paused, self.step_once = True, self.diverged is None

    def reset(self) -> None:
        self.sim.reset()
        self.watch, self.diverged = Watch(self.sim), None

    def screenshot(self) -> None:
        now = time.time()  # milliseconds in the name: two presses in one second keep both pictures
        stamp = time.strftime("%Y%m%d-%H%M%S", time.localtime(now)) + f"-{int(now * 1000) % 1000:03d}"
        path = Path("out") / f"{self.scene.name}-{stamp}.png"
        save_png(read_pixels(self.wnd.fbo), path)
        print(f"ugpcl-view: wrote {path}", file=sys.stderr)

    def toggle_help(self) -> None:
        self.show_help = not self.show_help

    def quit(self) -> None:
        self.wnd.close()

    # }}}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="ugpcl-view", description="Watch a scene in a window.", formatter_class=HelpFormatter, allow_abbrev=False
    )
    parser.add_argument("scene")
    parser.add_argument("--seed", type=int, default=0, help="random seed")
    parser.add_argument("--set", action="extend", nargs="+", metavar="NAME=VALUE", help="override parameters")
    parser.add_argument("--size", default="1280x720", help="window size WxH")
    parser.add_argument("--device", default=None, metavar="NAME", help="OpenCL device (as ugpcl run --device)")
    parser.add_argument("--keys", action="store_true", help="print the scene's key table (Markdown) and exit")
    args = parser.parse_args(argv)
    try:
        scene = scene_named(args.scene)
        if args.keys:
            print(keys_markdown(scene))
            sys.stdout.flush()
            return 0
        params = scene.params(**parse_sets(scene, args.set or []))
        width, height = parse_size(args.size, "--size")
        if sys.platform.startswith("linux") and not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
            raise NoDisplay(
                "no display to open a window on (DISPLAY is not set): run it in a desktop session or "
                f"under xvfb-run, or render pictures with `ugpcl run {scene.name} --png out.png`"
            )
        runtime = Runtime(args.device)  # OpenCL before the GL window: see ugpcl.runtime.all_devices
        resources.check(scene.simulation, params, runtime.device)  # ResourceError is a ValueError: exit 2
        ViewerWindow.launch = {"scene": scene, "params": params, "seed": args.seed, "runtime": runtime}
        # moderngl-window parses its own flags from sys.argv unless given a (non-empty) list of them
        mglw.run_window_config(ViewerWindow, args=["--size", f"{width}x{height}"])
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


class NoDisplay(RuntimeError):
    """There is no screen to open a window on."""


if __name__ == "__main__":
    sys.exit(main())
