"""StarGlow (vol.4 ch.4; docs/chapters/15-star-glow.md): the four passes against numpy, Kawase's impulse response,
the rules of threshold and modes, the fused variant, the GL passes, the headless run, the view and Oclgrind."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
from helpers import compare_images, linear_filter_error, render_view, run_cli
from scipy import ndimage

from ugpcl.bench.star_glow import streak_line_kernel
from ugpcl.registry import get
from ugpcl.scenes.star_glow import COMPOSITE_TYPES, Params, Simulation, demo_spheres

# {{{ numpy float64 reference, written from the book's StarGlow.shader passes and StarGlow.cs


def sample(image: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """tex2D with bilinear filtering and clamp-to-edge on an (h, w, 4) image in GL row order."""
    h, w = image.shape[:2]
    x, y = u * w - 0.5, v * h - 0.5
    x0, y0 = np.floor(x), np.floor(y)
    fx, fy = (x - x0)[..., None], (y - y0)[..., None]
    xi, yi = x0.astype(int), y0.astype(int)

    def texel(i, j):
        return image[np.clip(j, 0, h - 1), np.clip(i, 0, w - 1)]

    bottom = texel(xi, yi) * (1 - fx) + texel(xi + 1, yi) * fx
    top = texel(xi, yi + 1) * (1 - fx) + texel(xi + 1, yi + 1) * fx
    return bottom * (1 - fy) + top * fy


def centres(w: int, h: int) -> tuple[np.ndarray, np.ndarray]:
    """uv of every texel centre of a w x h target, as (h, w) arrays."""
    return np.meshgrid((np.arange(w) + 0.5) / w, (np.arange(h) + 0.5) / h)


def brightness_ref(src, w, h, threshold, intensity):
    """Pass 1: max(color - threshold, 0) * intensity."""
    return np.maximum(sample(src, *centres(w, h)) - threshold, 0.0) * intensity


def streak_ref(image, direction, power, attenuation):
    """Pass 2: color += saturate(tex2D(_MainTex, uv) * pow(ATTENUATION, power * j)); uv += offset."""
    h, w = image.shape[:2]
    u, v = centres(w, h)
    out = np.zeros_like(image)
    for j in range(4):
        tap = sample(image, u + j * direction[0] * power / w, v + j * direction[1] * power / h)
        out += np.clip(tap * attenuation ** (power * j), 0.0, 1.0)
    return out


def addressing_error(image: np.ndarray, reach: float) -> float:
    """What float32 uv addressing may cost one bilinear tap of ``image``, as GL's does: uv and uv * size are each
    rounded to 2^-24 of a position up to ``reach`` texels, which moves the tap by that much times the largest
    difference between neighbouring texels (per axis: x2), x2 margin."""
    gradient = max(np.abs(np.diff(image, axis=a)).max(initial=0.0) for a in (0, 1))
    return 8 * 2.0**-24 * reach * gradient


def composite_ref(src, comp, mode, color):
    """Pass 4 with the keyword of ``mode``."""
    H, W = src.shape[:2]
    glow = sample(comp, *centres(W, H))
    name = COMPOSITE_TYPES[mode]
    if name.startswith("colored"):
        glow[..., :3] = glow[..., :3].sum(axis=-1, keepdims=True) * 0.3333 * np.asarray(color[:3])
    if name.endswith("screen"):
        return np.clip(src + glow - np.clip(src * glow, 0, 1), 0, 1)
    if name.endswith("additive"):
        return np.clip(src + glow, 0, 1)
    return glow


def streaks_ref(bright: np.ndarray, p: Params) -> list[tuple[np.ndarray, float]]:
    """StarGlow.cs's loop over directions x = 1..N: Quaternion.AngleAxis(angle * x + angleOfStreak, forward) *
    Vector2.down, then iteration passes of power 4^(i-1) each; with each streak a bound on the kernel's error: a pass
    sums 4 taps of weight <= 1 (saturate is 1-Lipschitz), so it passes on 4x the error of its input and adds the
    addressing error of its taps and the rounding of its sum (<= 4)."""
    streaks = []
    for x in range(1, p.num_of_streak + 1):
        theta = np.radians(360.0 / p.num_of_streak * x + p.angle_of_streak)
        direction = np.round([np.sin(theta), -np.cos(theta)], 12)
        blurred, bound = bright.astype(np.float64), 0.0
        for i in range(1, p.iteration + 1):
            power = 4.0 ** (i - 1)
            reach = max(blurred.shape[:2]) + 3 * power
            bound = 4 * (bound + addressing_error(blurred, reach)) + 16 * UNIT_ROUNDOFF
            blurred = streak_ref(blurred, direction, power, p.attenuation)
        streaks.append((blurred, bound))
    return streaks


UNIT_ROUNDOFF = 2.0**-23
"""float32 rounding error of one operation, relative to its result (2^-24), doubled for margin."""


def screen_ref(streaks) -> tuple[np.ndarray, np.ndarray]:
    """comp after Blend OneMinusDstColor One of every streak onto a cleared target, and a bound on the float32 error
    of that chain: above 1 the screen blend is ill-conditioned (4 + 4 - 16 = -8 ...), each step multiplies the
    error so far by |1 - s| and adds the rounding of s + d, s d and the result."""
    comp = bound = np.zeros_like(np.asarray(streaks[0], np.float64))
    for s in streaks:
        s = np.asarray(s, np.float64)
        new = s + comp - s * comp
        bound = np.abs(1 - s) * bound + UNIT_ROUNDOFF * (np.abs(s) + np.abs(comp) + np.abs(s * comp) + np.abs(new))
        comp = new
    return comp, bound


# }}}


def make(runtime, tmp_path, image: np.ndarray, **overrides) -> Simulation:
    """A Simulation on ``image`` ((H, W, 4) float, GL row order) given as a .npy input (files are top row first)."""
    path = tmp_path / "input.npy"
    np.save(path, np.ascontiguousarray(image[::-1], np.float32))
    return Simulation(runtime, Params(input=str(path), **overrides), seed=0)


def random_hdr(shape, seed, top=4.0) -> np.ndarray:
    return np.random.default_rng(seed).uniform(0.0, top, (*shape, 4)).astype(np.float32)


def impulse(size: int, q: tuple[int, int], value: float = 1.0) -> np.ndarray:
    image = np.zeros((size, size, 4), np.float32)
    image[q[1], q[0]] = value
    return image


def close(actual, expected, tol=1e-5) -> bool:
    """|actual - expected| <= tol * max(1, |expected|): comp is unclamped, and screen blends of values above 1
    grow (4 + 4 - 16 = -8 ...), so the float32 error scales with the value."""
    return bool(np.all(np.abs(actual - expected) <= tol * np.maximum(1.0, np.abs(expected))))


# {{{ kernels vs reference


@pytest.mark.parametrize("variant", ["book", "fused"])
@pytest.mark.parametrize(
    "divide, streaks, iteration, angle",
    [(1, 4, 1, 0.0), (3, 5, 2, 30.0), (3, 4, 3, 12.5), (1, 5, 2, 200.0)],
)
def test_passes_match_reference_on_random_hdr(runtime, tmp_path, seed, variant, divide, streaks, iteration, angle):
    """Each pass against numpy on the kernels' own input of that pass (values 0-4), so that the ill-conditioned
    screen blend of HDR streaks does not carry one pass's float32 rounding into the next one's check."""
    src = random_hdr((48, 64), seed)
    common = dict(divide=divide, num_of_streak=streaks, iteration=iteration, angle_of_streak=angle)
    p = dict(common, threshold=0.8, intensity=1.3, attenuation=0.85, color=(1.0, 0.5, 0.25, 1.0), save_streaks=True)
    sim = make(runtime, tmp_path, src, variant=variant, **p)
    got = sim.images()
    H, W = src.shape[:2]
    assert got["bright"].shape == (H // divide, W // divide, 4)
    bright = brightness_ref(src, W // divide, H // divide, sim.params.threshold, sim.params.intensity)
    tolerance = 1e-5 + sim.params.intensity * addressing_error(src, max(W, H))
    assert np.abs(got["bright"] - bright).max() <= tolerance, compare_images(got["bright"], bright, tolerance)
    for d, (streak, bound) in enumerate(streaks_ref(got["bright"], sim.params)):
        tolerance = 1e-5 + bound
        error = np.abs(got["streaks"][d] - streak).max()
        assert error <= tolerance, f"streak {d}: {compare_images(got['streaks'][d], streak, tolerance)}"
    comp, bound = screen_ref(got["streaks"])
    assert (np.abs(got["comp"] - comp) <= bound).all(), compare_images(got["comp"], comp, 1e-5)
    assert got["streaks"].max() > 1.2  # HDR indeed: the screen blends see streaks above 1
    scale = np.maximum(1.0, sample(np.abs(got["comp"]), *centres(W, H)))  # the size of the glow taps
    tolerance = 1e-5 * scale + addressing_error(got["comp"], max(W, H) / divide)
    for mode in COMPOSITE_TYPES:  # composite_type is live: the same frame, recomposited
        sim.update(composite_type=mode)
        sim.composite()
        dst, want = sim.images()["dst"], composite_ref(src, got["comp"], sim.params.mode, sim.params.color)
        assert (np.abs(dst - want) <= tolerance).all(), f"dst ({mode}): {compare_images(dst, want, 1e-5)}"


@pytest.mark.parametrize("power", [1.0, 4.0, 16.0])
def test_streak_and_screen_accumulate_on_random_hdr(runtime, tmp_path, seed, power):
    """Pass 2 and pass 3 alone on HDR input (0-4): one streak pass along a diagonal, one screen blend."""
    image, comp = random_hdr((40, 50), seed), random_hdr((40, 50), seed + 1)
    sim = make(runtime, tmp_path, image, divide=1, attenuation=0.8)
    sim.bright.set(image)
    direction = np.array([0.6, -0.8], np.float32)
    sim.streak(sim.bright, sim.blur.write, direction, power)
    want = streak_ref(image.astype(np.float64), direction.astype(np.float64), power, 0.8)
    got, tolerance = sim.blur.write.get(), 1e-5 + 4 * addressing_error(image, 50 + 3 * power)
    assert np.abs(got - want).max() <= tolerance, compare_images(got, want, tolerance)
    sim.comp.set(comp)
    sim.screen_accumulate(sim.bright)
    want, bound = screen_ref([comp, image])
    assert (np.abs(sim.comp.get() - want) <= bound).all(), compare_images(sim.comp.get(), want, 1e-5)


@pytest.mark.parametrize("iteration", [1, 2, 3])
def test_impulse_response_is_attenuation_to_the_distance(runtime, tmp_path, iteration):
    """Kawase's property: n passes draw a^d at distance d < 4^n along -dir, 0 beyond; the seed's 1, 0.7, 0.49,
    0.343 for n = 1. q sits 2 * 4^n texels from every border, so clamp-to-edge never repeats a texel. A power-of-two
    size makes every float32 uv of an axis tap exact (texel centres are dyadic): the streak is exact too."""
    length, a = 4**iteration, 0.7
    size = 4 * length
    q = (2 * length, 2 * length)
    sim = make(
        runtime,
        tmp_path,
        impulse(size, q),
        threshold=0.0,
        intensity=1.0,
        divide=1,
        num_of_streak=4,
        angle_of_streak=0.0,
        attenuation=a,
        iteration=iteration,
        save_streaks=True,
    )
    images = sim.images()
    np.testing.assert_array_equal(sim.dirs_host, [[1, 0], [0, 1], [-1, 0], [0, -1]])
    d = np.arange(length)
    for k, (dx, dy) in enumerate(sim.dirs_host.astype(int)):
        expected = np.zeros((size, size, 4))
        expected[q[1] - d * dy, q[0] - d * dx] = (a**d)[:, None]  # the streak lies opposite to dir
        streak = images["streaks"][k]
        assert np.abs(streak - expected).max() <= 1e-6, f"dir {(dx, dy)}: {compare_images(streak, expected, 1e-6)}"
        arm = images["comp"][q[1] - d[1:] * dy, q[0] - d[1:] * dx, 0]
        assert np.abs(arm - a ** d[1:]).max() <= 1e-6  # the other three directions add 0 there
    if iteration == 1:
        np.testing.assert_allclose(images["streaks"][0][q[1], q[0] - d, 0], [1.0, 0.7, 0.49, 0.343], atol=1e-6)
    assert abs(images["comp"][q[1], q[0], 0] - 1.0) <= 1e-6  # screen blend of four 1s


@pytest.mark.parametrize("iteration", [1, 2, 3])
def test_attenuation_one_draws_a_box_of_4_to_the_n(runtime, tmp_path, iteration):
    """One direction (angle 0: dir (0, -1), the streak grows upwards in GL order) and a = 1: exactly 4^n ones
    (a power-of-two size: exact float32 uv, see the impulse test)."""
    length = 4**iteration
    size = max(16, 2 * length)
    sim = make(
        runtime,
        tmp_path,
        impulse(size, (5, 2)),
        threshold=0.0,
        divide=1,
        num_of_streak=1,
        angle_of_streak=0.0,
        attenuation=1.0,
        iteration=iteration,
        intensity=1.0,
        save_streaks=True,
    )
    np.testing.assert_array_equal(sim.dirs_host, [[0, -1]])
    streak = sim.images()["streaks"][0][..., 0]
    expected = np.zeros((size, size))
    expected[2 : 2 + length, 5] = 1.0
    assert np.abs(streak - expected).max() <= 1e-6, compare_images(streak, expected, 1e-6)


def test_angle_90_turns_the_single_streak_towards_minus_x(runtime, tmp_path):
    sim = make(runtime, tmp_path, impulse(32, (12, 12)), threshold=0.0, divide=1, num_of_streak=1)
    sim.update(angle_of_streak=90.0, iteration=1, attenuation=1.0)
    sim.star_glow()
    np.testing.assert_array_equal(sim.dirs_host, [[1, 0]])
    lit = np.argwhere(sim.images()["comp"][..., 0] > 0.5)
    assert sorted(map(tuple, lit)) == [(12, x) for x in range(9, 13)]  # (row, column): x = 12, 11, 10, 9


def test_streaks_equal_a_line_convolution_while_values_stay_below_one(runtime, tmp_path, seed):
    """Below saturation the cascade is the convolution with a^d, d < 4^n (scipy.ndimage.convolve with the line
    kernel), away from the edges where clamp-to-edge differs: pass-1 sums of inputs <= 0.35 stay <= 0.89."""
    iteration, a = 2, 0.7
    src = random_hdr((40, 48), seed, top=0.35)
    sim = make(runtime, tmp_path, src, threshold=0.0, intensity=1.0, divide=1, num_of_streak=4, attenuation=a)
    sim.update(iteration=iteration, save_streaks=True)
    sim.star_glow()
    images, length = sim.images(), 4**iteration
    for k, direction in enumerate(sim.dirs_host):
        kernel = streak_line_kernel(a, iteration, direction)
        for c in range(4):
            expected = ndimage.convolve(images["bright"][..., c].astype(np.float64), kernel, mode="nearest")
            inner = (slice(length, -length), slice(length, -length))
            got = images["streaks"][k][..., c]
            np.testing.assert_allclose(got[inner], expected[inner], atol=1e-5, err_msg=f"direction {direction}")


def test_each_tap_is_saturated_after_its_weight(runtime, tmp_path):
    """saturate(tex2D * pow(a, power j)): an impulse of 2 gives 1, 1, 0.98, 0.686 (not 1, 0.7, 0.49, 0.343)."""
    sim = make(runtime, tmp_path, impulse(16, (8, 8), 2.0), threshold=0.0, intensity=1.0, divide=1, num_of_streak=4)
    sim.update(angle_of_streak=0.0, iteration=1, attenuation=0.7, save_streaks=True)
    sim.star_glow()
    streak = sim.images()["streaks"][0]  # dir (1, 0): the streak runs to -x
    np.testing.assert_allclose(streak[8, 8 - np.arange(4), 0], [1.0, 1.0, 0.98, 0.686], atol=1e-6)


def demo_ref(W: int, H: int, spheres: np.ndarray, albedo: np.ndarray) -> np.ndarray:
    """The demo frame (H, W, 4) in float64: the Sample's camera (at (0, 0, -2) looking along +z, vertical FOV 30
    degrees) casting a ray through every pixel centre; the nearest sphere is lit by the Sample's directional light
    (colour (1, 0.957, 0.839) x 0.87, Euler (50, -30, 0): towards the light is (cos 50 sin 30, sin 50,
    -cos 50 cos 30)) with an ambient 0.06, Lambert and Blinn-Phong (specular 3, shininess 64); black elsewhere."""
    u, v = centres(W, H)
    t = math.tan(math.radians(15.0))
    ray = np.stack([(2 * u - 1) * t * W / H, (2 * v - 1) * t, np.ones_like(u)], axis=-1)
    ray /= np.linalg.norm(ray, axis=-1, keepdims=True)
    eye = np.array([0.0, 0.0, -2.0])
    nearest, hit = np.full(u.shape, np.inf), np.full(u.shape, -1)
    for i, sphere in enumerate(spheres.astype(np.float64)):
        oc = eye - sphere[:3]
        b = ray @ oc
        disc = b * b - (oc @ oc - sphere[3] ** 2)
        with np.errstate(invalid="ignore"):
            dist = -b - np.sqrt(disc)
        closer = (disc >= 0) & (dist > 0) & (dist < nearest)
        nearest, hit = np.where(closer, dist, nearest), np.where(closer, i, hit)
    a50, a30 = math.radians(50.0), math.radians(30.0)
    light = np.array([math.cos(a50) * math.sin(a30), math.sin(a50), -math.cos(a50) * math.cos(a30)])
    colour = 0.87 * np.array([1.0, 0.957, 0.839])
    n = eye + np.where(np.isfinite(nearest), nearest, 0.0)[..., None] * ray - spheres[hit, :3]
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    half = light - ray
    half /= np.linalg.norm(half, axis=-1, keepdims=True)
    diffuse = np.maximum(n @ light, 0.0)
    highlight = np.where(diffuse > 0, 3.0 * np.maximum(np.sum(n * half, axis=-1), 0.0) ** 64, 0.0)
    rgb = albedo[hit, :3] * (0.06 + diffuse[..., None] * colour) + highlight[..., None] * colour
    out = np.zeros((H, W, 4))
    out[..., :3] = np.where((hit >= 0)[..., None], rgb, 0.0)
    out[..., 3] = 1.0
    return out


def test_demo_scene_is_the_samples_camera_and_light(runtime):
    """DemoScene against demo_ref: every sphere where the Sample's pinhole camera sees it, lit from the Sample's
    light; float32 and float64 may disagree about a pixel on a silhouette, nowhere else."""
    W, H = 96, 64
    sim = Simulation(runtime, Params(width=W, height=H, divide=2, spheres=24), seed=3)
    sim.frame(0.5)
    src = sim.images()["src"]
    spheres, albedo = demo_spheres(24, 3, 0.5, W / H)
    want = demo_ref(W, H, spheres, albedo)
    covered = want[..., :3].any(axis=-1)
    assert 0.05 < covered.mean() < 0.5, "the spheres fill some of the frame"
    off = np.abs(src - want).max(axis=-1) > 1e-3 * np.maximum(1.0, want.max(axis=-1))
    assert off.mean() <= 0.01, f"{off.sum()} of {off.size} pixels differ from the reference"
    assert src[..., :3].max() > 1.0, "the glints come from specular highlights exceeding 1.0"


# }}}

# {{{ rules


def test_nothing_above_threshold_leaves_the_source_clamped(runtime, tmp_path, seed):
    src = random_hdr((30, 40), seed, top=0.9)
    sim = make(runtime, tmp_path, src, threshold=0.9, divide=2)
    for mode in COMPOSITE_TYPES:
        sim.update(composite_type=mode)
        sim.star_glow()
        images = sim.images()
        assert not images["bright"].any() and not images["comp"].any()
        expected = np.zeros_like(src) if mode == "debug" else np.clip(src, 0, 1)
        np.testing.assert_array_equal(images["dst"], expected, err_msg=mode)


def test_screen_never_exceeds_additive_and_modes_stay_in_range(runtime, tmp_path, seed):
    sim = make(runtime, tmp_path, random_hdr((30, 40), seed, top=2.0), threshold=0.5, divide=2, iteration=2)
    dst = {}
    for mode in COMPOSITE_TYPES:
        sim.update(composite_type=mode)
        sim.star_glow()
        dst[mode] = sim.images()["dst"]
    assert (dst["screen"] <= dst["additive"] + 1e-6).all()
    assert (dst["colored_screen"] <= dst["colored_additive"] + 1e-6).all()
    for mode in COMPOSITE_TYPES[:4]:
        assert dst[mode].min() >= 0.0 and dst[mode].max() <= 1.0, mode
    assert dst["debug"].max() > 1.0  # the glow alone, unclamped


def book_streak_angles(num_of_streak: int, angle_of_streak: float) -> np.ndarray:
    """Where the book's streaks land, degrees counter-clockwise from +x in uv (y up), written from section 4.2 and
    4.3 without the scene's code: StarGlow.cs sets the offset of direction x = 1..numOfStreak to
    (Quaternion.AngleAxis(angle * x + angleOfStreak, Vector3.forward) * Vector2.down).normalized with
    angle = 360 / numOfStreak (the sample's script; the chapter's listing shows the rotation in a comment), and "the
    streak stretches opposite to the offset given" (4.2). Unity's Quaternion * Vector3 is written out:
    v' = v + 2 w (q x v) + 2 q x (q x v), q = (axis sin(a/2), cos(a/2))."""
    angles = []
    for x in range(1, num_of_streak + 1):
        half = math.radians(360.0 / num_of_streak * x + angle_of_streak) / 2
        q, w = np.array([0.0, 0.0, math.sin(half)]), math.cos(half)  # Vector3.forward = (0, 0, 1)
        down = np.array([0.0, -1.0, 0.0])  # Vector2.down
        t = 2 * np.cross(q, down)
        offset = down + w * t + np.cross(q, t)
        offset /= np.linalg.norm(offset)
        angles.append(math.degrees(math.atan2(-offset[1], -offset[0])) % 360)  # the streak: -offset
    return np.sort(angles)


def measured_streak_angles(image: np.ndarray, centre, inner: float, outer: float) -> np.ndarray:
    """Angles (degrees from +x, counter-clockwise, GL rows: y up) of the arms of a star around ``centre`` (x, y)
    in a single-channel image: the intensity summed along rays from ``inner`` to ``outer`` texels (bilinear, every
    1/4 degree), cut into arcs where it exceeds a quarter of its maximum, each arc's intensity-weighted circular
    mean."""
    phi = np.radians(np.arange(0.0, 360.0, 0.25))
    radius = np.arange(inner, outer + 1e-9, 0.5)[:, None]
    x, y = centre[0] + radius * np.cos(phi), centre[1] + radius * np.sin(phi)
    profile = ndimage.map_coordinates(image.astype(np.float64), [y, x], order=1).sum(axis=0)
    lit = profile > 0.25 * profile.max()
    assert not lit.all(), "no gap between the arms"
    start = np.flatnonzero(~lit)[0]  # begin on a dark ray so that no arc wraps around 0
    lit, profile, phi = (np.roll(a, -start) for a in (lit, profile, phi))
    edges = np.diff(np.concatenate([[0], lit.astype(int), [0]]))
    arcs = zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1), strict=True)
    angles = [np.angle((profile[b:e] * np.exp(1j * phi[b:e])).sum(), deg=True) % 360 for b, e in arcs]
    return np.sort(angles)


@pytest.mark.parametrize("variant", ["book", "fused"])
@pytest.mark.parametrize(
    "num_of_streak, angle_of_streak",
    [(5, 30.0), (4, 0.0), (7, 10.0)],  # the Sample scene's 5 at 30 degrees, the script's default 4 at 0, an odd 7
)
def test_streaks_land_at_the_books_angles(runtime, tmp_path, variant, num_of_streak, angle_of_streak):
    """One bright texel in the middle of a dark 160 x 160 frame, rendered at divide 1, three passes (64-texel arms,
    attenuation 0.97 so the far ends still show): the arms measured in the output image (dst, additive), between 12
    and 56 texels from the texel, lie at the book's angles to 0.5 degrees (measured: within 0.11 degrees; a wrong
    sign of angleOfStreak moves the Sample's arms by 12 degrees, a streak on the wrong side by 36)."""
    size, centre = 160, (80, 80)
    sim = make(
        runtime,
        tmp_path,
        impulse(size, centre),
        threshold=0.0,
        intensity=1.0,
        divide=1,
        iteration=3,
        attenuation=0.97,
        num_of_streak=num_of_streak,
        angle_of_streak=angle_of_streak,
        variant=variant,
    )
    dst = sim.images()["dst"][..., 0]
    got, want = measured_streak_angles(dst, centre, 12.0, 56.0), book_streak_angles(num_of_streak, angle_of_streak)
    assert len(got) == num_of_streak, f"{len(got)} arms at {np.round(got, 2)}; the book's {np.round(want, 2)}"
    error = np.abs((got[:, None] - want[None, :] + 180) % 360 - 180).min(axis=0)  # each book arm's nearest
    assert error.max() <= 0.5, f"arms at {np.round(got, 2)} degrees; the book's {np.round(want, 2)}"


def test_sizes_and_launches_follow_the_book(runtime):
    sim = Simulation(runtime, Params(width=1920, height=1080, divide=7, spheres=1), seed=0)
    assert (sim.w, sim.h) == (274, 154)
    assert sim.stats()["launches per frame"] == 1 + 2 + 4 * (5 + 1)  # demo, passes 1 and 4, 4 x (5 streaks, blend)


# ranges and limits: tests/test_params.py checks them for every field of every scene
@pytest.mark.parametrize(
    "values, words",
    [
        ({"composite_type": "multiply"}, "composite_type must be one of additive|screen|"),
        ({"input": "picture.bmp"}, "input must be demo or a .png/.npy file"),
    ],
)
def test_bad_parameters_name_themselves(values, words):
    with pytest.raises(ValueError, match=re.escape(words)):
        Params(**values)


def _npy(shape, dtype, body_bytes=None) -> bytes:
    """A .npy header for ``shape`` and ``dtype`` and ``body_bytes`` zero bytes (default: the whole array)."""
    import io

    dtype = np.dtype(dtype)
    f = io.BytesIO()
    header = {"descr": np.lib.format.dtype_to_descr(dtype), "fortran_order": False, "shape": shape}
    np.lib.format.write_array_header_1_0(f, header)
    return f.getvalue() + bytes(int(np.prod(shape)) * dtype.itemsize if body_bytes is None else body_bytes)


def _png_header(width, height) -> bytes:
    import struct
    import zlib

    ihdr = b"IHDR" + struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + struct.pack(">I", 13) + ihdr + struct.pack(">I", zlib.crc32(ihdr))


BAD_IMAGES = [
    ("empty.npy", b"", "is empty"),
    (
        "struct.npy",
        _npy((4, 4, 3), [("a", "<f4"), ("b", "<i4")]),
        "holds [('a', '<f4'), ('b', '<i4')] values; an image",
    ),
    ("complex.npy", _npy((4, 4, 3), np.complex64), "holds complex64 values; an image holds floats or integers"),
    ("object.npy", _npy((4, 4, 3), object), "holds object values; an image holds floats or integers"),
    ("flat.npy", _npy((4, 4), np.float32), "an array of shape (4, 4); an image is (height, width, 3 or 4)"),
    ("five.npy", _npy((4, 4, 5), np.float32), "an array of shape (4, 4, 5); an image is (height, width, 3 or 4)"),
    ("none.npy", _npy((0, 4, 3), np.float32), "a 4x0 image; each side must be 1 to 8192 pixels"),
    ("huge.npy", _npy((100000, 100000, 3), np.float32, 64), "a 100000x100000 image; each side must be 1 to 8192"),
    ("short.npy", _npy((8, 8, 3), np.float32, 700), "truncated (828 bytes, its header needs 896)"),
    (
        "junk.npy",
        b"not numpy",
        "not a .npy array (the magic string is not correct; expected b'\\x93NUMPY', got b'not nu')",
    ),
    ("junk.png", b"hello, not a png", "not a PNG file (no PNG signature and IHDR header)"),
    ("bomb.png", _png_header(14000, 14000) + bytes(100), "a 14000x14000 image; each side must be 1 to 8192 pixels"),
    ("cut.png", _png_header(8000, 8000) + bytes(100), "cannot decode the PNG ("),
]


@pytest.mark.parametrize("name, data, message", BAD_IMAGES)
def test_bad_image_files_are_refused_in_one_line_before_decoding(tmp_path, name, data, message):
    path = tmp_path / name
    path.write_bytes(data)
    with pytest.raises(ValueError) as err:
        Params(input=str(path))
    assert str(err.value).startswith(f"input {path}: {message}"), str(err.value)


def test_non_finite_images_and_a_folder_are_refused(tmp_path):
    np.save(tmp_path / "nan.npy", np.full((4, 4, 3), np.nan, np.float32))
    with pytest.raises(ValueError, match="nan.npy: holds NaN or inf$"):
        Params(input=str(tmp_path / "nan.npy"))
    (tmp_path / "d.png").mkdir()
    with pytest.raises(ValueError, match="d.png: is a folder, not a file$"):
        Params(input=str(tmp_path / "d.png"))
    np.save(tmp_path / "small.npy", np.ones((2, 2, 3), np.float32))
    with pytest.raises(ValueError, match="small.npy: a 2x2 image leaves no glow image at divide=3$"):
        Params(input=str(tmp_path / "small.npy"))


def test_png_input_is_read_top_row_first_and_scaled(runtime, tmp_path):
    from PIL import Image

    pixels = np.zeros((12, 20, 3), np.uint8)
    pixels[2, 15] = 255  # near the top right of the file
    Image.fromarray(pixels).save(tmp_path / "in.png")
    sim = Simulation(runtime, Params(input=str(tmp_path / "in.png"), input_gain=3.0, divide=1), seed=0)
    state = sim.state()
    assert state["src"].shape == (12, 20, 4) and state["src"][2, 15, 0] == 3.0
    assert sim.images()["src"][12 - 1 - 2, 15, 0] == 3.0  # GL order inside
    assert state["comp"][2, 15, 0] > 0.9  # it glows (threshold 1 < 3)


# }}}

# {{{ fused variant


@pytest.mark.parametrize("iteration", [1, 2, 3])
def test_fused_variant_equals_the_book_launches(runtime, seed, iteration):
    p = dict(width=96, height=64, divide=2, num_of_streak=6, iteration=iteration, angle_of_streak=17.0)
    book = Simulation(runtime, Params(**p, attenuation=0.9, save_streaks=True), seed)
    fused = Simulation(runtime, Params(**p, attenuation=0.9, save_streaks=True, variant="fused"), seed)
    for _ in range(2):
        book.step()
        fused.step()
    a, b = book.images(), fused.images()
    assert a["comp"].max() > 0.5  # the demo glows
    for name in ("src", "bright", "comp", "dst", "streaks"):
        np.testing.assert_allclose(b[name], a[name], rtol=1e-6, atol=1e-6, err_msg=name)
    assert fused.stats()["launches per frame"] == iteration + 3


# }}}

# {{{ headless CLI


def test_run_writes_the_spec_arrays_and_a_png(tmp_path, capsys):
    out, png = tmp_path / "x.npz", tmp_path / "x.png"
    sets = ["width=160", "height=90", "divide=3", "spheres=12"]
    code, text = run_cli(
        capsys,
        "run",
        "star_glow",
        "--steps",
        "3",
        "--out",
        str(out),
        "--png",
        str(png),
        "--png-size",
        "160x90",
        "--set",
        *sets,
    )
    assert code == 0, text
    with np.load(out) as data:
        assert data["src"].shape == data["dst"].shape == (90, 160, 4)
        assert data["bright"].shape == data["comp"].shape == (30, 53, 4)
        assert data["streak_dirs"].shape == (5, 2)
        assert '"intensity": 1.3' in str(data["params"])  # the Sample scene's values
        assert data["src"].max() > 1.0 and data["dst"].max() <= 1.0
        dst = data["dst"]
    from PIL import Image

    pixels = np.asarray(Image.open(png).convert("RGB"), np.float64) / 255
    # the PNG is the GL passes on the same source: equal to the kernels' dst up to 8-bit rounding
    assert np.abs(pixels - dst[..., :3]).max() <= 1.5 / 255, compare_images(pixels, dst[..., :3], 1.5 / 255)


# }}}

# {{{ GL passes and the view


@pytest.mark.parametrize("mode", COMPOSITE_TYPES)
def test_gl_passes_match_the_kernels(gl, runtime, tmp_path, seed, mode):
    from ugpcl.viewer.postfx import FloatTarget, float_texture
    from ugpcl.viewer.views.star_glow import GLStarGlow

    src = random_hdr((144, 256), seed, top=3.0)
    sim = make(runtime, tmp_path, src, divide=3, composite_type=mode, attenuation=0.8, iteration=3, angle_of_streak=10)
    glow, source, out = GLStarGlow(gl), float_texture(gl, src), FloatTarget(gl, (256, 144))
    try:
        glow.run(source, sim.params, out)
        images = sim.images()
        assert images["comp"].max() > 0.5 and images["bright"].max() > 1.0  # streaks from HDR input to compare
        # The GL bound (2e-3). Both sides address texels through float32 uv, but GL interpolates its uv
        # across the triangle (llvmpipe: ~1e-5 texel off the kernel's), so a bilinear tap of neighbours that differ
        # by 3 moves by up to ~1e-4 (measured: bright 8e-5, comp and dst 2.4e-7); a wrong weight, direction, clamp
        # or mode moves a texel by far more. A GPU's texture unit rounds the bilinear weights (1/512 on an H100:
        # linear_filter_error), worth up to 2 x 3 x that error per tap of bright, passed on 4x per streak pass.
        results = {"bright": glow.bright.read(), "comp": glow.comp.read(), "dst": out.read()}
        filtering = 6 * linear_filter_error(gl)  # last: it leaves no framebuffer bound
        tolerances = {"bright": 2e-3 + filtering, "comp": 2e-3 + filtering * 4**3, "dst": 2e-3 + filtering * 4**3}
        for name, got in results.items():
            error, tolerance = np.abs(got - images[name]).max(), tolerances[name]
            assert error <= tolerance, f"{name}: {compare_images(got, images[name], tolerance)}"
    finally:
        for obj in (glow, source, out):
            obj.release()


def test_view_keys_and_debug_displays(gl, runtime):
    from ugpcl.viewer.views import view_class

    scene = get("star_glow")
    sim = scene.create(runtime, 0, width=160, height=90, spheres=12, divide=2)
    images = sim.images()
    assert images["comp"].max() > 0.5  # streaks to see
    u, v = centres(160, 90)
    for display, image in (
        ("glow", "dst"),
        ("source", "src"),
        ("bright", "bright"),
        ("comp", "comp"),
        ("opencl", "dst"),
    ):
        pixels, _, view, _ = render_view(gl, "star_glow", sim, size=(160, 90), display=display)
        # each display is its image stretched over the frame (a bilinear copy), top row first, clamped to 8 bits
        expected = np.clip(sample(images[image], u, v)[::-1, :, :3], 0, 1) * 255
        assert np.abs(pixels - expected).max() <= 2.0, f"{display}: {compare_images(pixels, expected, 2.0)}"
    for key in view_class(scene).keys:  # every key's action runs and leaves valid parameters
        getattr(view, key.action)()
    assert view.sim.params.num_of_streak == 9 and view.display == "opencl"


# }}}


@pytest.mark.oclgrind
def test_kernels_on_oclgrind(oclgrind, seed):
    p = dict(width=40, height=24, divide=2, num_of_streak=3, iteration=2, spheres=3, save_streaks=True)
    book = Simulation(oclgrind, Params(**p), seed)  # DemoScene, Brightness, Streak, ScreenAccumulate, Composite
    fused = Simulation(oclgrind, Params(**p, variant="fused"), seed)  # StreakAllDirections, StreakAccumulate
    for name in ("comp", "dst", "streaks"):
        np.testing.assert_allclose(fused.images()[name], book.images()[name], rtol=1e-6, atol=1e-6, err_msg=name)
