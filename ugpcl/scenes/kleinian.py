"""Limit sets of Kleinian groups: Jos Leys' escape-time algorithm per pixel, the band of tangent circles and its
extra circle inversion (vol.4 ch.2; docs/chapters/13-kleinian.md).

The book's KleinianGroup.shader is a full-screen fragment shader with three passes: ``mode`` 0 (frag), 1
(frag_multisample: 20 jittered samples) and 2 (frag_circle_inverse: 10 samples of the screen point inverted in a
circle that the KleinianGroupCircleInverse scene animates with an Animator clip). Its core is written once in
clkernels/include/kleinian.h, included by the kernels of clkernels/kleinian.cl (headless frames, point queries) and
by viewer/shaders/kleinian.frag (the window and PNGs).

Per frame (the book's KleinianGroup.Update + OnRenderImage): t = (u, v) from its curves while
``use_uv_animation`` (script time = time * time_scale), scale / offset / circle from the Animator clip while
``animator`` (clip time = time), then ``RenderKleinian`` (after ``PixelCentreHits`` with ``adaptive``). A step only
advances time; ``state()`` renders the frame at the current time. No state carries between frames.

Differences from the book: the jitter hash is a portable integer hash by default (``hash=sin`` is the original);
``samples=0`` means the book's count per pass; ``adaptive`` (ours) supersamples only pixels whose 3x3 neighbourhood
of centre samples is not uniform; ``precision=double`` builds the kernels in double (cl_khr_fp64) for deep zooms.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pyopencl.cltypes as cltypes

from ..resources import Allocation
from ..scene import Animation, AtScale, PreviewCheck, Scene, param
from ..scene import Params as BaseParams
from ..scene import Simulation as BaseSimulation

BOOK_SAMPLES = {0: 1, 1: 20, 2: 10}
"""Samples per pixel of each pass (KleinianGroup.shader: frag, frag_multisample, frag_circle_inverse)."""
HIT_COLOR = (0.0746262, 0.23055694, 0.3679245, 1.0)
"""hitColor of both of the book's scenes."""
BACK_COLOR_KLEINIAN = (1.0, 1.0, 1.0, 1.0)
"""backColor of the KleinianGroup scene."""
BACK_COLOR_INVERSE = (1.0, 0.97255427, 0.874, 1.0)
"""backColor of the KleinianGroupCircleInverse scene."""
LOCAL_SIZE = 16
"""Work-group edge of the 2-D pixel launches (halved where the device cannot run 16 x 16)."""

# {{{ the book's animation curves (KleinianGroup.cs, KleinianGroupCircleInverse.anim)

U_CURVE = ((0.0016, 1.9879456), (1.0, 1.939613))
"""animKleinU keys (time s, value): flat tangents, pre-wrap loop, post-wrap clamp."""
V_CURVE = ((0.0, 0.005859375), (1.0, 0.02))
"""animKleinV keys, the same shape."""
CLIP_LENGTH = 33.133335
"""Length of the looping Animator clip of KleinianGroupCircleInverse, s."""
CLIP_TIMES = (0.0, 5.0, 9.0, 13.0, 17.066668, 21.0, 25.0, 29.0, 33.133335)
CLIP = {
    "scale": (1.9, 1.9, 2.0, 2.0, 2.0, 2.0, 2.0, 2.0, 1.9),
    "circle_x": (0.0, 0.0, 0.0, 2.0, 0.0, 3.0, 3.0, 0.0, 0.0),
    "circle_y": (0.0, 0.0, 1.0, 1.0, 2.5, 2.5, 2.0, 2.0, 0.0),
    "offset_x": (0.0, 0.0, -2.5, -1.0, -2.5, 0.5, 0.5, 0.0, 0.0),
    "offset_y": (0.0, 0.0, 1.0, 1.0, 0.5, 0.5, 0.5, 0.0, 0.0),
}
"""Keys of the Animator clip at CLIP_TIMES (all tangents zero; circle.z = 0 and circle.w = 1 throughout)."""


def flat_curve(times, values, time: float, pre_loop: bool = False) -> float:
    """A Unity AnimationCurve whose keys all have zero tangents: the cubic Hermite between two keys is
    a + (b - a)(3s^2 - 2s^3). Clamped after the last key; before the first one it clamps too, or with ``pre_loop``
    wraps into the keyed range (WrapMode.Loop)."""
    first, last = times[0], times[-1]
    if pre_loop and time < first and last > first:
        time = first + (time - first) % (last - first)
    if time <= first:
        return float(values[0])
    if time >= last:
        return float(values[-1])
    k = int(np.searchsorted(times, time, side="right")) - 1
    s = (time - times[k]) / (times[k + 1] - times[k])
    return float(values[k] + (values[k + 1] - values[k]) * (3 * s * s - 2 * s * s * s))


def uv_at(time: float) -> tuple[float, float]:
    """t = (u, v) of the book's curves at script time ``time`` (KleinianGroup.cs with useUVAnimation)."""
    (tu, u), (tv, v) = zip(*U_CURVE, strict=True), zip(*V_CURVE, strict=True)
    return flat_curve(tu, u, time, pre_loop=True), flat_curve(tv, v, time, pre_loop=True)


def clip_at(time: float) -> dict[str, float]:
    """scale, circle_x, circle_y, offset_x, offset_y of the looping Animator clip at ``time``."""
    local = time % CLIP_LENGTH
    return {name: flat_curve(CLIP_TIMES, keys, local) for name, keys in CLIP.items()}


# }}}


@dataclass(frozen=True)
class Params(BaseParams):
    width: int = param(640, 16, 8192)
    """Width of the headless frame, pixels (the window uses its own size)."""
    height: int = param(360, 16, 8192)
    """Height of the headless frame, pixels."""
    u: float = param(2.0, 0.1, 4.0, live=True, ignored_when={"use_uv_animation": True})
    """Real part of t = u + iv (book: kleinUV.x): the height of the band 0 <= y <= u. The Line3 fit is made for u
    near 1.94-2 (book 2.6: (2, 0) the most standard, about (1.94, 0.02) the interesting shapes)."""
    v: float = param(0.0, -2.0, 2.0, live=True, ignored_when={"use_uv_animation": True})
    """Imaginary part of t (book: kleinUV.y): shears the parallelogram."""
    use_uv_animation: bool = param(False, live=True)
    """Drive t by the book's curves animKleinU / animKleinV (book: useUVAnimation) instead of u and v."""
    time_scale: float = param(1.0, 0.0, 100.0, live=True, used_only_when={"use_uv_animation": True})
    """Multiplier of the script time that the t curves read (book: timeScale)."""
    animator: bool = param(False, live=True)
    """Drive scale, offset and the inversion circle by the KleinianGroupCircleInverse Animator clip (looping,
    CLIP_LENGTH s, unscaled time) instead of the fields."""
    start_time: float = param(0.0, 0.0, 1e6, live=True)
    """Time of the first frame, s (both clocks start here)."""
    scale: float = param(1.9, 1e-12, 1e4, live=True, ignored_when={"animator": True})
    """World units per screen height (book: _Scale). Below about 1e-4 float32 cannot resolve pixels: use
    precision=double."""
    offset: tuple[float, float] = param((0.0, 0.0), -1e12, 1e12, live=True, ignored_when={"animator": True})
    """Pan (book: _Offset): in screen heights before scaling for modes 0/1 (so a zoom into world point c needs
    c / scale: hence the wide range), world units after it for mode 2."""
    circle: tuple[float, float] = param(
        (0.0, 0.0), -1e4, 1e4, live=True, used_only_when={"mode": 2}, ignored_when={"animator": True}
    )
    """Centre of the extra inversion circle of mode 2, world units (book: _Circle.xy)."""
    circle_w: float = param(1.0, 1e-6, 1e4, live=True, used_only_when={"mode": 2}, ignored_when={"animator": True})
    """The inversion's 'radius' argument (book: _Circle.w); the shader multiplies by it over |p - c|^2, so it acts as
    the squared radius."""
    iteration: int = param(50, 1, 5000, live=True)
    """Most fold-and-transform steps per sample (book: _Iteration; 500 in the script, 50 in the scenes)."""
    mode: int = param(0, choices=(0, 1, 2), live=True)
    """Shader pass: 0 plain, 1 multisampled, 2 with the extra circle inversion (book: pass)."""
    samples: int = param(0, 0, 1024, live=True, ignored_when={"mode": 0})
    """Samples per pixel in modes 1 and 2; 0 = the book's (20 and 10). Mode 0 takes one."""
    jitter: float = param(3.0, 0.0, 100.0, live=True, ignored_when={"mode": 0})
    """Sample offsets rand2 * jitter / height in world units, one-sided (book: 3 / _ScreenParams.y; it does not
    follow scale)."""
    hash: str = param("portable", choices=("portable", "sin"), live=True, ignored_when={"mode": 0})
    """Jitter hash: a PCG integer hash, the same on every device, or the book's sin hash rand2n."""
    hit_color: tuple[float, float, float, float] = param(HIT_COLOR, 0.0, 1.0, live=True)
    """Colour of points of the limit set's disks (book: _HitColor)."""
    back_color: tuple[float, float, float, float] = param(BACK_COLOR_KLEINIAN, 0.0, 1.0, live=True)
    """Colour of the other points (book: _BackColor)."""
    adaptive: bool = param(False, live=True, ignored_when={"mode": 0})
    """Take the samples only where the 3x3 neighbourhood of centre samples is not uniform; elsewhere the centre
    colour stands (not in the book)."""
    precision: str = param("float", choices=("float", "double"), live=True)
    """Kernel arithmetic: float as the book, or double (cl_khr_fp64) for deep zooms. The view draws in float."""
    overlay: bool = param(False, live=True)
    """Draw Line1, Line2, Line3, the parallelogram and the largest disk over the view (Figure 2.3)."""

    @property
    def effective_samples(self) -> int:
        """Samples per pixel: 1 in mode 0, else ``samples`` or the book's count of the pass."""
        return 1 if self.mode == 0 else self.samples or BOOK_SAMPLES[self.mode]


class Simulation(BaseSimulation):
    """The book's full-screen pass as kernels: t, scale, offset and circle of the current time, then a frame."""

    Params = Params
    history = ("rgba", "hit", "iters", "t", "scale", "offset", "circle")

    def _reset(self) -> None:
        self._frame_cache = None
        self._buffers = None

    def program(self, precision: str | None = None):
        """kleinian.cl built for ``precision`` (float or double)."""
        double = (precision or self.params.precision) == "double"
        if double and "cl_khr_fp64" not in self.runtime.device.extensions:
            raise ValueError(f"precision=double needs cl_khr_fp64, which {self.runtime.label} lacks")
        return self.runtime.program("kleinian", KLEINIAN_DOUBLE=int(double))

    def real(self, precision: str | None = None) -> type:
        return np.float64 if (precision or self.params.precision) == "double" else np.float32

    @classmethod
    def allocations(cls, params: Params) -> list:
        pixels = params.width * params.height
        return [Allocation("rgba frame", 16 * pixels, "width")]

    def _step(self, dt: float) -> None:
        """Nothing to run: a frame is rendered from the time when ``state()`` asks for it."""

    # {{{ the frame's values (KleinianGroup.Update)

    def frame(self) -> dict:
        """t, scale, offset, circle (cx, cy, 0, w) and time of the current frame, from the curves and the clip
        where they are on, else from the fields."""
        p = self.params
        time = p.start_time + self.time
        u, v = uv_at(time * p.time_scale) if p.use_uv_animation else (p.u, p.v)
        if p.animator:
            c = clip_at(time)
            scale, offset, circle = c["scale"], (c["offset_x"], c["offset_y"]), (c["circle_x"], c["circle_y"], 0.0, 1.0)
        else:
            scale, offset, circle = p.scale, p.offset, (*p.circle, 0.0, p.circle_w)
        return {"t": (u, v), "scale": scale, "offset": tuple(offset), "circle": tuple(circle), "time": time}

    def view_args(self, width: int, height: int, frame: dict | None = None, precision: str | None = None) -> tuple:
        """The kernels' VIEW_ARGS for a width x height frame."""
        p, f = self.params, frame or self.frame()
        real = self.real(precision)
        (u, v), (ox, oy), (cx, cy, _, cw) = f["t"], f["offset"], f["circle"]
        reals = (u, v, f["scale"], ox, oy, cx, cy, cw)
        return (
            np.int32(width),
            np.int32(height),
            *(real(x) for x in reals),
            np.int32(p.iteration),
            np.int32(p.mode),
            np.int32(p.effective_samples),
            real(p.jitter),
            np.int32(p.hash == "sin"),
        )

    # }}}

    # {{{ kernels

    def classify_points(self, points, u: float | None = None, v: float | None = None, iteration: int | None = None):
        """ClassifyPoints: (hit uint8 0/1, iterations int32) of world points (N, 2) for t = (u, v) (default: the
        frame's) in the kernel's precision."""
        p, f = self.params, self.frame()
        u, v = f["t"] if u is None else (u, v)
        real = self.real()
        pts = np.ascontiguousarray(points, real).reshape(-1, 2)
        n = len(pts)
        hit, iters = self.runtime.zeros(max(n, 1), np.uint8), self.runtime.zeros(max(n, 1), np.int32)
        if n:
            self.program().kernel("ClassifyPoints").over(
                n, 64, self.runtime.to_device(pts), np.int32(n), real(u), real(v),
                np.int32(iteration or p.iteration), hit, iters,
            )  # fmt: skip
        return hit.get()[:n], iters.get()[:n]

    def _frame_buffers(self, width: int, height: int):
        if self._buffers is None or self._buffers[0] != (width, height):
            rt, n = self.runtime, width * height
            self._buffers = (
                (width, height),
                rt.empty((n, 4), np.float32),
                rt.empty(n, np.uint16),
                rt.empty(n, np.int32),
                rt.empty(n, np.uint8),
            )
        return self._buffers[1:]

    def render_kleinian(self, width: int | None = None, height: int | None = None, frame: dict | None = None,
                        **changes) -> dict[str, np.ndarray]:  # fmt: skip
        """PixelCentreHits (with adaptive), then RenderKleinian: rgba (H, W, 4), hit (samples that hit, uint16),
        iters (H, W) and with adaptive centre_hit (H, W), rows in GL order (row 0 = bottom). ``changes`` override
        Params for this frame only."""
        saved = self.params
        self.params = saved.replace(**changes) if changes else saved
        try:
            return self._render(width or self.params.width, height or self.params.height, frame)
        finally:
            self.params = saved

    def _render(self, width: int, height: int, frame: dict | None) -> dict[str, np.ndarray]:
        rgba, hit, iters, centre = self.enqueue_frame(width, height, frame)
        out = {
            "rgba": rgba.get().reshape(height, width, 4),
            "hit": hit.get().reshape(height, width),
            "iters": iters.get().reshape(height, width),
        }
        if self.params.adaptive:
            out["centre_hit"] = centre.get().reshape(height, width)
        return out

    def enqueue_frame(self, width: int, height: int, frame: dict | None = None) -> tuple:
        """Enqueue PixelCentreHits (with adaptive) and RenderKleinian, built for the precision and a work-group
        both run; the frame's device arrays (rgba, hit, iters, centre_hit), nothing read."""
        p = self.params
        rgba, hit, iters, centre = self._frame_buffers(width, height)
        size, program = self.runtime.fitted_program(
            "kleinian", ("PixelCentreHits", "RenderKleinian"), LOCAL_SIZE, dims=2,
            KLEINIAN_DOUBLE=int(p.precision == "double"),
        )  # fmt: skip
        args = self.view_args(width, height, frame)
        if p.adaptive:
            program.kernel("PixelCentreHits").over((width, height), (size, size), centre, iters, *args)
        program.kernel("RenderKleinian").over(
            (width, height), (size, size), rgba, hit, iters, centre, np.int32(p.adaptive),
            cltypes.make_float4(*p.hit_color), cltypes.make_float4(*p.back_color), *args,
        )  # fmt: skip
        return rgba, hit, iters, centre

    # }}}

    def state(self) -> dict[str, np.ndarray]:
        key = (self.time, self.params)
        if self._frame_cache is None or self._frame_cache[0] != key:
            p, f = self.params, self.frame()
            image = self.render_kleinian(frame=f)
            samples = p.effective_samples
            self._frame_cache = (
                key,
                {
                    "rgba": image["rgba"][::-1].copy(),  # top row first, as image files
                    "hit": image["hit"][::-1].astype(np.uint8 if samples <= 255 else np.uint16),
                    "iters": image["iters"][::-1].copy(),
                    "t": np.asarray(f["t"], np.float32),
                    "scale": np.float32(f["scale"]),
                    "offset": np.asarray(f["offset"], np.float32),
                    "circle": np.asarray(f["circle"], np.float32),
                    "time": np.float32(f["time"]),
                    "mode": np.int32(p.mode),
                    "iteration": np.int32(p.iteration),
                    "samples": np.int32(samples),
                },
            )
        return dict(self._frame_cache[1])

    def stats(self) -> dict:
        state = self.state()
        f = self.frame()
        samples = int(state["samples"])
        return {
            **super().stats(),
            "t": tuple(round(x, 6) for x in f["t"]),
            "hit fraction": float(state["hit"].mean() / samples),
            "mean iterations": float(state["iters"].mean()),
        }


SCENES = [
    Scene(
        "kleinian",
        Simulation,
        "Limit set of a Kleinian group: the band of tangent circles, per pixel (vol.4 ch.2, KleinianGroup)",
        defaults={"use_uv_animation": True, "time_scale": 1.0},
        preview={"steps": 0, "use_uv_animation": False},
        animation=Animation(
            "the book's uv animation (use_uv_animation: t along animKleinU/V over its 1 s clip, here in 2 s) grows the "
            "spirals",
            every=2,
            start=1,
            frames=30,
            overrides={"use_uv_animation": True},
        ),
        preview_check=PreviewCheck(fills_frame="the limit set tiles the whole plane"),
        at_scale=AtScale(gpu={"width": 3840, "height": 2160}, cpu={"width": 1280, "height": 720}, frame=(3840, 2160)),
    ),
    Scene(
        "kleinian_inverse",
        Simulation,
        "Kleinian limit set through an animated extra circle inversion (vol.4 ch.2, KleinianGroupCircleInverse)",
        defaults={
            "use_uv_animation": True,
            "time_scale": 0.5,
            "animator": True,
            "mode": 2,
            "back_color": BACK_COLOR_INVERSE,
        },
        preview={"steps": 600},
        preview_check=PreviewCheck(fills_frame="the limit set tiles the whole plane"),
    ),
]
