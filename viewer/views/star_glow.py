"""StarGlow view (vol.4 ch.4): the scene's HDR source post-processed by the book's passes as GL full-screen passes
(``GLStarGlow``, the twin of the OpenCL kernels), or the kernels' own output (tab), or a debug image (b, v)."""

from __future__ import annotations

from functools import partialmethod

import moderngl
import numpy as np

from ugpcl.scenes.star_glow import COMPOSITE_TYPES, TAPS, streak_directions, tap_weights

from ..postfx import BLEND_SCREEN, FloatTarget, FullscreenPass, PingPong, float_texture
from . import Key
from . import View as BaseView

DISPLAYS = ("glow", "source", "bright", "comp", "opencl")
"""What the view shows: the GL passes' result, the source alone (g), the brightness image (b), the screen-blended
streaks (v), the OpenCL kernels' dst (tab)."""
TINTS = ((1.0, 1.0, 1.0, 1.0), (1.0, 0.6, 0.2, 1.0), (0.3, 0.6, 1.0, 1.0), (1.0, 0.3, 0.7, 1.0))
"""Colours c cycles through (the colored_* composite types)."""


class GLStarGlow:
    """The book's StarGlow passes 1-4 on GL float targets (RGBA32F, linear, clamped to edge, as ``image.h`` samples
    the kernels' buffers); ``bright`` and ``comp`` hold passes 1 and 3 after a run."""

    def __init__(self, ctx: moderngl.Context):
        self.ctx = ctx
        self.brightness = FullscreenPass(ctx, "star_glow_brightness")
        self.streak = FullscreenPass(ctx, "star_glow_streak")
        self.copy = FullscreenPass(ctx, "star_glow_copy")
        self.composite = FullscreenPass(ctx, "star_glow_composite")
        self.size = None

    def _targets(self, size: tuple[int, int]) -> None:
        if self.size == size:
            return
        if self.size is not None:
            self._release_targets()
        self.size = size
        self.bright = FloatTarget(self.ctx, size)  # the book's brightnessTex
        self.blur = PingPong(self.ctx, size)  # blurredTex1, blurredTex2
        self.comp = FloatTarget(self.ctx, size)  # compositeTex

    def run(self, source: moderngl.Texture, params, out: FloatTarget | None = None) -> None:
        """Passes 1-4: the glow of ``source`` composited onto it, into ``out`` (None: the bound framebuffer)."""
        self.streaks(source, params)
        uniforms = {"composite_type": COMPOSITE_TYPES.index(params.composite_type), "color": params.color}
        self.composite.run(out, {"source": source, "composite": self.comp}, uniforms)

    def streaks(self, source: moderngl.Texture, params) -> None:
        """Passes 1-3: ``bright``, then every direction's streak screen-blended into ``comp`` (cleared first)."""
        W, H = source.size
        w, h = W // params.divide, H // params.divide
        self._targets((w, h))
        self.brightness.run(
            self.bright, {"source": source}, {"threshold": params.threshold, "intensity": params.intensity}
        )
        self.comp.clear()
        for direction in streak_directions(params.num_of_streak, params.angle_of_streak):
            source_of_pass = self.bright
            for i in range(1, params.iteration + 1):
                power = float(TAPS ** (i - 1))
                uniforms = {
                    "step_uv": direction * power / np.array([w, h]),
                    "weights": tap_weights(params.attenuation, power),
                }
                self.streak.run(self.blur.write, {"source": source_of_pass}, uniforms)
                self.blur.swap()
                source_of_pass = self.blur.read
            self.copy.run(self.comp, {"source": self.blur.read}, blend=BLEND_SCREEN)  # pass 3

    def _release_targets(self) -> None:
        for target in (self.bright, self.blur, self.comp):
            target.release()

    def release(self) -> None:
        if self.size is not None:
            self._release_targets()
        for step in (self.brightness, self.streak, self.copy, self.composite):
            step.release()


class View(BaseView):
    title = "StarGlow (vol.4 ch.4)"
    background = (0.0, 0.0, 0.0)  # the sample camera clears to solid black
    keys = (
        Key("g", "effect on/off (source alone)", "toggle_effect"),
        Key("m", "composite type: additive / screen / colored additive / colored screen / debug", "next_mode"),
        *(Key(str(n), f"num_of_streak = {n}", f"streaks_{n}") for n in range(1, 10)),
        Key(".", "num_of_streak + 1 (up to 16)", "more_streaks"),
        Key(",", "num_of_streak - 1", "fewer_streaks"),
        Key("w", "angle_of_streak + 5", "turn_left"),
        Key("q", "angle_of_streak - 5", "turn_right"),
        Key("a", "attenuation + 0.02", "longer"),
        Key("z", "attenuation - 0.02", "shorter"),
        Key("y", "threshold + 0.05", "raise_threshold"),
        Key("t", "threshold - 0.05", "lower_threshold"),
        Key("i", "intensity + 0.1", "brighter"),
        Key("k", "intensity - 0.1", "dimmer"),
        Key("]", "iteration + 1 (streaks 4x longer)", "more_passes"),
        Key("[", "iteration - 1", "fewer_passes"),
        Key("+", "divide + 1 (smaller glow images)", "coarser"),
        Key("-", "divide - 1", "finer"),
        Key("c", "tint colour of the colored types", "next_tint"),
        Key("b", "show the brightness image (pass 1)", "show_bright"),
        Key("v", "show the screen-blended streaks (comp)", "show_comp"),
        Key("tab", "GL passes / OpenCL kernels' output", "toggle_opencl"),
        Key("f", "kernel variant: book / fused", "toggle_variant"),
    )

    def __init__(self, ctx: moderngl.Context, sim):
        super().__init__(ctx, sim)
        self.glow = GLStarGlow(ctx)
        self.copy = self.glow.copy
        self.display = "glow"
        self.source = self.dst = None

    def _texture(self, texture, array: np.ndarray):
        if texture is None or texture.size != (array.shape[1], array.shape[0]):
            if texture is not None:
                texture.release()
            return float_texture(self.ctx, array)
        texture.write(np.ascontiguousarray(array, np.float32).tobytes())
        return texture

    def upload(self) -> None:
        self.source = self._texture(self.source, self.sim.src.get())
        if self.display == "opencl":
            self.dst = self._texture(self.dst, self.sim.dst.get())

    def _letterbox(self) -> None:
        """Keep the source's aspect inside the current viewport (black bars)."""
        x, y, vw, vh = self.ctx.viewport
        W, H = self.source.size
        scale = min(vw / W, vh / H)
        w, h = round(W * scale), round(H * scale)
        self.ctx.viewport = (x + (vw - w) // 2, y + (vh - h) // 2, w, h)

    def draw(self, camera) -> None:
        viewport = self.ctx.viewport
        shown = {"source": self.source, "opencl": self.dst}.get(self.display)
        if self.display in ("bright", "comp"):
            self.glow.streaks(self.source, self.sim.params)
            shown = getattr(self.glow, self.display)
        self._letterbox()
        if self.display == "glow":
            self.glow.run(self.source, self.sim.params)
        else:
            self.copy.run(None, {"source": shown})  # the book's pass 0: a plain copy
        self.ctx.viewport = viewport

    def status(self) -> list[str]:
        p, s = self.sim.params, self.sim
        return [
            f"{s.W}x{s.H} -> glow {s.w}x{s.h}  {p.composite_type}  display {self.display}  kernels {p.variant}",
            f"threshold {p.threshold:.2f}  intensity {p.intensity:.1f}  attenuation {p.attenuation:.2f}  "
            f"streaks {p.num_of_streak} at {p.angle_of_streak:g} deg  iteration {p.iteration}  divide {p.divide}",
        ]

    # {{{ key actions

    def _set(self, **changes) -> None:
        self.sim.update(**changes)

    def _step(self, name: str, delta: float, lo: float, hi: float) -> None:
        value = getattr(self.sim.params, name) + delta
        self._set(**{name: type(delta)(min(hi, max(lo, round(value, 6))))})

    def _show(self, display: str) -> None:
        self.display = "glow" if self.display == display else display

    toggle_effect = partialmethod(_show, "source")
    show_bright = partialmethod(_show, "bright")
    show_comp = partialmethod(_show, "comp")
    toggle_opencl = partialmethod(_show, "opencl")
    more_streaks = partialmethod(_step, "num_of_streak", 1, 1, 16)
    fewer_streaks = partialmethod(_step, "num_of_streak", -1, 1, 16)

    def _turn(self, degrees: float) -> None:
        self._set(angle_of_streak=(self.sim.params.angle_of_streak + degrees) % 360.0)

    turn_left = partialmethod(_turn, 5.0)
    turn_right = partialmethod(_turn, -5.0)
    longer = partialmethod(_step, "attenuation", 0.02, 0.0, 1.0)
    shorter = partialmethod(_step, "attenuation", -0.02, 0.0, 1.0)
    raise_threshold = partialmethod(_step, "threshold", 0.05, 0.0, 1e4)
    lower_threshold = partialmethod(_step, "threshold", -0.05, 0.0, 1e4)
    brighter = partialmethod(_step, "intensity", 0.1, 0.0, 1e4)
    dimmer = partialmethod(_step, "intensity", -0.1, 0.0, 1e4)
    more_passes = partialmethod(_step, "iteration", 1, 1, 8)
    fewer_passes = partialmethod(_step, "iteration", -1, 1, 8)

    def coarser(self) -> None:
        p, s = self.sim.params, self.sim
        if min(s.W, s.H) // (p.divide + 1) >= 1:
            self._set(divide=min(64, p.divide + 1))

    def finer(self) -> None:
        self._set(divide=max(1, self.sim.params.divide - 1))

    def next_mode(self) -> None:
        p = self.sim.params
        self._set(composite_type=COMPOSITE_TYPES[(COMPOSITE_TYPES.index(p.composite_type) + 1) % len(COMPOSITE_TYPES)])

    def next_tint(self) -> None:
        color = self.sim.params.color
        self._set(color=TINTS[(TINTS.index(color) + 1) % len(TINTS)] if color in TINTS else TINTS[0])

    def toggle_variant(self) -> None:
        self._set(variant="fused" if self.sim.params.variant == "book" else "book")

    # }}}


for _n in range(1, 10):
    setattr(View, f"streaks_{_n}", partialmethod(View._set, num_of_streak=_n))
