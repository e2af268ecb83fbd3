"""StarGlow: Kawase's light streaks from the bright pixels of an HDR frame (vol.4 ch.4; docs/chapters/15-star-glow.md).

Kernel order per frame, as the book's ``StarGlow.cs`` blits its shader passes: ``Brightness`` (pass 1) into a
``divide``-times smaller image; for each of ``num_of_streak`` directions ``Streak`` (pass 2) ``iteration`` times
with power 1, 4, 16 ... (a ping-pong pair), then ``ScreenAccumulate`` (pass 3, ``Blend OneMinusDstColor One``) into
``comp``; ``Composite`` (pass 4) onto the source. Pass 0 of the book's shader is never described in the chapter and
never blitted by the script: it is a plain copy for debugging, which the viewer's display keys play.
``variant=fused`` (not in the book): every direction of a pass in one 3-D launch (``StreakAllDirections``), and the
last pass fused with the screen accumulation (``StreakAccumulate``): ``iteration + 2`` launches instead of
``2 + num_of_streak * (iteration + 1)``, the same result.

The source is ``input``: ``demo`` (``DemoScene``: lit white spheres falling through the frame, their specular
highlights above 1, as the book's sample of lit falling cubes on a black HDR camera) or an image file (``.png``,
scaled by ``input_gain``; ``.npy``, HDR float (H, W, 3|4), top row first).

Differences from the book: ``comp`` is cleared every frame (the book blends into an uncleared temporary); the tap
weights a^(power*j) come from the host as exact float32 powers.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pyopencl as cl
import pyopencl.cltypes as cltypes

from ..buffers import PingPong
from ..inputs import InputError, file_cached, read_image
from ..resources import Allocation
from ..scene import Animation, ParamError, PreviewCheck, Scene, param
from ..scene import Params as BaseParams
from ..scene import Simulation as BaseSimulation

STEM = "star_glow"
COMPOSITE_TYPES = ("additive", "screen", "colored_additive", "colored_screen", "debug")
"""The book's CompositeType keywords (_COMPOSITE_TYPE_ADDITIVE ...), in the order of their ids 0-4."""
TAPS = 4
"""Taps per streak pass (Kawase's value; the shader's `j < 4`)."""
LOCAL = (16, 16)
"""Work-group of every 2-D kernel (16x16)."""
IMAGE_SUFFIXES = (".png", ".npy")
MAX_IMAGE_SIDE = 8192
"""Largest width or height of an image input (the demo frame's limit)."""
MAX_IMAGE_BYTES = 2 << 30
"""Largest image file: an 8192 x 8192 x 4 float64 .npy."""

# {{{ the demo's scene (the book's Sample scene: a lit white particle shower on a black HDR camera)

EYE = (0.0, 0.0, -2.0)
"""Camera position; it looks along +z (Sample: camera at (0, 0, -2))."""
FOV_DEGREES = 30.0
"""Vertical field of view (Sample camera)."""
LIGHT_COLOR = (1.0, 0.957, 0.839)
LIGHT_INTENSITY = 0.87
LIGHT_EULER = (50.0, -30.0, 0.0)
"""The Sample's directional light: colour, intensity and Unity Euler angles (degrees)."""
SPECULAR, SHININESS = 3.0, 64.0
"""Blinn-Phong specular gain and exponent: highlights reach ~3x the light (a strong specular term)."""
FALL_SPEED = 0.25
"""Mean falling speed of the spheres, world units/s."""


def to_light_direction(euler=LIGHT_EULER) -> np.ndarray:
    """Unit vector towards a Unity directional light with Euler angles (x, y, z) degrees: its forward (0, 0, 1)
    rotated by Rx then Ry (Unity applies z, x, y), negated."""
    ax, ay = np.radians(euler[0]), np.radians(euler[1])
    forward = np.array([0.0, -np.sin(ax), np.cos(ax)])  # Rx: +x tilts forward down (left-handed, y up)
    forward = np.array(
        [
            forward[0] * np.cos(ay) + forward[2] * np.sin(ay),
            forward[1],
            -forward[0] * np.sin(ay) + forward[2] * np.cos(ay),
        ]
    )
    return -forward / np.linalg.norm(forward)


def demo_spheres(count: int, seed: int, time: float, aspect: float) -> tuple[np.ndarray, np.ndarray]:
    """(centres+radius, albedo) float32 (count, 4) at ``time``: spheres falling through the view and wrapping to the
    top, each with its own depth, size, speed and a pale tint."""
    rng = np.random.default_rng(seed)
    z = rng.uniform(1.0, 3.0, count)
    half_h = (z - EYE[2]) * math.tan(math.radians(FOV_DEGREES / 2))
    x = rng.uniform(-0.9, 0.9, count) * half_h * aspect
    radius = rng.uniform(0.05, 0.12, count)
    speed = FALL_SPEED * rng.uniform(0.6, 1.4, count)
    span = 2 * (half_h + radius)
    y = half_h + radius - np.mod(rng.uniform(0.0, 1.0, count) * span + speed * time, span)
    albedo = 1.0 - rng.uniform(0.0, 0.35, (count, 3)) * (rng.random((count, 1)) < 0.5)
    spheres = np.stack([x, y, z, radius], axis=1).astype(np.float32)
    return spheres, np.concatenate([albedo, np.ones((count, 1))], axis=1).astype(np.float32)


# }}}


@dataclass(frozen=True)
class Params(BaseParams):
    composite_type: str = param("additive", choices=COMPOSITE_TYPES, live=True)
    """Final blend of the glow onto the source (book: compositeType): clamp(src + glow), screen, the two with the
    glow's grey times ``color``, or debug (the glow alone, unclamped)."""
    threshold: float = param(1.0, 0.0, 1e4, live=True)
    """Brightness threshold: only channel values above it glow (book: threshold, inspector 0-1)."""
    intensity: float = param(1.0, 0.0, 1e4, live=True)
    """Gain on what passes the threshold (book: intensity, inspector 0-10)."""
    divide: int = param(3, 1, 64)
    """Downscale of the glow images: w = W // divide, h = H // divide (book: divide, inspector 1-20)."""
    iteration: int = param(5, 1, 8, live=True)
    """Streak passes per direction; a streak is 4^iteration texels long (book: iteration, inspector 1-5)."""
    attenuation: float = param(1.0, 0.0, 1.0, live=True)
    """Decay per texel along a streak: tap j of pass i weighs attenuation^(4^(i-1) j) (book: attenuation)."""
    angle_of_streak: float = param(0.0, -360.0, 360.0, live=True)
    """Rotation of the star, degrees (book: angleOfStreak, inspector 0-360)."""
    num_of_streak: int = param(4, 1, 16)
    """Number of streak directions, 360/num_of_streak degrees apart (book: numOfStreak)."""
    color: tuple[float, float, float, float] = param(
        (1.0, 1.0, 1.0, 1.0),
        0.0,
        1e4,
        live=True,
        used_only_when={"composite_type": {"colored_additive", "colored_screen"}},
    )
    """Tint of the colored_* composite types (book: color)."""
    input: str = "demo"
    """Source frame: ``demo`` (lit spheres, rendered by DemoScene) or an image file (.png, .npy float HDR (H, W, 3|4)),
    at most 8192 pixels a side and 2 GiB."""
    input_gain: float = param(1.0, 0.0, 1e4, ignored_when={"input": "demo"})
    """Scale of an image input (PNG values are <= 1: raise it, or lower threshold, to make them glow)."""
    width: int = param(640, 1, 8192, used_only_when={"input": "demo"})
    """Width W of the demo frame, pixels (an image input has its own size)."""
    height: int = param(360, 1, 8192, used_only_when={"input": "demo"})
    """Height H of the demo frame, pixels (an image input has its own size)."""
    spheres: int = param(24, 1, 1024, used_only_when={"input": "demo"})
    """Spheres of the demo frame."""
    variant: str = param("book", choices=("book", "fused"), live=True)
    """book: one launch per pass and direction; fused: one 3-D launch per pass, the last fused with pass 3."""
    save_streaks: bool = param(False, live=True)
    """Keep every direction's final streak image (``streaks`` (N, h, w, 4) in the state)."""

    limits = ("width // divide >= 1", "height // divide >= 1")
    """The glow images need a texel (for the demo frame; an image input is checked when it is read)."""

    def check(self) -> None:
        for rule, size in zip(self.limits, (self.width, self.height), strict=True):
            if size // self.divide < 1:
                raise self.broken(rule, f"glow image {self.width // self.divide}x{self.height // self.divide}")
        if self.input != "demo" and Path(self.input).suffix.lower() not in IMAGE_SUFFIXES:
            raise ValueError(f"input must be demo or a {'/'.join(IMAGE_SUFFIXES)} file, got {self.input!r}")
        if self.input != "demo":
            height, width = load_image(self.input).shape[:2]  # read and checked here, cached for the reset
            if width // self.divide < 1 or height // self.divide < 1:
                raise ValueError(
                    f"input {self.input}: a {width}x{height} image leaves no glow image at divide={self.divide}"
                )

    @property
    def mode(self) -> int:
        return COMPOSITE_TYPES.index(self.composite_type)


def streak_directions(count: int, angle_of_streak: float) -> np.ndarray:
    """(count, 2) float32: direction x = 1..count is (0, -1) rotated by 360/count * x + angle_of_streak degrees
    about +z (book: Quaternion.AngleAxis(angle * x + angleOfStreak, forward) * Vector2.down), in float64 with
    components below 1e-6 snapped to 0 so axis streaks hit texel centres."""
    theta = np.radians(360.0 / count * np.arange(1, count + 1) + angle_of_streak)
    dirs = np.stack([np.sin(theta), -np.cos(theta)], axis=1)
    dirs[np.abs(dirs) < 1e-6] = 0.0
    return (dirs / np.linalg.norm(dirs, axis=1, keepdims=True)).astype(np.float32)


def tap_weights(attenuation: float, power: float) -> np.ndarray:
    """attenuation^(power * j) for the 4 taps (pow(0, 0) = 1, as HLSL)."""
    return np.array([attenuation ** (power * j) for j in range(TAPS)], np.float32)


@file_cached(maxsize=1)
def load_image(path: str) -> np.ndarray:
    """An image file as float32 (H, W, 4), top row first, after the checks of ``ugpcl.inputs.read_image``; cached
    by file version (one image), read-only."""
    image = read_image("input", path, MAX_IMAGE_SIDE, MAX_IMAGE_BYTES)
    image.flags.writeable = False
    return image


class Simulation(BaseSimulation):
    """One StarGlow frame per step: the demo's frame (or the input image), then passes 1-4."""

    Params = Params

    @classmethod
    def allocations(cls, params: Params) -> list:
        demo = params.input == "demo"
        height, width = (params.height, params.width) if demo else load_image(params.input).shape[:2]
        full = width * height * 16
        glow = full // (params.divide * params.divide)
        return [
            Allocation("source image", full, "width"),
            Allocation("output image", full, "width"),
            Allocation("streak layers (three sets)", 3 * glow * params.num_of_streak, "num_of_streak"),
            Allocation("glow images (four)", 4 * glow, "width"),
        ]

    def _reset(self) -> None:
        p, rt = self.params, self.runtime
        self.program = rt.program(STEM)
        self.demo = p.input == "demo"
        try:  # in GL row order (row 0 = bottom), times the gain
            image = None if self.demo else np.ascontiguousarray(load_image(p.input)[::-1] * np.float32(p.input_gain))
        except InputError as err:  # edited since check() read it
            raise ParamError(str(err)) from None
        self.W, self.H = (p.width, p.height) if self.demo else (image.shape[1], image.shape[0])
        self.w, self.h = self.W // p.divide, self.H // p.divide
        n = p.num_of_streak
        self.src = rt.to_device(image) if image is not None else rt.zeros((self.H, self.W, 4), np.float32)
        self.dst = rt.zeros((self.H, self.W, 4), np.float32)
        self.bright = rt.zeros((self.h, self.w, 4), np.float32)
        self.comp = rt.zeros((self.h, self.w, 4), np.float32)
        self.blur = PingPong.zeros(rt, (self.h, self.w, 4), np.float32)  # the book's blurredTex1/2
        self.layers = PingPong.zeros(rt, (n, self.h, self.w, 4), np.float32)  # fused: one layer per direction
        self.streaks = rt.zeros((n, self.h, self.w, 4), np.float32)
        self.dirs = rt.zeros(n, cltypes.float2)
        self.dirs_angle = None  # the angle_of_streak self.dirs holds (it is live: see _directions)
        self.frame()

    # {{{ kernels, in the book's order

    def demo_scene(self, time: float | None = None) -> None:
        """DemoScene: the spheres at ``time`` (default: now), lit, into src (not in the book)."""
        p = self.params
        time = self.time if time is None else time
        spheres, albedo = demo_spheres(p.spheres, self.seed, time, self.W / self.H)
        to_light = to_light_direction()
        self.program.kernel("DemoScene").over(
            (self.W, self.H),
            LOCAL,
            self.src,
            np.int32(self.W),
            np.int32(self.H),
            self.runtime.to_device(spheres),
            self.runtime.to_device(albedo),
            np.int32(p.spheres),
            cltypes.make_float4(*EYE, 0.0),
            np.float32(math.tan(math.radians(FOV_DEGREES / 2))),
            cltypes.make_float4(*to_light, 0.0),
            cltypes.make_float4(*(c * LIGHT_INTENSITY for c in LIGHT_COLOR), 0.0),
            np.float32(SPECULAR),
            np.float32(SHININESS),
        )

    def brightness(self) -> None:
        """Pass 1: bright = max(src - threshold, 0) * intensity, one bilinear tap per small texel."""
        p = self.params
        self.program.kernel("Brightness").over(
            (self.w, self.h),
            LOCAL,
            self.src,
            np.int32(self.W),
            np.int32(self.H),
            self.bright,
            np.int32(self.w),
            np.int32(self.h),
            np.float32(p.threshold),
            np.float32(p.intensity),
        )

    def streak(self, source, target, direction, power: float) -> None:
        """Pass 2: 4 taps from ``source`` along ``direction`` * power texels into ``target``."""
        self.program.kernel("Streak").over(
            (self.w, self.h),
            LOCAL,
            source,
            target,
            np.int32(self.w),
            np.int32(self.h),
            cltypes.make_float2(*direction),
            np.float32(power),
            cltypes.make_float4(*tap_weights(self.params.attenuation, power)),
        )

    def screen_accumulate(self, source) -> None:
        """Pass 3: comp = source + comp - source * comp (the book's Blend OneMinusDstColor One)."""
        self.program.kernel("ScreenAccumulate").over(
            (self.w, self.h), LOCAL, source, self.comp, np.int32(self.w), np.int32(self.h)
        )

    def streak_all_directions(self, source, target, in_stride: int, power: float) -> None:
        """Pass 2 of every direction in one launch: layer d of ``target`` from layer d of ``source`` (in_stride 0:
        every direction reads ``source`` itself)."""
        self.program.kernel("StreakAllDirections").over(
            (self.w, self.h, self.params.num_of_streak),
            (*LOCAL, 1),
            source,
            target,
            np.int32(self.w),
            np.int32(self.h),
            np.int32(in_stride),
            self.dirs,
            np.float32(power),
            cltypes.make_float4(*tap_weights(self.params.attenuation, power)),
        )

    def streak_accumulate(self, source, in_stride: int, power: float) -> None:
        """The last pass 2 of every direction, screen-blended into comp (which it overwrites: no clear needed)."""
        self.program.kernel("StreakAccumulate").over(
            (self.w, self.h),
            LOCAL,
            source,
            self.comp,
            np.int32(self.w),
            np.int32(self.h),
            np.int32(in_stride),
            self.dirs,
            np.int32(self.params.num_of_streak),
            np.float32(power),
            cltypes.make_float4(*tap_weights(self.params.attenuation, power)),
        )

    def composite(self) -> None:
        """Pass 4: the glow onto the source by composite_type."""
        p = self.params
        self.program.kernel("Composite").over(
            (self.W, self.H),
            LOCAL,
            self.src,
            np.int32(self.W),
            np.int32(self.H),
            self.comp,
            np.int32(self.w),
            np.int32(self.h),
            self.dst,
            np.int32(p.mode),
            cltypes.make_float4(*p.color),
        )

    # }}}

    def powers(self) -> list[float]:
        """power of pass i = 1..iteration: 4^(i-1) (book: pow(4, _Iteration - 1)), exact in float32."""
        return [float(TAPS ** (i - 1)) for i in range(1, self.params.iteration + 1)]

    def _directions(self) -> None:
        """Directions for the current angle_of_streak (a live parameter), uploaded when it changed."""
        if self.dirs_angle != self.params.angle_of_streak:
            self.dirs_host = streak_directions(self.params.num_of_streak, self.params.angle_of_streak)
            self.dirs.set(self.dirs_host.view(cltypes.float2).reshape(-1))
            self.dirs_angle = self.params.angle_of_streak

    def star_glow(self) -> None:
        """The book's OnRenderImage: passes 1, (2 x iteration, 3) per direction, 4."""
        self._directions()
        self.brightness()
        if self.params.variant == "fused":
            self._streaks_fused()
        else:
            self._streaks_book()
        self.composite()

    def _streaks_book(self) -> None:
        queue, layer = self.runtime.queue, self.w * self.h * 16
        self.comp.fill(0.0)  # the book's compositeTex is an uncleared temporary
        for d, direction in enumerate(self.dirs_host):
            powers = self.powers()
            self.streak(self.bright, self.blur.read, direction, powers[0])
            for power in powers[1:]:
                self.streak(self.blur.read, self.blur.write, direction, power)
                self.blur.swap()
            self.screen_accumulate(self.blur.read)
            if self.params.save_streaks:
                cl.enqueue_copy(queue, self.streaks.data, self.blur.read.data, dst_offset=d * layer, byte_count=layer)

    def _streaks_fused(self) -> None:
        *early, last = self.powers()
        source, stride = self.bright, 0
        for power in early:
            self.streak_all_directions(source, self.layers.write, stride, power)
            self.layers.swap()
            source, stride = self.layers.read, self.w * self.h
        self.streak_accumulate(source, stride, last)
        if self.params.save_streaks:  # the fused pass keeps no streaks: run the last pass once more to show them
            self.streak_all_directions(source, self.streaks, stride, last)

    def frame(self, time: float | None = None) -> None:
        """One frame: the demo's source at ``time`` (default: now; an image input stays), then StarGlow."""
        if self.demo:
            self.demo_scene(time)
        self.star_glow()

    def _step(self, dt: float) -> None:
        self.frame(self.time + dt)  # the frame at the end of this step

    def images(self) -> dict[str, np.ndarray]:
        """Every image in GL row order (row 0 = bottom), as the kernels see them."""
        images = {name: getattr(self, name).get() for name in ("src", "bright", "comp", "dst")}
        if self.params.save_streaks:
            images["streaks"] = self.streaks.get()
        return images

    def state(self) -> dict[str, np.ndarray]:
        """The chapter's arrays, top row first (as image files): src, bright, comp, dst, streak_dirs (+ streaks)."""
        images = self.images()
        state = {name: np.ascontiguousarray(image[..., ::-1, :, :]) for name, image in images.items()}
        return {**state, "streak_dirs": self.dirs_host.copy()}

    def stats(self) -> dict:
        p = self.params
        launches = p.iteration + 2 if p.variant == "fused" else 2 + p.num_of_streak * (p.iteration + 1)
        return {
            **super().stats(),
            "source": f"{self.W}x{self.H}",
            "glow image": f"{self.w}x{self.h}",
            "launches per frame": launches + int(self.demo),
            "streak length": f"{TAPS**p.iteration} texels",
        }


PREVIEW = {"steps": 30, "width": 800, "height": 450}
"""docs/img/star_glow.png: the Sample scene's settings on the demo's falling spheres after half a second."""

SCENES = [
    Scene(
        STEM,
        Simulation,
        "StarGlow: Kawase light streaks from the highlights of lit falling spheres (vol.4 ch.4)",
        defaults={
            "threshold": 1.0,
            "intensity": 1.3,
            "divide": 7,
            "iteration": 2,
            "attenuation": 0.7,
            "angle_of_streak": 30.0,
            "num_of_streak": 5,
        },
        preview=PREVIEW,
        interactive={"width": 480, "height": 270},
        animation=Animation("the demo spheres fall and their star streaks follow the highlights", every=2),
        preview_check=PreviewCheck(fills_frame="a field of stars all around the camera"),
    )
]
