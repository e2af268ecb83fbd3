"""Kleinian limit sets (vol.4 ch.2): the kernels of clkernels/kleinian.cl against a float32 numpy
port of the book's josKleinian, the properties of the limit set (golden points, periodicity, symmetries, monotone in
the iteration budget), the passes' colours, the GLSL shader against the kernel, adaptive anti-aliasing, the double
variant, the animation curves, the headless CLI and Oclgrind."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import run_cli

from ugpcl.registry import get
from ugpcl.scenes.kleinian import CLIP, CLIP_LENGTH, CLIP_TIMES, Params, clip_at, flat_curve, uv_at

# {{{ numpy reference: KleinianGroup.shader's josKleinian, float32, the shader's operation order (book 2.6)

F = np.float32


def line3_np(x, u, v):
    d = x + F(v) * F(0.5)
    k = -(F(7.2) - (F(1.95) - F(u)) * F(15.0))
    return F(u) * F(0.5) + F(np.sign(v)) * (F(2.0) * F(u) - F(1.95)) / F(4.0) * np.sign(d) * (
        F(1.0) - np.exp(k * np.abs(d))
    )


def jos_kleinian_np(zx, zy, u, v, iteration):
    """(hit bool, iterations) per point, float32 like the shader."""
    zx, zy = np.array(zx, F), np.array(zy, F)
    u, v = F(u), F(v)
    lzx, lzy, llzx, llzy = zx + F(1), zy + F(1), zx - F(1), zy - F(1)
    hit = np.zeros(zx.shape, bool)
    iters = np.full(zx.shape, iteration, np.int32)
    live = np.ones(zx.shape, bool)
    with np.errstate(all="ignore"):
        for i in range(iteration):
            offset_x = np.abs(v) / u * zy
            x = zx + offset_x
            x = x + F(1)  # wrap(x, 2, -1)
            x = (x - F(2) * np.floor(x / F(2))) + F(-1)
            zx = np.where(live, x - offset_x, zx)
            above = live & (zy >= line3_np(zx, u, v))
            zx, zy = np.where(above, -v - zx, zx), np.where(above, u - zy, zy)
            d = zx * zx + zy * zy
            nx, ny = zx / d + -v, -zy / d + u  # TransA
            zx, zy = np.where(live, nx, zx), np.where(live, ny, zy)
            now_hit = live & (zy < 0)
            cycle = live & ~now_hit & (np.sqrt((zx - llzx) ** 2 + (zy - llzy) ** 2) < F(1e-6))
            hit |= now_hit
            iters = np.where(now_hit | cycle, i + 1, iters)
            live &= ~(now_hit | cycle)
            llzx, llzy = np.where(live, lzx, llzx), np.where(live, lzy, llzy)
            lzx, lzy = np.where(live, zx, lzx), np.where(live, zy, lzy)
            if not live.any():
                break
    return hit, iters


def pixel_points_np(width, height, scale, offset, mode=0):
    """World points of the pixel centres (H, W), row 0 = bottom, as the shader maps i.uv."""
    x, y = np.meshgrid(np.arange(width, dtype=F), np.arange(height, dtype=F))
    px = (x + F(0.5)) / F(width) * (F(width) / F(height))
    py = (y + F(0.5)) / F(height)
    if mode == 2:
        return px * F(scale) + F(offset[0]), py * F(scale) + F(offset[1])
    return (px + F(offset[0])) * F(scale), (py + F(offset[1])) * F(scale)


# }}}


def simulation(runtime, **overrides):
    return get("kleinian").create(runtime, **{"use_uv_animation": False, **overrides})


def neighbours_differ(a: np.ndarray) -> np.ndarray:
    """Pixels with a 4-neighbour of another value."""
    out = np.zeros(a.shape, bool)
    out[1:] |= a[1:] != a[:-1]
    out[:-1] |= a[:-1] != a[1:]
    out[:, 1:] |= a[:, 1:] != a[:, :-1]
    out[:, :-1] |= a[:, :-1] != a[:, 1:]
    return out


# {{{ points: golden values, periodicity, symmetries

GOLDEN_HITS = [(0.0, 0.25), (2.0, 0.25), (0.0, 1.75)]
GOLDEN_MISSES = [(1.0, 1.0), (0.5, 0.5), (1.0, 0.05), (-1.0, 1.0)]


@pytest.mark.parametrize("precision", ["float", "double"])
def test_golden_points_at_t_2_0(runtime, precision):
    sim = simulation(runtime, precision=precision)
    points = np.array(GOLDEN_HITS + GOLDEN_MISSES)
    hit, iters = sim.classify_points(points, 2.0, 0.0, 50)
    assert hit.tolist() == [1, 1, 1, 0, 0, 0, 0]
    _, expected = jos_kleinian_np(points[:, 0], points[:, 1], 2.0, 0.0, 50)
    # (0, 0.25), the centre of the largest disk, is a hit after one step; (2, 0.25) wraps onto it exactly
    assert iters.tolist() == expected.tolist() == [1, 1, 1, 3, 4, 5, 3]


def random_band_points(rng, n, u):
    return np.stack([rng.uniform(-1, 1, n), rng.uniform(0, u, n)], axis=1).astype(F)


@pytest.mark.parametrize(("t", "tolerance"), [((2.0, 0.0), 0.0), ((1.94, 0.02), 0.001)])
def test_periodic_in_x_with_period_2(runtime, seed, t, tolerance):
    sim = simulation(runtime)
    points = random_band_points(np.random.default_rng(seed), 200_000, t[0])
    shifted = points + np.array([2.0, 0.0], F)
    a, _ = sim.classify_points(points, *t)
    b, _ = sim.classify_points(shifted, *t)
    # x + 2 rounds in float32, so off t = (2, 0) a point on a fine boundary may flip (spec: measured 0.03 %)
    assert (a != b).mean() <= tolerance, f"{(a != b).mean():.5f} of points differ from their x + 2 twin"
    assert 0.05 < a.mean() < 0.95


def test_mirror_and_point_symmetry_at_v_0(runtime, seed):
    u = 2.0
    sim = simulation(runtime)
    points = random_band_points(np.random.default_rng(seed), 200_000, u)
    hit, _ = sim.classify_points(points, u, 0.0)
    mirrored, _ = sim.classify_points(points * np.array([-1, 1], F), u, 0.0)
    turned, _ = sim.classify_points(np.array([0.0, u], F) - points, u, 0.0)
    # the wrap adds 1 to x, which rounds differently for x and -x: a point on a fine boundary may flip (measured:
    # 1 of 200 000 for the mirror); "exact" holds for the maths, not for every float32 point
    assert (hit != mirrored).mean() <= 1e-4, f"{(hit != mirrored).mean():.5f} differ from hit(-x, y)"
    assert (hit != turned).mean() <= 1e-4, f"{(hit != turned).mean():.5f} differ from hit((-v, u) - z)"


def test_point_symmetry_at_an_interesting_t(runtime, seed):
    u, v = 1.94, 0.02
    sim = simulation(runtime)
    points = random_band_points(np.random.default_rng(seed), 200_000, u)
    hit, _ = sim.classify_points(points, u, v)
    turned, _ = sim.classify_points(np.array([-v, u], F) - points, u, v)
    assert (hit != turned).mean() <= 0.001  # Line3 is a fit (book 2.6); spec measured 0.0125 %


def test_classify_matches_the_numpy_port(runtime, seed):
    u, v = 1.94, 0.02
    points = random_band_points(np.random.default_rng(seed), 20_000, u)
    hit, iters = simulation(runtime).classify_points(points, u, v)
    expected_hit, expected_iters = jos_kleinian_np(points[:, 0], points[:, 1], u, v, 50)
    # the same operations in float32; exp and the division may differ by an ulp near the boundary
    assert (hit != expected_hit).mean() <= 0.002
    assert (iters != expected_iters).mean() <= 0.005


# }}}

# {{{ frames


@pytest.mark.parametrize(
    ("u", "v", "fraction"), [(2.0, 0.0, 0.1219), (1.9864494, 0.0063085477, 0.1314), (1.94, 0.02, 0.310)]
)
def test_mode_0_matches_the_numpy_reference(runtime, u, v, fraction):
    sim = simulation(runtime, width=320, height=180, u=u, v=v)
    image = sim.render_kleinian()
    x, y = pixel_points_np(320, 180, 1.9, (0.0, 0.0))
    expected, _ = jos_kleinian_np(x, y, u, v, 50)
    hit = image["hit"].astype(bool)
    assert (hit != expected).mean() <= 0.002, f"{(hit != expected).mean():.4%} of pixels differ from numpy"
    assert abs(hit.mean() - fraction) <= 0.003, f"hit fraction {hit.mean():.4f}, spec {fraction}"
    assert abs(expected.mean() - fraction) <= 0.003


def test_monotone_in_iteration(runtime):
    sim = simulation(runtime, width=160, height=90, u=1.94, v=0.02)
    few = sim.render_kleinian(iteration=50)["hit"].astype(bool)
    many = sim.render_kleinian(iteration=500)["hit"].astype(bool)
    assert not (few & ~many).any(), "a hit within 50 steps must stay a hit with 500 (same orbit, early exits)"
    assert many.sum() > few.sum()


def test_mode_0_colours_are_exactly_the_two_colours(runtime):
    sim = simulation(runtime, width=160, height=90, u=1.94, v=0.02)
    image = sim.render_kleinian()
    rgba, hit = image["rgba"], image["hit"].astype(bool)
    assert (rgba[hit] == np.array(sim.params.hit_color, F)).all()
    assert (rgba[~hit] == np.array(sim.params.back_color, F)).all()
    assert np.isfinite(rgba).all()
    assert image["iters"].min() >= 1 and image["iters"].max() <= 50


@pytest.mark.parametrize(("mode", "n"), [(1, 20), (2, 10)])
@pytest.mark.parametrize("hash_", ["portable", "sin"])
def test_multisample_colours_are_k_over_n_mixes(runtime, mode, n, hash_):
    scene = "kleinian_inverse" if mode == 2 else "kleinian"
    sim = get(scene).create(runtime, width=96, height=54, mode=mode, hash=hash_)
    sim.step(1.0)
    image = sim.render_kleinian()
    k = image["hit"].astype(F)
    assert k.max() <= n and sim.params.effective_samples == n
    back, hit = np.array(sim.params.back_color, F), np.array(sim.params.hit_color, F)
    expected = back + (k / n)[..., None] * (hit - back)
    assert np.abs(image["rgba"] - expected).max() <= 1e-6
    assert 0 < (k % n != 0).mean() < 0.5, "some pixels, not all, mix the two colours"


def test_mode_2_without_jitter_classifies_the_inverted_point(runtime):
    sim = simulation(runtime, width=160, height=90, mode=2, samples=1, jitter=0.0, circle=(0.0, 0.0), circle_w=1.0)
    hit = sim.render_kleinian()["hit"].astype(bool)
    x, y = pixel_points_np(160, 90, 1.9, (0.0, 0.0), mode=2)
    d = x * x + y * y
    expected, _ = sim.classify_points(np.stack([x / d, y / d], axis=-1).reshape(-1, 2), 2.0, 0.0)
    assert (hit != expected.reshape(hit.shape).astype(bool)).mean() <= 0.002


def test_double_and_float_agree_at_shallow_zoom(runtime):
    if "cl_khr_fp64" not in runtime.device.extensions:
        pytest.skip("the device has no cl_khr_fp64")  # PoCL has it: this runs in CI
    sim = simulation(runtime, width=160, height=90, u=1.94, v=0.02)
    single = sim.render_kleinian()["hit"]
    double = sim.render_kleinian(precision="double")["hit"]
    differ = single != double
    assert differ.mean() <= 0.005
    assert (neighbours_differ(single) | neighbours_differ(double))[differ].all(), "differences only on the boundary"


def test_double_resolves_a_deep_zoom_that_float_cannot(runtime):
    if "cl_khr_fp64" not in runtime.device.extensions:
        pytest.skip("the device has no cl_khr_fp64")
    # (0.5458834805, 0.25) lies on the boundary at t = (1.94, 0.02) (bisection with 500 steps in double). At scale
    # 1e-6 a pixel is ~3e-8 world units, an ulp of float32 there: float repeats columns, double does not.
    x, y, scale = 0.5458834805471363, 0.25, 1e-6
    offset = (x / scale - 32 / 36, y / scale - 0.5)  # modes 0/1: world = (uv + offset) * scale
    sim = simulation(runtime, width=64, height=36, u=1.94, v=0.02, scale=scale, offset=offset, iteration=500)
    single = sim.render_kleinian()["iters"]
    double = sim.render_kleinian(precision="double")["iters"]
    distinct = lambda a: len({a[:, i].tobytes() for i in range(a.shape[1])})  # noqa: E731
    assert distinct(double) >= 60 and distinct(single) <= 32, (distinct(double), distinct(single))


def test_adaptive_changes_only_nonuniform_pixels(runtime):
    sim = simulation(runtime, width=160, height=90, u=1.94, v=0.02, mode=1)
    full = sim.render_kleinian()
    centre = sim.render_kleinian(mode=0)
    adaptive = sim.render_kleinian(adaptive=True)
    assert (adaptive["centre_hit"] == centre["hit"]).all(), "the centre pass is mode 0's picture"
    nonuniform = np.zeros(centre["hit"].shape, bool)
    padded = np.pad(centre["hit"], 1, mode="edge")
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            nonuniform |= padded[1 + dy : 1 + dy + 90, 1 + dx : 1 + dx + 160] != centre["hit"]
    assert (adaptive["rgba"][nonuniform] == full["rgba"][nonuniform]).all()
    assert (adaptive["rgba"][~nonuniform] == centre["rgba"][~nonuniform]).all()
    assert 0.02 < nonuniform.mean() < 0.6
    # the approximation costs little: most uniform pixels are uniform in the full picture too
    assert (adaptive["rgba"] != full["rgba"]).any(axis=-1).mean() < 0.05


def test_adaptive_centre_pass_of_mode_2_classifies_the_inverted_point(runtime):
    """frag_circle_inverse's centre sample inverts the pixel in the circle before josKleinian, in the adaptive
    centre pass too: mode 0's uninverted centres would mark about half of these pixels wrongly."""
    p = {"circle": (0.0, 0.0), "circle_w": 1.0, "scale": 4.0}  # about half the pixels change class by the inversion
    sim = simulation(runtime, width=80, height=45, mode=2, samples=2, adaptive=True, **p)
    centre = sim.render_kleinian()["centre_hit"].astype(bool)
    x, y = pixel_points_np(80, 45, 4.0, (0.0, 0.0), mode=2)
    d = x * x + y * y
    expected, _ = sim.classify_points(np.stack([x / d, y / d], axis=-1).reshape(-1, 2), 2.0, 0.0)
    assert (centre != expected.reshape(centre.shape).astype(bool)).mean() <= 0.005


# }}}

# {{{ animation (KleinianGroup.cs curves, KleinianGroupCircleInverse.anim)


def test_flat_tangent_curves_are_smoothsteps():
    assert flat_curve((0.0, 2.0), (1.0, 3.0), 1.0) == pytest.approx(2.0)
    assert flat_curve((0.0, 2.0), (1.0, 3.0), 0.5) == pytest.approx(1.0 + 2.0 * (3 * 0.25**2 - 2 * 0.25**3))
    assert flat_curve((0.0, 2.0), (1.0, 3.0), 5.0) == 3.0  # clamped after the last key


def test_uv_curves_hold_after_one_second_and_the_clip_loops():
    assert uv_at(1.0) == pytest.approx((1.939613, 0.02))
    assert uv_at(7.0) == uv_at(1.0)
    assert uv_at(0.5)[0] == pytest.approx((1.9879456 + 1.939613) / 2, abs=0.002)
    for i, time in enumerate(CLIP_TIMES):
        assert clip_at(time % CLIP_LENGTH)["offset_x"] == pytest.approx(CLIP["offset_x"][i % (len(CLIP_TIMES) - 1)])
    assert clip_at(3.0 + CLIP_LENGTH) == pytest.approx(clip_at(3.0))


def test_scene_frames_follow_the_clocks(runtime):
    sim = get("kleinian_inverse").create(runtime, width=32, height=18)
    for _ in range(60):
        sim.step(1 / 60)
    frame = sim.frame()
    assert frame["t"] == pytest.approx(uv_at(0.5))  # timeScale 0.5: script time = half the time
    assert frame["scale"] == pytest.approx(clip_at(1.0)["scale"])
    state = sim.state()
    assert state["t"].tolist() == pytest.approx(list(frame["t"]))
    assert state["circle"][3] == 1.0 and state["mode"] == 2 and state["samples"] == 10


def test_bad_parameters_name_the_field():
    # ranges: tests/test_params.py checks them for every field of every scene
    with pytest.raises(ValueError, match="mode must be one of"):
        Params(mode=3)


# }}}

# {{{ headless CLI


def test_run_writes_the_spec_arrays(capsys, tmp_path):
    out, png = tmp_path / "k.npz", tmp_path / "k.png"
    code, text = run_cli(
        capsys, "run", "kleinian", "--steps", "3", "--set", "width=64", "height=36", "u=1.94", "v=0.02",
        "use_uv_animation=false", "--out", str(out), "--png", str(png), "--png-size", "64x36", "--quiet",
    )  # fmt: skip
    assert code == 0, text
    with np.load(out) as data:
        assert data["rgba"].shape == (36, 64, 4) and data["rgba"].dtype == np.float32
        assert data["hit"].shape == (36, 64) and data["hit"].dtype == np.uint8
        assert data["iters"].dtype == np.int32
        assert data["t"].tolist() == pytest.approx([1.94, 0.02])
        for name, dtype in (("scale", F), ("offset", F), ("circle", F), ("time", F)):
            assert data[name].dtype == dtype
        assert int(data["mode"]) == 0 and int(data["iteration"]) == 50 and int(data["samples"]) == 1
        # top row first: the band starts at y = 0, the bottom of the picture, where the largest disks touch it
        assert data["hit"][-1].mean() > data["hit"][0].mean()
    from PIL import Image

    pixels = np.asarray(Image.open(png))
    assert pixels.shape[:2] == (36, 64) and len(np.unique(pixels.reshape(-1, pixels.shape[-1]), axis=0)) >= 2


# }}}

# {{{ view: the GLSL shader runs the same core


def render_shader(gl, sim, size=(320, 180)):
    from ugpcl.viewer.postfx import FloatTarget
    from ugpcl.viewer.views import create_view

    view = create_view(get("kleinian"), gl, sim)
    target = FloatTarget(gl, size)
    view.draw(view.make_camera(), target=target)
    pixels = target.read()
    target.release()
    return pixels


@pytest.mark.gl
def test_shader_matches_the_kernel_in_mode_0(runtime, gl):
    sim = simulation(runtime, width=320, height=180, u=1.94, v=0.02)
    shader = render_shader(gl, sim)
    kernel = sim.render_kleinian()["rgba"]
    differ = (shader != kernel).any(axis=-1)
    assert differ.mean() <= 0.005
    boundary = neighbours_differ((shader == kernel[0, 0]).all(-1)) | neighbours_differ(sim.render_kleinian()["hit"])
    assert boundary[differ].all(), "pixels differ only on the boundary of the limit set"


@pytest.mark.gl
@pytest.mark.parametrize("mode", [1, 2])
def test_shader_matches_the_kernel_in_modes_1_and_2(runtime, gl, mode):
    sim = get("kleinian_inverse" if mode == 2 else "kleinian").create(runtime, width=320, height=180, mode=mode)
    sim.step(0.5)
    shader = render_shader(gl, sim)
    kernel = sim.render_kleinian()["rgba"]
    assert np.abs(shader - kernel).mean(axis=(0, 1)).max() <= 0.01
    sim.update(hash="sin")  # sin of large arguments differs between GL and the CPU: compare the means
    shader, kernel = render_shader(gl, sim), sim.render_kleinian()["rgba"]
    assert np.abs(shader.mean(axis=(0, 1)) - kernel.mean(axis=(0, 1))).max() <= 0.01


@pytest.mark.gl
def test_overlay_draws_the_lines_of_figure_2_3(runtime, gl):
    # a centred view of t = (2, 0): world x = -2.4 .. 2.4, y = -0.15 .. 2.55 on 320 x 180 pixels
    scale, offset = 2.7, (-0.8889, -0.0556)
    sim = simulation(runtime, scale=scale, offset=offset, overlay=True)
    drawn = render_shader(gl, sim)
    plain = render_shader(gl, sim.__class__(runtime, sim.params.replace(overlay=False)))

    def near(x, y):
        """The 5 x 5 pixels around world point (x, y): (25, 4)."""
        col, row = int((x / scale - offset[0]) * 180), int((y / scale - offset[1]) * 180)
        return drawn[row - 2 : row + 3, col - 2 : col + 3].reshape(-1, 4)

    r, g, b = (near(1.0, 1.5)[:, i] for i in range(3))
    assert (r > b + 0.3).any(), "Line1 (red) through (1, 0) and (1 - v, u) = (1, 2)"
    r, g, b = (near(-1.0, 1.5)[:, i] for i in range(3))
    assert (b > r + 0.3).any(), "Line2 (blue) through (-1, 0) and (-1, 2)"
    r, g, b = (near(-0.5, 1.0)[:, i] for i in range(3))
    assert (g > r + 0.3).any(), "Line3 (green): y = u / 2 for v = 0"
    r, g, b = (near(0.0, 0.5)[:, i] for i in range(3))
    assert ((r > g + 0.3) & (b > g + 0.3)).any(), "the largest disk (magenta): centre (0, 1/(2u)), top at (0, 0.5)"
    inside, outside = (0.5, 1.5), (2.0, 2.45)  # in the parallelogram (filled lightly), outside it and off every line
    col, row = int((outside[0] / scale - offset[0]) * 180), int((outside[1] / scale - offset[1]) * 180)
    assert (drawn[row, col] == plain[row, col]).all()
    col, row = int((inside[0] / scale - offset[0]) * 180), int((inside[1] / scale - offset[1]) * 180)
    assert np.abs(drawn[row, col] - plain[row, col]).max() > 0.05, "the parallelogram is tinted"


# }}}


@pytest.mark.oclgrind
def test_kernels_run_clean_on_oclgrind(oclgrind):
    sim = get("kleinian").create(oclgrind, width=16, height=16, use_uv_animation=False, iteration=8, u=1.94, v=0.02)
    sim.classify_points(np.array(GOLDEN_HITS + GOLDEN_MISSES), iteration=8)
    image = sim.render_kleinian(mode=1, samples=2, adaptive=True)
    assert np.isfinite(image["rgba"]).all()
    image = sim.render_kleinian(mode=2, samples=2)
    assert image["hit"].max() <= 2
