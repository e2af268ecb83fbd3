"""Kleinian limit set view (vol.4 ch.2): the book's KleinianGroup.shader as one full-screen pass
(viewer/shaders/kleinian.frag, whose core is clkernels/include/kleinian.h, the kernels' own), and the overlay of
Figure 2.3 (Line1, Line2, Line3, the parallelogram, the largest disk). Left drag pans, the wheel zooms about the
centre, right drag moves the inversion circle of mode 2.

The view draws what ``Simulation.frame()`` says (t, scale, offset, circle of the current time); it never runs the
kernels. Pan, zoom and the t keys stop the animation that would otherwise override them.
"""

from __future__ import annotations

from dataclasses import dataclass

import moderngl

from ugpcl.runtime import INCLUDE_DIR

from ..postfx import BLEND_ALPHA, FullscreenPass
from . import Key
from . import View as BaseView

ZOOM_STEP = 0.9
"""Scale factor per wheel notch (and per + / - press)."""
PAN_STEP = 0.1
"""Arrow keys pan by this fraction of the screen height."""
U_STEP, V_STEP = 0.005, 0.001
"""Steps of the u and v keys."""
MAX_ITERATION = 5000
OVERLAY_LINE_WIDTH = 2.0
"""Pixels."""


def serve_core(ctx: moderngl.Context) -> None:
    """Let ``#include "kleinian.h"`` find the kernels' header: the shader and the kernels run the same text."""
    ctx.includes["kleinian.h"] = (INCLUDE_DIR / "kleinian.h").read_text()


@dataclass
class PlaneCamera:
    """The window's 'camera' for a flat, per-pixel picture: the wheel and the right drag act on the view's
    parameters (zoom about the centre, the inversion circle)."""

    view: View
    aspect: float = 16 / 9

    def drag(self, dx: float, dy: float) -> None:
        self.view.move_circle(dx / 600.0, dy / 600.0)  # the app passes window fractions * 600

    def zoom(self, steps: float) -> None:
        self.view.zoom(ZOOM_STEP**steps)


class View(BaseView):
    title = "Kleinian limit set (vol.4 ch.2)"
    background = (1.0, 1.0, 1.0)
    max_frame_dt = 1.0 / 30.0
    keys = (
        Key("0", "mode 0: the plain pass (frag)", "mode_0"),
        Key("1", "mode 1: multisampled (frag_multisample)", "mode_1"),
        Key("2", "mode 2: extra circle inversion (frag_circle_inverse)", "mode_2"),
        Key("u", "u + 0.005 (stops the t animation)", "more_u"),
        Key("j", "u - 0.005", "less_u"),
        Key("v", "v + 0.001 (stops the t animation)", "more_v"),
        Key("b", "v - 0.001", "less_v"),
        Key("i", "iteration x 2", "more_iterations"),
        Key("k", "iteration / 2", "fewer_iterations"),
        Key("+", "zoom in", "zoom_in"),
        Key("-", "zoom out", "zoom_out"),
        Key("up", "pan up", "pan_up"),
        Key("down", "pan down", "pan_down"),
        Key("left", "pan left", "pan_left"),
        Key("right", "pan right", "pan_right"),
        Key("]", "circle_w x 1.25 (mode 2)", "bigger_circle"),
        Key("[", "circle_w / 1.25", "smaller_circle"),
        Key("a", "t animation (useUVAnimation) on/off", "toggle_uv_animation"),
        Key("t", "Animator clip (scale, offset, circle) on/off", "toggle_animator"),
        Key("o", "overlay: Line1, Line2, Line3, parallelogram, largest disk (Figure 2.3)", "toggle_overlay"),
        Key("x", "jitter hash: portable / sin (the book's)", "toggle_hash"),
    )

    def __init__(self, ctx: moderngl.Context, sim):
        super().__init__(ctx, sim)
        serve_core(ctx)
        self.limit_set = FullscreenPass(ctx, "kleinian")
        self.overlay = FullscreenPass(ctx, "kleinian_overlay")

    def make_camera(self):
        return PlaneCamera(self)

    def uniforms(self, size: tuple[int, int]) -> dict:
        """kleinian.frag's uniforms for a viewport of ``size``: the frame's values and the parameters."""
        p, f = self.sim.params, self.sim.frame()
        return {
            "resolution": tuple(size),
            "t": f["t"],
            "scale": f["scale"],
            "offset": f["offset"],
            "circle": f["circle"],
            "iteration": p.iteration,
            "mode": p.mode,
            "samples": p.effective_samples,
            "jitter": p.jitter,
            "hash": int(p.hash == "sin"),
            "hit_color": p.hit_color,
            "back_color": p.back_color,
            "line_width": OVERLAY_LINE_WIDTH,
        }

    def draw(self, camera, target=None) -> None:
        """The limit set, then the overlay, into ``target`` (None: the bound framebuffer and its viewport)."""
        size = target.size if target is not None else tuple(self.ctx.viewport[2:])
        uniforms = self.uniforms(size)
        self.limit_set.run(target, uniforms=uniforms)
        if self.sim.params.overlay:
            self.overlay.run(target, uniforms=uniforms, blend=BLEND_ALPHA)

    def status(self) -> list[str]:
        p, f = self.sim.params, self.sim.frame()
        (u, v), (ox, oy) = f["t"], f["offset"]
        return [
            f"mode {p.mode}  t = ({u:.6f}, {v:.6f})  iteration {p.iteration}  samples {p.effective_samples}",
            f"scale {f['scale']:.4g}  offset ({ox:.4g}, {oy:.4g})  time {f['time']:.2f} s"
            + ("  [t animated]" if p.use_uv_animation else "")
            + ("  [Animator]" if p.animator else ""),
        ]

    # {{{ mouse

    def _hold_view(self) -> dict:
        """Scale, offset and circle of the current frame as fields, the Animator off (the user takes over)."""
        f = self.sim.frame()
        (cx, cy, _, cw) = f["circle"]
        return {"scale": f["scale"], "offset": f["offset"], "circle": (cx, cy), "circle_w": cw, "animator": False}

    def on_drag(self, camera, u: float, v: float, du: float, dv: float) -> None:
        """Left drag: the picture follows the mouse."""
        self.pan(-du, -dv)

    def pan(self, du: float, dv: float) -> None:
        """Move the view by (du, dv) window fractions: in screen heights before scaling in modes 0/1 (book: pos +=
        _Offset; pos *= _Scale), in world units after it in mode 2."""
        held = self._hold_view()
        aspect = self._aspect()
        dx, dy = du * aspect, dv
        if self.sim.params.mode == 2:
            dx, dy = dx * held["scale"], dy * held["scale"]
        ox, oy = held["offset"]
        self.sim.update(**{**held, "offset": (ox + dx, oy + dy)})

    def zoom(self, factor: float) -> None:
        """Scale by ``factor`` keeping the world point at the centre of the screen where it is."""
        held = self._hold_view()
        s, (ox, oy) = held["scale"], held["offset"]
        new = min(max(s * factor, 1e-12), 1e4)
        cx, cy = self._aspect() / 2, 0.5
        if self.sim.params.mode == 2:  # world = c * s + offset
            offset = (ox + cx * (s - new), oy + cy * (s - new))
        else:  # world = (c + offset) * s
            offset = ((cx + ox) * s / new - cx, (cy + oy) * s / new - cy)
        self.sim.update(**{**held, "scale": new, "offset": offset})

    def move_circle(self, du: float, dv: float) -> None:
        """Right drag: the inversion circle's centre follows the mouse (world units)."""
        held = self._hold_view()
        cx, cy = held["circle"]
        s = held["scale"]
        self.sim.update(**{**held, "circle": (cx + du * self._aspect() * s, cy + dv * s)})

    def _aspect(self) -> float:
        w, h = self.ctx.viewport[2:]
        return w / max(h, 1)

    # }}}

    # {{{ key actions

    def mode_0(self) -> None:
        self.sim.update(mode=0)

    def mode_1(self) -> None:
        self.sim.update(mode=1)

    def mode_2(self) -> None:
        self.sim.update(mode=2)

    def _shift_t(self, du: float, dv: float) -> None:
        u, v = self.sim.frame()["t"]
        self.sim.update(u=min(max(u + du, 0.1), 4.0), v=min(max(v + dv, -2.0), 2.0), use_uv_animation=False)

    def more_u(self) -> None:
        self._shift_t(U_STEP, 0.0)

    def less_u(self) -> None:
        self._shift_t(-U_STEP, 0.0)

    def more_v(self) -> None:
        self._shift_t(0.0, V_STEP)

    def less_v(self) -> None:
        self._shift_t(0.0, -V_STEP)

    def more_iterations(self) -> None:
        self.sim.update(iteration=min(self.sim.params.iteration * 2, MAX_ITERATION))

    def fewer_iterations(self) -> None:
        self.sim.update(iteration=max(self.sim.params.iteration // 2, 1))

    def zoom_in(self) -> None:
        self.zoom(ZOOM_STEP)

    def zoom_out(self) -> None:
        self.zoom(1.0 / ZOOM_STEP)

    def pan_up(self) -> None:
        self.pan(0.0, PAN_STEP)

    def pan_down(self) -> None:
        self.pan(0.0, -PAN_STEP)

    def pan_left(self) -> None:
        self.pan(-PAN_STEP, 0.0)

    def pan_right(self) -> None:
        self.pan(PAN_STEP, 0.0)

    def bigger_circle(self) -> None:
        held = self._hold_view()
        self.sim.update(**{**held, "circle_w": min(held["circle_w"] * 1.25, 1e4)})

    def smaller_circle(self) -> None:
        held = self._hold_view()
        self.sim.update(**{**held, "circle_w": max(held["circle_w"] / 1.25, 1e-6)})

    def toggle_uv_animation(self) -> None:
        self.sim.update(use_uv_animation=not self.sim.params.use_uv_animation)

    def toggle_animator(self) -> None:
        if self.sim.params.animator:
            self.sim.update(**self._hold_view())
        else:
            self.sim.update(animator=True)

    def toggle_overlay(self) -> None:
        self.sim.update(overlay=not self.sim.params.overlay)

    def toggle_hash(self) -> None:
        self.sim.update(hash="sin" if self.sim.params.hash == "portable" else "portable")

    # }}}
