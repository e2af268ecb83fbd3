"""Stable fluids 3D (vol.1 ch.4, Solver3D.compute; docs/chapters/04-stable-fluids-3d.md): every kernel against a numpy
float64 reference, the solver's invariants, the headless CLI, the ray-marched view, Oclgrind."""

from __future__ import annotations

import re

import numpy as np
import pytest
from helpers import first_mismatch, foreground

from ugpcl.registry import get
from ugpcl.runtime import KERNEL_DIR
from ugpcl.scenes.stable_fluids_3d import KERNELS, Params, Simulation

SIZES = [(19, 17, 13), (16, 16, 16), (3, 4, 5)]
"""(w, h, d): non-cubic and no multiple of the (8, 8, 4) work-group, cubic, the smallest grid."""
DT = 1.0 / 60.0
PUFF_FRAMES = 120
"""emitter_frames of the tests' puff (the 2D scene's scripted stroke holds the brush as long)."""

# {{{ numpy reference, float64, written from Solver3D.compute and the chapter page's kernel list
# (arrays are (d, h, w[, 4]))


def pad(f: np.ndarray) -> np.ndarray:
    """Zero ring around the grid: ld() reads 0 outside, as D3D's out-of-range texture reads."""
    return np.pad(f, [(1, 1)] * 3 + [(0, 0)] * (f.ndim - 3))


def neighbours(f: np.ndarray) -> np.ndarray:
    """Sum of the 6 face neighbours of every cell."""
    p = pad(f)
    return (
        p[1:-1, 1:-1, :-2]
        + p[1:-1, 1:-1, 2:]
        + p[1:-1, :-2, 1:-1]
        + p[1:-1, 2:, 1:-1]
        + p[:-2, 1:-1, 1:-1]
        + p[2:, 1:-1, 1:-1]
    )


def central(f: np.ndarray, axis: int) -> np.ndarray:
    """ld(f, +1) - ld(f, -1) along a grid axis (0 x, 1 y, 2 z)."""
    p = pad(f)
    inner = [slice(1, -1)] * 3
    hi, lo = list(inner), list(inner)
    hi[2 - axis], lo[2 - axis] = slice(2, None), slice(None, -2)
    return p[tuple(hi)] - p[tuple(lo)]


def boundary(f: np.ndarray, kind: str) -> np.ndarray:
    """SetBoundary<kind> (density, velocity, div, p): faces copy (velocity: negated normal component), then edges =
    mean of their 2 face neighbours, then corners = mean of their 3 edge neighbours. Works in f's dtype (float32:
    the kernels' arithmetic exactly, (a + b)*0.5 and (a + b + c)*(1/3))."""
    out = f.copy()
    half, third = f.dtype.type(0.5), f.dtype.type(1.0 / 3.0)
    comp = {"div": 1, "p": 0}.get(kind)

    def put(index, value):
        if comp is None:
            out[index] = value
        else:
            out[index + (comp,)] = value

    def get(index):
        return out[index] if comp is None else out[index + (comp,)]

    inner = slice(1, -1)
    for axis in range(3):  # faces; numpy axis of grid axis a is 2 - a
        for side, src in ((0, 1), (-1, -2)):
            target, source = [inner] * 3, [inner] * 3
            target[2 - axis], source[2 - axis] = side, src
            target, source = tuple(target), tuple(source)
            if kind == "velocity":
                out[target + (axis,)] = -f[source + (axis,)]
            else:
                put(target, get(source))
    for along in range(3):  # edges: the two other axes on the boundary
        o1, o2 = [a for a in range(3) if a != along]
        for s1, i1 in ((0, 1), (-1, -2)):
            for s2, i2 in ((0, 1), (-1, -2)):
                target, a, b = [None] * 3, [None] * 3, [None] * 3
                for idx, (v1, v2) in ((target, (s1, s2)), (a, (i1, s2)), (b, (s1, i2))):
                    idx[2 - along], idx[2 - o1], idx[2 - o2] = inner, v1, v2
                put(tuple(target), (get(tuple(a)) + get(tuple(b))) * half)
    for cx in (0, -1):  # corners: x-, y-, z-inward edge cells, summed in that order
        for cy in (0, -1):
            for cz in (0, -1):
                ix, iy, iz = (1 if c == 0 else -2 for c in (cx, cy, cz))
                value = (get((cz, cy, ix)) + get((cz, iy, cx)) + get((iz, cy, cx))) * third
                put((cz, cy, cx), value)
    return out


def brush_reference(shape, center, direction, radius) -> np.ndarray:
    d, h, w = shape
    z, y, x = np.meshgrid(np.arange(d), np.arange(h), np.arange(w), indexing="ij")
    uvw = np.stack([(x + 0.5) / w, (y + 0.5) / h, (z + 0.5) / d], axis=-1)
    q = (uvw - np.asarray(center)) / radius
    f = np.clip(1.0 - np.sum(q * q, axis=-1), 0.0, 1.0)
    return np.concatenate([np.asarray(direction) * f[..., None], f[..., None]], axis=-1)


def cells(shape) -> float:
    return float(np.prod(shape))


def diffuse_velocity_reference(velocity, prev, p: Params, dt=DT):
    a = dt * p.visc * cells(velocity.shape[:3])
    out = np.zeros(velocity.shape[:3] + (4,))
    out[..., :3] = (prev[..., :3] + a * neighbours(velocity[..., :3].astype(np.float64))) / (1 + 6 * a)
    return boundary(out, "velocity")


def diffuse_density_reference(density, prev, p: Params, dt=DT):
    a = dt * p.diff * cells(density.shape)
    return boundary((prev[..., 3] + a * neighbours(density.astype(np.float64))) / (1 + 6 * a), "density")


def project_step1_reference(velocity, prev, variant: str):
    d, h, w = velocity.shape[:3]
    v = velocity.astype(np.float64)
    du, dv, dw = (central(v[..., a], a) for a in range(3))
    if variant == "book":
        div = -0.5 * (du / w) + dv / h + dw / d  # the original's operator precedence
    else:
        div = -0.5 * (du / w + dv / h + dw / d)
    out = prev.astype(np.float64).copy()
    out[..., 0], out[..., 1] = 0.0, div
    return boundary(boundary(out, "div"), "p")


def project_step2_reference(prev):
    prev = prev.astype(np.float64)
    out = prev.copy()
    out[..., 0] = (prev[..., 1] + neighbours(prev[..., 0])) / 6.0
    return boundary(out, "p")


def project_step3_reference(velocity, prev):
    d, h, w = velocity.shape[:3]
    v = np.zeros(velocity.shape[:3] + (4,))
    v[..., :3] = velocity
    p = prev[..., 0].astype(np.float64)
    for axis, n in enumerate((w, h, d)):
        v[..., axis] -= 0.5 * central(p, axis) * n
    return boundary(v, "velocity")


def trilinear(field, b):
    """Sample field (d, h, w, c) at grid points b (..., 3) = (x, y, z), zero outside (book's s/t/u weights)."""
    p = pad(field.astype(np.float64))
    b0 = np.floor(b)
    s1, t1, u1 = (b - b0)[..., 0], (b - b0)[..., 1], (b - b0)[..., 2]
    x0, y0, z0 = (b0[..., i].astype(int) for i in range(3))
    # pad shifts indices by 1; anything beyond the zero ring reads the ring (also 0)
    d, h, w = field.shape[:3]

    def tap(x, y, z):
        return p[np.clip(z + 1, 0, d + 1), np.clip(y + 1, 0, h + 1), np.clip(x + 1, 0, w + 1)]

    s0, t0, u0 = 1 - s1, 1 - t1, 1 - u1
    e = (Ellipsis, None)
    return (
        (s0 * u0)[e] * (t0[e] * tap(x0, y0, z0) + t1[e] * tap(x0, y0 + 1, z0))
        + (s1 * u0)[e] * (t0[e] * tap(x0 + 1, y0, z0) + t1[e] * tap(x0 + 1, y0 + 1, z0))
        + (s0 * u1)[e] * (t0[e] * tap(x0, y0, z0 + 1) + t1[e] * tap(x0, y0 + 1, z0 + 1))
        + (s1 * u1)[e] * (t0[e] * tap(x0 + 1, y0, z0 + 1) + t1[e] * tap(x0 + 1, y0 + 1, z0 + 1))
    )


def back_trace(shape, velocity, variant: str, dt=DT):
    d, h, w = shape
    z, y, x = np.meshgrid(np.arange(d), np.arange(h), np.arange(w), indexing="ij")
    dfdt = dt * (w + h + d) / 3.0
    b = np.stack([x, y, z], axis=-1) - dfdt * velocity[..., :3].astype(np.float64)
    if variant == "fixed":
        b = np.clip(b, 0.5, np.array([w, h, d]) - 1.5)
    return b  # book: the original's clamp() result is dropped


def advect_velocity_reference(prev, variant: str):
    out = np.zeros(prev.shape)
    out[..., :3] = trilinear(prev, back_trace(prev.shape[:3], prev, variant))[..., :3]
    return boundary(out, "velocity")


def advect_density_reference(velocity, prev, variant: str):
    return boundary(trilinear(prev, back_trace(prev.shape[:3], velocity, variant))[..., 3], "density")


# }}}


def make(runtime, shape=(19, 17, 13), seed=0, **overrides) -> Simulation:
    w, h, d = shape
    return Simulation(runtime, Params(width=w, height=h, depth=d, **overrides), seed)


def random_fields(rng, shape, speed=1.0):
    w, h, d = shape
    velocity = rng.normal(0.0, speed, (d, h, w, 3)).astype(np.float32)
    density = rng.uniform(0.0, 1.0, (d, h, w)).astype(np.float32)
    prev = rng.normal(0.0, 1.0, (d, h, w, 4)).astype(np.float32)
    return velocity, density, prev


def smooth_field(rng, shape, channels: int, amplitude: float) -> np.ndarray:
    """(d, h, w, channels) float32: a few random sine modes with wavelengths of 4+ cells. Back-traces land between
    cells, so float32 rounding of the traced point (~1e-6 cells) moves a sample by ~1e-6 x the field's change per cell:
    smooth fields keep that inside the advection tolerance 1e-5, white noise (a change of ~amplitude per cell) would
    not."""
    w, h, d = shape
    z, y, x = np.meshgrid(np.arange(d), np.arange(h), np.arange(w), indexing="ij")
    out = np.zeros((d, h, w, channels))
    for c in range(channels):
        for _ in range(4):
            k = rng.uniform(-1.5, 1.5, 3)  # radians per cell: wavelengths >= 4 cells
            out[..., c] += np.sin(k[0] * x + k[1] * y + k[2] * z + rng.uniform(0, 2 * np.pi))
    return (amplitude / 2 * out).astype(np.float32)


def assert_close(actual, expected, atol, rtol=0.0):
    assert np.allclose(actual, expected, rtol=rtol, atol=atol), first_mismatch(
        actual.reshape(-1, actual.shape[-1]) if actual.ndim > 3 else actual.reshape(-1),
        expected.reshape(-1, expected.shape[-1]) if expected.ndim > 3 else expected.reshape(-1),
        rtol,
        atol,
    )


# {{{ boundaries (exact)


@pytest.mark.parametrize("shape", SIZES)
@pytest.mark.parametrize("kind", ["density", "velocity", "div", "p"])
def test_boundary_kernels_match_reference_exactly(runtime, shape, kind, seed):
    rng = np.random.default_rng(seed)
    sim = make(runtime, shape)
    velocity, density, prev = random_fields(rng, shape)
    sim.set_fields(velocity=velocity, density=density, prev=prev)
    state = sim.state()
    before = {"density": state["density"], "div": state["prev"], "p": state["prev"]}.get(kind)
    if kind == "velocity":
        before = np.concatenate([state["velocity"], np.zeros(state["velocity"].shape[:3] + (1,), np.float32)], -1)
    getattr(sim, f"set_boundary_{kind}")()
    after = sim.state()
    actual = {"density": after["density"], "div": after["prev"], "p": after["prev"]}.get(kind)
    if kind == "velocity":
        actual = after["velocity"]
    expected = boundary(before, kind)
    if kind == "velocity":
        expected = expected[..., :3]
    np.testing.assert_array_equal(actual, expected)
    interior = (slice(1, -1),) * 3
    np.testing.assert_array_equal(actual[interior], expected[interior])  # and the interior untouched
    assert (actual != (before[..., :3] if kind == "velocity" else before)).any(), "the boundary pass changed nothing"


PRODUCERS = {
    "diffuse_velocity": ("velocity", "set_boundary_velocity", lambda sim: sim.diffuse_velocity(DT, 1)),
    "advect_velocity": ("velocity", "set_boundary_velocity", lambda sim: sim.advect_velocity(DT)),
    "diffuse_density": ("density", "set_boundary_density", lambda sim: sim.diffuse_density(DT, 1)),
    "advect_density": ("density", "set_boundary_density", lambda sim: sim.advect_density(DT)),
    "advect_density_from_ext": ("density", "set_boundary_density", lambda sim: sim.advect_density_from_ext(DT)),
    "project_step1": ("prev", "set_boundary_div", lambda sim: sim.project_step1()),
    # from a prev set on the host (fixed: copied into the pressure and divergence fields first), and after
    # ProjectStep1 as step() runs it (fixed sweeps the fields ProjectStep1 fills)
    "project_step2": ("prev", "set_boundary_p", lambda sim: sim.project_step2(1)),
    "project_step1_2": ("prev", "set_boundary_p", lambda sim: (sim.project_step1(), sim.project_step2(2))),
}


@pytest.mark.parametrize("variant", ["fixed", "book"])
@pytest.mark.parametrize("producer", sorted(PRODUCERS))
@pytest.mark.parametrize("shape", [(7, 6, 5), (3, 4, 5)])
def test_kernels_leave_walls_their_boundary_kernel_would_not_change(runtime, seed, variant, producer, shape):
    """The kernels that apply a boundary rule themselves compute a wall cell from the cells the rule reads (the
    book's in-kernel SetBoundary* calls, without their race): their output is a fixed point of the separate
    SetBoundary* kernel, bit for bit. With the reference tests (interior values), this pins every cell."""
    field, boundary_kernel, run = PRODUCERS[producer]
    rng = np.random.default_rng(seed)
    sim = make(runtime, shape, variant=variant, visc=1e-4, diff=2e-4)  # a ~ 1: the sweeps do not just average
    velocity, density, prev = random_fields(rng, shape)
    sim.set_fields(velocity=velocity, density=density, prev=prev)
    sim.set_source(rng.normal(0.0, 1.0, (*sim.shape, 4)))
    run(sim)
    produced = sim.state()[field]
    getattr(sim, boundary_kernel)()
    np.testing.assert_array_equal(sim.state()[field], produced)


def test_the_kernel_file_lists_the_kernels_in_host_call_order():
    source = (KERNEL_DIR / "stable_fluids_3d.cl").read_text()
    assert tuple(re.findall(r"^__kernel\b[^;{]*?\bvoid\s+(\w+)", source, re.M)) == KERNELS
    header = source[source.index("Kernels, in host call order") : source.index("#ifndef THREAD_X")]
    first = [re.search(rf"\b{name}\b", header).start() for name in KERNELS]
    assert first == sorted(first), "the header lists the kernels out of order"


# }}}

# {{{ kernels vs reference


@pytest.mark.parametrize("shape", SIZES)
def test_add_source_brush3d_matches_reference(runtime, shape):
    sim = make(runtime, shape, source_radius=0.3, emitter_center=(0.4, 0.3, 0.6), emitter_direction=(0.5, 1.0, -0.25))
    sim.add_source_brush3d()
    p = sim.params
    expected = brush_reference(sim.shape, p.emitter_center, p.emitter_direction, p.source_radius)
    assert_close(sim.state()["source"], expected, 1e-6)
    assert expected[..., 3].max() > 0.5 or shape == (3, 4, 5)


@pytest.mark.parametrize("shape", SIZES[:2])
def test_add_source_kernels_match_reference(runtime, shape, seed):
    rng = np.random.default_rng(seed)
    sim = make(runtime, shape, velocity_coef=3.0, density_coef=1.5)
    velocity, density, prev = random_fields(rng, shape)
    sim.set_fields(velocity=velocity, density=density, prev=prev)
    sim.add_source_brush3d()
    source = sim.state()["source"].astype(np.float64)
    sim.add_source_velocity(DT)
    state = sim.state()
    s = source[..., :3] * 3.0 * DT
    assert_close(state["velocity"], velocity + s, 1e-6)
    assert_close(state["prev"][..., :3], s, 1e-6)
    np.testing.assert_array_equal(state["prev"][..., 3], prev[..., 3])  # prev.w (density) kept
    sim.add_source_density(DT)
    state = sim.state()
    assert_close(state["density"], density + source[..., 3] * 1.5 * DT, 1e-6)
    assert_close(state["prev"][..., 3], source[..., 3] * 1.5 * DT, 1e-6)
    # the density added is exactly the source's total: the one place this solver adds or removes mass by design
    added = state["density"].sum(dtype=np.float64) - density.sum(dtype=np.float64)
    assert added == pytest.approx(source[..., 3].sum() * 1.5 * DT, rel=1e-5)


@pytest.mark.parametrize("shape", SIZES)
@pytest.mark.parametrize("visc", [20.0, 0.01])  # the scene's a ~ 1e3 (a blur) and a ~ 1 (source and mean mixed)
def test_diffuse_velocity_sweep_matches_reference(runtime, shape, visc, seed):
    rng = np.random.default_rng(seed)
    sim = make(runtime, shape, visc=visc)
    velocity, _, prev = random_fields(rng, shape)
    sim.set_fields(velocity=velocity, prev=prev)
    sim.diffuse_velocity(DT, sweeps=1)
    expected = diffuse_velocity_reference(velocity, prev, sim.params)
    assert_close(sim.state()["velocity"], expected[..., :3], 1e-6)


@pytest.mark.parametrize("shape", SIZES)
def test_diffuse_density_two_sweeps_match_reference(runtime, shape, seed):
    rng = np.random.default_rng(seed)
    sim = make(runtime, shape, diff=0.05)
    _, density, prev = random_fields(rng, shape)
    sim.set_fields(density=density, prev=prev)
    sim.diffuse_density(DT)  # gs_iterations = 2 sweeps, each from the last one's output (ping-pong)
    expected = diffuse_density_reference(diffuse_density_reference(density, prev, sim.params), prev, sim.params)
    assert_close(sim.state()["density"], expected, 1e-6)


@pytest.mark.parametrize("shape", SIZES)
@pytest.mark.parametrize("variant", ["fixed", "book"])
def test_project_step1_matches_reference(runtime, shape, variant, seed):
    rng = np.random.default_rng(seed)
    sim = make(runtime, shape, variant=variant)
    velocity, _, prev = random_fields(rng, shape)
    sim.set_fields(velocity=velocity, prev=prev)
    sim.project_step1()
    assert_close(sim.state()["prev"], project_step1_reference(velocity, prev, variant), 1e-6)


def test_project_step1_variants_differ_as_documented(runtime, seed):
    """Only the x term agrees: book div = fixed div + 1.5*(dv/h + dw/d) with the original's precedence."""
    rng = np.random.default_rng(seed)
    velocity, _, prev = random_fields(rng, (19, 17, 13))
    divs = {}
    for variant in ("fixed", "book"):
        sim = make(runtime, variant=variant)
        sim.set_fields(velocity=velocity, prev=prev)
        sim.project_step1()
        divs[variant] = sim.state()["prev"][..., 1]
    v = velocity.astype(np.float64)
    extra = 1.5 * (central(v[..., 1], 1) / 17 + central(v[..., 2], 2) / 13)
    interior = (slice(1, -1),) * 3
    assert_close(divs["book"][interior], (divs["fixed"] + extra)[interior], 1e-5)


@pytest.mark.parametrize("shape", SIZES)
def test_project_step2_sweep_matches_reference(runtime, shape, seed):
    rng = np.random.default_rng(seed)
    sim = make(runtime, shape)
    prev = rng.normal(0.0, 0.05, (*sim.shape, 4)).astype(np.float32)
    sim.set_fields(prev=prev)
    sim.project_step2(sweeps=1)
    assert_close(sim.state()["prev"], project_step2_reference(prev), 1e-6)


@pytest.mark.parametrize("shape", SIZES)
def test_fixed_pressure_solve_is_the_books_float4_solve_bit_for_bit(runtime, shape, seed):
    """fixed sweeps its own float pressure and divergence fields, book the float4 prev; ProjectStep2 and 3 do the same
    arithmetic in both variants, so from the same velocity and prev the two give the same bits."""
    rng = np.random.default_rng(seed)
    velocity, _, _ = random_fields(rng, shape)
    prev = rng.normal(0.0, 0.05, (*shape[::-1], 4)).astype(np.float32)
    results = {}
    for variant in ("book", "fixed"):
        sim = make(runtime, shape, variant=variant)
        sim.set_fields(velocity=velocity, prev=prev)
        sim.project_step2(sweeps=3)
        mid = sim.state()["prev"]
        sim.project_step3()
        results[variant] = (mid, sim.state()["prev"], sim.state()["velocity"])
    for book, fixed in zip(results["book"], results["fixed"], strict=True):
        np.testing.assert_array_equal(fixed, book)
    assert (results["fixed"][1][..., 0] != prev[..., 0]).any(), "the sweeps changed no p"


def test_fixed_projection_keeps_prev_as_the_books(runtime, seed):
    """fixed: ProjectStep1 fills the divergence field and zeroes the pressure pair, the sweeps leave prev alone (p
    lives in the pressure field meanwhile, which state() reports as prev.x), ProjectStep3 copies p into prev.x."""
    rng = np.random.default_rng(seed)
    shape = (19, 17, 13)
    sim = make(runtime, shape)
    velocity, _, prev = random_fields(rng, shape)
    sim.set_fields(velocity=velocity, prev=prev)
    sim.project_step1()
    assert sim.solving
    raw = sim.prev.read.get()
    np.testing.assert_array_equal(sim.divergence.get(), raw[..., 1])
    assert not sim.pressure.read.get().any() and (raw[..., 1] != 0).any()
    sim.project_step2(sweeps=2)
    np.testing.assert_array_equal(sim.prev.read.get(), raw)  # the sweeps touch only the float fields
    p = sim.pressure.read.get()
    assert (p != 0).any()
    np.testing.assert_array_equal(sim.state()["prev"][..., 0], p)
    np.testing.assert_array_equal(sim.state()["prev"][..., 1:], raw[..., 1:])
    sim.project_step3()
    assert not sim.solving
    after = sim.prev.read.get()
    np.testing.assert_array_equal(after[..., 0], p)
    np.testing.assert_array_equal(after[..., 1:], raw[..., 1:])


def test_restore_mid_projection_goes_on_as_the_original(runtime, seed):
    """A checkpoint taken between ProjectStep1 and ProjectStep3 (fixed: p in the pressure field) restores into a
    simulation that finishes the projection and steps on with the same bits."""
    a = make(runtime, velocity_coef=10.0)
    for _ in range(3):
        a.step()
    a.project_step1()
    a.project_step2(sweeps=1)
    b = make(runtime, velocity_coef=10.0)
    b.restore(a.state())
    b.steps = a.steps
    for sim in (a, b):
        sim.project_step2(sweeps=1)
        sim.project_step3()
        sim.step()
    for key, value in a.state().items():
        np.testing.assert_array_equal(b.state()[key], value, err_msg=key)


@pytest.mark.parametrize("variant", ["fixed", "book"])
def test_restore_with_the_source_off_goes_on_from_the_leftovers(runtime, variant):
    """With the emitter off the diffusions read what the last step left in prev (fixed: in its split float fields);
    a state() restored into a new simulation (prev as one float4 array) steps on with the same bits."""
    a = make(runtime, variant=variant, velocity_coef=10.0, emitter_frames=3)
    for _ in range(5):
        a.step()
    b = make(runtime, variant=variant, velocity_coef=10.0, emitter_frames=3)
    b.restore(a.state())
    b.steps = a.steps
    for _ in range(3):
        for sim in (a, b):
            sim.step()
        assert not a.source_active()
        for key, value in a.state().items():
            np.testing.assert_array_equal(np.asarray(b.state()[key]).view(np.uint32), np.asarray(value).view(np.uint32))
    assert (a.state()["prev"][..., 3] != 0).any() and (a.state()["prev"][..., :3] != 0).any()


@pytest.mark.parametrize("shape", SIZES)
def test_project_step3_matches_reference(runtime, shape, seed):
    rng = np.random.default_rng(seed)
    sim = make(runtime, shape)
    velocity, _, _ = random_fields(rng, shape)
    prev = rng.normal(0.0, 0.01, (*sim.shape, 4)).astype(np.float32)  # p ~ div/6 at the scene's scale
    sim.set_fields(velocity=velocity, prev=prev)
    sim.project_step3()
    assert_close(sim.state()["velocity"], project_step3_reference(velocity, prev)[..., :3], 1e-6)


@pytest.mark.parametrize("shape", SIZES)
@pytest.mark.parametrize("variant", ["fixed", "book"])
def test_advect_velocity_matches_reference(runtime, shape, variant, seed):
    rng = np.random.default_rng(seed)
    sim = make(runtime, shape, variant=variant)
    prev = smooth_field(rng, shape, 4, 6.0)  # back-traces of a few cells, some leave the grid
    sim.set_fields(prev=prev)
    sim.advect_velocity(DT)
    assert_close(sim.state()["velocity"], advect_velocity_reference(prev, variant)[..., :3], 1e-5)


@pytest.mark.parametrize("shape", SIZES)
@pytest.mark.parametrize("variant", ["fixed", "book"])
def test_advect_density_matches_reference(runtime, shape, variant, seed):
    rng = np.random.default_rng(seed)
    sim = make(runtime, shape, variant=variant)
    velocity, prev = smooth_field(rng, shape, 3, 6.0), smooth_field(rng, shape, 4, 1.0)
    sim.set_fields(velocity=velocity, prev=prev)
    sim.advect_density(DT)
    assert_close(sim.state()["density"], advect_density_reference(velocity, prev, variant), 1e-5)


@pytest.mark.parametrize("variant", ["fixed", "book"])
def test_advect_density_from_ext_uses_the_source_velocity(runtime, variant, seed):
    rng = np.random.default_rng(seed)
    sim = make(runtime, variant=variant)
    velocity, prev = smooth_field(rng, (19, 17, 13), 3, 6.0), smooth_field(rng, (19, 17, 13), 4, 1.0)
    source = smooth_field(rng, (19, 17, 13), 4, 6.0)
    sim.set_fields(velocity=velocity, prev=prev)
    sim.set_source(source)
    sim.advect_density_from_ext(DT)
    assert_close(sim.state()["density"], advect_density_reference(source, prev, variant), 1e-5)


def test_swap_and_draw_copy_exactly(runtime, seed):
    rng = np.random.default_rng(seed)
    sim = make(runtime)
    velocity, density, prev = random_fields(rng, (19, 17, 13))
    sim.set_fields(velocity=velocity, density=density, prev=prev)
    sim.swap_velocity()
    sim.swap_density()
    sim.draw()
    state = sim.state()
    np.testing.assert_array_equal(state["prev"], np.concatenate([velocity, density[..., None]], -1))
    np.testing.assert_array_equal(state["solver"][..., :3], velocity)
    np.testing.assert_array_equal(state["solver"][..., 3], density)


@pytest.mark.parametrize("shape", SIZES)
@pytest.mark.parametrize("local_size", [(8, 8, 4), (4, 3, 2)])
def test_draw_volume_is_the_shown_field_in_half_floats_and_its_maxima(runtime, shape, local_size, seed):
    """DrawVolume (the view's upload): Draw's density or speed rounded to half floats, and the grid's largest density
    and speed reduced on the device, as numpy has them from solver. The largest cell is put first, last and in the
    middle, all densities negative (the ordered ints), in groups of a power of two and of 24 items."""
    rng = np.random.default_rng(seed)
    w, h, d = shape
    sim = make(runtime, shape, local_size=local_size)
    for where in [(0, 0, 0), (d - 1, h - 1, w - 1), (d // 2, h // 2, w // 2)]:
        velocity, density, _ = random_fields(rng, shape)
        density -= 2.0  # all negative: the ordered ints must order negative floats
        density[where], velocity[where] = -0.5, 4.0
        sim.set_fields(velocity=velocity, density=density)
        sim.draw()
        solver = sim.solver_field()
        speed = np.sqrt((solver[..., :3] ** 2).sum(axis=-1))
        volume, max_density, max_speed = sim.draw_volume("density")
        assert volume.dtype == np.float16
        np.testing.assert_array_equal(volume, solver[..., 3].astype(np.float16))
        assert (max_density, max_speed) == (solver[..., 3].max(), pytest.approx(speed.max(), rel=1e-6))
        volume, max_density_again, _ = sim.draw_volume("speed")
        assert max_density_again == max_density
        np.testing.assert_allclose(volume, speed.astype(np.float16), rtol=2**-10)
    density[where] = 1e6  # past half's range: clamped to its largest value, not inf
    sim.set_fields(density=density)
    volume, max_density, _ = sim.draw_volume("density")
    assert (volume[where], max_density) == (np.float16(65504), 1e6)


def project_reference(velocity, prev, variant: str, sweeps: int):
    prev = project_step1_reference(velocity, prev, variant)
    for _ in range(sweeps):
        prev = project_step2_reference(prev)
    return project_step3_reference(velocity, prev)[..., :3], prev


def step_reference(state, sim: Simulation, source_on: bool, dt=DT):
    """One Update() in the book's order (vol.1 §4.8 "Each item step of the simulation", in 3D): numpy float64."""
    p = sim.params
    velocity, density, prev, source = (state[k].astype(np.float64) for k in ("velocity", "density", "prev", "source"))
    if source_on and not sim.external_source:
        source = brush_reference(sim.shape, p.emitter_center, p.emitter_direction, p.source_radius)
    if not p.density_only:
        if source_on:
            added = source[..., :3] * p.velocity_coef * dt
            velocity, prev[..., :3] = velocity + added, added
        for _ in range(p.gs_iterations):
            velocity = diffuse_velocity_reference(velocity, prev, p, dt)[..., :3]
        velocity, prev = project_reference(velocity, prev, p.variant, p.gs_iterations)
        prev[..., :3] = velocity
        velocity = advect_velocity_reference(prev, p.variant)[..., :3]
        velocity, prev = project_reference(velocity, prev, p.variant, p.gs_iterations)
    if source_on:
        added = source[..., 3] * p.density_coef * dt
        density, prev[..., 3] = density + added, added
    for _ in range(p.gs_iterations):
        density = diffuse_density_reference(density, prev, p, dt)
    prev[..., 3] = density
    # density_only: the source's velocity carries the density; with the source off the original binds no source
    # texture, whose reads are 0 (as the 2D scene's AdvectDensityFromExt without a brush)
    carrier = (source if source_on else 0 * source) if p.density_only else velocity
    density = advect_density_reference(carrier, prev, p.variant)
    return {"velocity": velocity, "density": density, "prev": prev, "source": source}


@pytest.mark.parametrize(
    "overrides",
    [
        {"variant": "fixed"},
        {"variant": "book"},
        {"variant": "fixed", "density_only": True},
        {"variant": "book", "density_only": True, "gs_iterations": 3},
    ],
)
def test_whole_steps_match_the_books_order(runtime, overrides):
    """Every kernel in the host's order for 6 frames, the emitter blowing for the first 4 (then prev keeps its
    leftovers and, in density_only mode, nothing carries the density): catches a kernel launched out of order, on
    the wrong buffer of a ping-pong pair, or a stale source."""
    sim = make(
        runtime,
        (11, 9, 7),
        emitter_frames=4,
        emitter_center=(0.45, 0.4, 0.55),
        emitter_direction=(0.6, 1.0, -0.4),
        source_radius=0.35,
        velocity_coef=40.0,
        diff=0.5,
        visc=0.2,
        **overrides,
    )
    state = sim.state()
    expected = {k: state[k].astype(np.float64) for k in ("velocity", "density", "prev", "source")}
    fastest = 0.0
    for frame in range(6):
        source_on = sim.source_active()
        assert source_on == (frame < 4)
        sim.step(DT)
        expected = step_reference(expected, sim, source_on)
        state = sim.state()
        for key in ("velocity", "density", "prev"):
            scale = max(np.abs(expected[key]).max(), 1e-3)
            assert_close(state[key], expected[key], 1e-5 * scale)
        fastest = max(fastest, np.abs(expected["velocity"]).max())
    assert expected["density"].max() > 0.01
    if not sim.params.density_only:
        assert fastest * DT * (11 + 9 + 7) / 3 > 0.1, "back-traces under a tenth of a cell: a weak test"


def book_step(sim: Simulation, dt=DT) -> None:
    """One Update() as the book's kernels run one by one, every write made: the brush every frame, both projections
    leaving (p, div) in prev, Draw at the end (step() skips what no later read sees)."""
    source, p = sim.source_active(), sim.params
    if source and not sim.external_source:
        sim.add_source_brush3d()
    if not p.density_only:
        if source:
            sim.add_source_velocity(dt)
        sim.diffuse_velocity(dt)
        sim.project()
        sim.swap_velocity()
        sim.advect_velocity(dt)
        sim.project()
    if source:
        sim.add_source_density(dt)
    sim.diffuse_density(dt)
    sim.swap_density()
    if p.density_only:
        sim.advect_density_from_ext(dt, source)
    else:
        sim.advect_density(dt)
    sim.draw()
    sim.time, sim.steps = sim.time + dt, sim.steps + 1


@pytest.mark.parametrize(
    "overrides",
    [
        {"variant": "fixed"},
        {"variant": "book"},
        {"variant": "fixed", "density_only": True},
        {"variant": "fixed", "gs_iterations": 1},
        {"variant": "fixed", "gs_iterations": 3, "local_size": (4, 3, 2)},
    ],
)
def test_step_is_the_books_kernels_one_by_one_bit_for_bit(runtime, overrides, seed):
    """step() leaves out writes no later read sees (the first projection's p and div in prev, a brush that writes
    the source it holds, Draw until solver is read), and the fixed variant's runs fused kernels on prev split into
    float fields (fused_step): the state after every frame is the one-by-one run's, bit for bit (signs of zeros
    too), while the emitter moves, stops, starts again, an external source comes and goes, and (frames 2 and 9) the
    fast run takes the book's kernels one by one itself, so that prev moves between its float4 and split forms."""
    rng = np.random.default_rng(seed)
    args = dict(emitter_center=(0.45, 0.4, 0.55), source_radius=0.35, velocity_coef=40.0, diff=0.5, visc=0.2)
    fast, book = (make(runtime, (12, 9, 7), **args, **overrides) for _ in range(2))
    external = smooth_field(rng, (12, 9, 7), 4, 2.0)
    changes = {
        3: lambda sim: sim.update(emitter_center=(0.6, 0.3, 0.4)),
        4: lambda sim: sim.update(source_radius=0.3),
        5: lambda sim: sim.update(emitter=False),
        6: lambda sim: sim.update(emitter=True),
        7: lambda sim: sim.set_source(external),
        8: lambda sim: sim.set_source(None),
    }
    for frame in range(12):
        for sim in (fast, book):
            changes.get(frame, lambda sim: None)(sim)
        if frame in (2, 9):
            book_step(fast, DT)
        else:
            fast.step(DT)
            assert fast.prev_split == (fast.params.variant == "fixed")  # fused_step ran
        book_step(book, DT)
        expected = book.state()
        for key, value in fast.state().items():
            bits, expected_bits = (np.asarray(v).view(np.uint32) for v in (value, expected[key]))
            np.testing.assert_array_equal(bits, expected_bits, err_msg=f"{key} after frame {frame}")
    assert expected["density"].max() > 0.01
    assert np.abs(expected["velocity"]).max() > 0.1 or fast.params.density_only


# }}}

# {{{ invariants


@pytest.mark.parametrize("variant", ["fixed", "book"])
def test_zero_state_stays_exactly_zero(runtime, variant):
    sim = make(runtime, emitter=False, variant=variant)
    for _ in range(10):
        sim.step()
    for key, value in sim.state().items():
        np.testing.assert_array_equal(value, 0.0, err_msg=key)


@pytest.mark.parametrize("variant", ["fixed", "book"])
def test_max_principle_after_the_puff(runtime, variant):
    """Once the source stops, every kernel mixes existing values with non-negative weights summing to <= 1, so
    M = max(max density, max prev.w) never grows."""
    sim = make(runtime, emitter_frames=PUFF_FRAMES, variant=variant, velocity_coef=10.0)
    for _ in range(PUFF_FRAMES):
        sim.step()
    state = sim.state()
    m = max(state["density"].max(), state["prev"][..., 3].max())
    assert m > 0.01
    for _ in range(40):
        sim.step()
        state = sim.state()
        m_next = max(state["density"].max(), state["prev"][..., 3].max())
        assert m_next <= m * (1 + 1e-6)
        assert state["density"].min() >= -1e-7
        assert np.isfinite(state["velocity"]).all()
        m = m_next


def mirrored(field: np.ndarray, axis: int) -> np.ndarray:
    return np.flip(field, axis=2 - axis)


@pytest.mark.parametrize("variant", ["fixed", "book"])
def test_emitter_in_the_middle_keeps_the_mirror_symmetries(runtime, variant):
    """Emitter on the vertical centre line blowing up: the state is mirror-symmetric in x and in z (u odd in x, w odd
    in z, everything else even), in both variants: each boundary rule and divergence term is symmetric."""
    sim = make(runtime, variant=variant, velocity_coef=10.0, emitter_center=(0.5, 0.2, 0.5))
    for _ in range(30):
        sim.step()
    state = sim.state()
    density, velocity = state["density"], state["velocity"]
    scale_d, scale_v = density.max(), np.abs(velocity).max()
    assert scale_d > 0 and scale_v > 0
    for axis in (0, 2):
        np.testing.assert_allclose(mirrored(density, axis), density, atol=1e-5 * scale_d)
        for c in range(3):
            sign = -1.0 if c == axis else 1.0
            np.testing.assert_allclose(sign * mirrored(velocity[..., c], axis), velocity[..., c], atol=1e-5 * scale_v)


@pytest.mark.parametrize("variant", ["fixed", "book"])
def test_z_independent_source_keeps_density_only_state_z_independent(runtime, variant, seed):
    """A z-independent source should give a z-independent state. It holds in density_only mode; with the velocity step,
    the book's walls keep each face cell's own tangential velocity (computed from zero reads beyond the face), which
    differs from the layer inside, so the z faces seed a z-dependence there (docs/chapters/04-stable-fluids-3d.md,
    "Known limits")."""
    rng = np.random.default_rng(seed)
    sim = make(runtime, variant=variant, density_only=True)
    layer = np.zeros((sim.shape[1], sim.shape[2], 4), np.float32)
    layer[..., :2] = rng.normal(0.0, 3.0, layer.shape[:2] + (2,))  # xy velocity, w = 0
    layer[..., 3] = rng.uniform(0.0, 1.0, layer.shape[:2])
    sim.set_source(np.broadcast_to(layer, sim.shape + (4,)))
    for _ in range(20):
        sim.step()
    density = sim.state()["density"]
    assert density.max() > 0.01
    np.testing.assert_allclose(density, np.broadcast_to(density[1], density.shape), atol=1e-6 * density.max())


def test_solver_is_velocity_and_density(runtime):
    sim = make(runtime, velocity_coef=10.0)
    for _ in range(5):
        sim.step()
    state = sim.state()
    np.testing.assert_array_equal(state["solver"][..., 3], state["density"])
    np.testing.assert_array_equal(state["solver"][..., :3], state["velocity"])
    assert state["density"].max() > 0


def test_reruns_are_bitwise_identical(runtime):
    a, b = make(runtime, velocity_coef=10.0), make(runtime, velocity_coef=10.0)
    for _ in range(15):
        a.step()
        b.step()
    for key, value in a.state().items():
        np.testing.assert_array_equal(value, b.state()[key], err_msg=key)


def divergent_field(n: int) -> np.ndarray:
    """Gradient of a Gaussian bump (sigma^2 = 0.01 in uvw units) plus a vortex about the z axis."""
    z, y, x = np.meshgrid(*(((np.arange(n) + 0.5) / n - 0.5),) * 3, indexing="ij")
    bump = np.exp(-(x * x + y * y + z * z) / (2 * 0.01))
    swirl = np.exp(-(x * x + y * y + z * z) / (2 * 0.02))
    return np.stack(
        [-x * bump / 0.01 * 0.1 - y * swirl, -y * bump / 0.01 * 0.1 + x * swirl, -z * bump / 0.01 * 0.1], -1
    )


@pytest.mark.parametrize("variant, sweeps", [("fixed", 500), ("book", 500)])
def test_projection_removes_divergence_only_in_the_fixed_variant(runtime, variant, sweeps):
    n = 24
    sim = make(runtime, (n, n, n), variant=variant)
    velocity = divergent_field(n).astype(np.float32)
    sim.set_fields(velocity=velocity)
    before = np.abs(sim.state()["divergence"][2:-2, 2:-2, 2:-2]).mean()
    sim.project(sweeps=sweeps)
    after = np.abs(sim.state()["divergence"][2:-2, 2:-2, 2:-2]).mean()
    ratio = before / after
    if variant == "fixed":
        assert ratio >= 5.0, f"mean |div| only dropped {ratio:.2f}x"
    else:  # the precedence bug adds the y and z divergence instead of removing it
        assert ratio < 1.0, f"book projection reduced |div| {ratio:.2f}x"


def test_fixed_kinetic_energy_decays_after_the_puff(runtime):
    sim = make(runtime, emitter_frames=PUFF_FRAMES, velocity_coef=10.0)
    for _ in range(PUFF_FRAMES):
        sim.step()
    energy = sim.state()["kinetic_energy"]
    for _ in range(100):
        sim.step()
    assert sim.state()["kinetic_energy"] < 0.5 * energy


@pytest.mark.slow
def test_book_long_run_stays_finite_and_slow(runtime):
    sim = make(runtime, variant="book", velocity_coef=10.0)
    dfdt = DT * (19 + 17 + 13) / 3
    for _ in range(400):
        sim.step()
    state = sim.state()
    for key in ("velocity", "density", "prev"):
        assert np.isfinite(state[key]).all(), key
    assert np.abs(state["velocity"]).max() * dfdt <= 3.0, "the back-trace passes 3 cells per frame"


# }}}

# {{{ parameters


# ranges and cross-field limits: tests/test_params.py checks them for every field of every scene
@pytest.mark.parametrize(
    "overrides, message",
    [
        ({"emitter_direction": (0.0, 1.0)}, "emitter_direction must be 3 numbers"),
        ({"diff": float("nan")}, "diff must be a finite number"),
        ({"variant": "stam"}, "variant must be one of book\\|fixed"),
    ],
)
def test_bad_parameters_name_the_field_and_range(overrides, message):
    with pytest.raises(ValueError, match=message):
        Params(**overrides)


def test_bad_source_and_dt_are_refused(runtime):
    sim = make(runtime)
    with pytest.raises(ValueError, match="source must have shape"):
        sim.set_source(np.zeros((3, 3, 3, 4)))
    with pytest.raises(ValueError, match="dt must be in"):
        sim.step(float("nan"))


# }}}

# {{{ headless CLI


def test_cli_writes_the_chapter_page_arrays(capsys, tmp_path):
    from ugpcl.cli import main

    out = tmp_path / "sf3.npz"
    argv = ["run", "stable_fluids_3d", "--steps", "4", "--every", "2", "--out", str(out)]
    argv += ["--set", "width=12", "--set", "height=10", "--set", "depth=8", "--set", "variant=book"]
    assert main(argv) == 0
    data = np.load(out)
    shapes = {
        "velocity": (8, 10, 12, 3),
        "density": (8, 10, 12),
        "solver": (8, 10, 12, 4),
        "prev": (8, 10, 12, 4),
        "source": (8, 10, 12, 4),
        "divergence": (8, 10, 12),
        "density_history": (3, 8, 10, 12),
        "kinetic_energy_history": (3,),
    }
    for key, shape in shapes.items():
        assert data[key].shape == shape and data[key].dtype == np.float32, key
    assert data["density"].max() > 0 and '"variant": "book"' in str(data["params"])
    np.testing.assert_array_equal(data["density_history"][-1], data["density"])


# }}}

# {{{ view


def projected(camera, point, size) -> tuple[float, float]:
    clip = camera.projection() @ camera.view() @ np.array([*point, 1.0])
    ndc = clip[:2] / clip[3]
    return (ndc[0] + 1) / 2 * size[0], (1 - ndc[1]) / 2 * size[1]  # image row 0 at the top


@pytest.mark.gl
def test_view_draws_smoke_where_the_density_is(runtime, gl):
    from ugpcl.viewer.offscreen import frame
    from ugpcl.viewer.views import create_view

    scene = get("stable_fluids_3d")
    sim = scene.create(runtime, width=24, height=20, depth=16, emitter=False)
    view = create_view(scene, gl, sim)
    view.show_box = False
    camera = view.png_camera()
    size = (160, 120)
    camera.aspect = size[0] / size[1]
    view.upload()
    empty = frame(size).render(view, camera)
    assert not foreground(empty, view.background).any(), "smoke drawn with zero density"

    # a blob of smoke at uvw (0.25, 0.7, 0.5): left and high in the box
    d, h, w = sim.shape
    z, y, x = np.meshgrid((np.arange(d) + 0.5) / d, (np.arange(h) + 0.5) / h, (np.arange(w) + 0.5) / w, indexing="ij")
    blob = 0.3 * np.exp(-((x - 0.25) ** 2 + (y - 0.7) ** 2 + (z - 0.5) ** 2) / (2 * 0.08**2))
    sim.set_fields(density=blob)
    sim.draw()
    view.upload()
    pixels = frame(size).render(view, camera)
    mask = foreground(pixels, view.background, tolerance=30)
    assert 0.005 < mask.mean() < 0.3
    ys, xs = np.nonzero(mask)
    centre = (np.array([0.25, 0.7, 0.5]) - 0.5) * view.box_size  # uvw -> scene coordinates
    px, py = projected(camera, centre, size)
    assert abs(xs.mean() - px) < 6 and abs(ys.mean() - py) < 6, "smoke is not where the density is"
    grey = pixels[mask].astype(int)
    assert (np.abs(grey[:, 0] - grey[:, 2]) < 12).all(), "smoke should be white/grey"
    # slice mode through the blob's z shows it too, as an opaque square of the box's size
    view.next_display()
    pixels = frame(size).render(view, camera)
    assert foreground(pixels, view.background).mean() > mask.mean()


@pytest.mark.gl
@pytest.mark.parametrize("field", ["density", "speed", "uniform speed"])
def test_device_smoke_is_the_shaders_smoke(runtime, gl, field):
    """The smoke display ray-marched by RayMarchSmoke into a picture (Simulation.ray_march, what the view draws) is
    the fragment shader's ray march of the uploaded volume (gl_smoke) within rounding: the picture's RGBA8 before the
    blend, the volume's half floats and GL's filter weights (llvmpipe: the same pixels), from outside the box and from
    inside it, in a non-cubic grid. Two blobs, one above the other, so that the shadow rays darken the lower one: the
    lower thin (its absorption shows throughout), the upper dense enough for the rays' early exit; a smooth velocity
    for the speed display. Mutations it caught: absorption x 1.1, no shadow, texel centres off by 0.1 cell, the heat
    ramp at 0.9 x the speed, the early exit at 5 % transmittance instead of 1 %. "uniform speed": every cell at the
    largest speed, so the top of the heat ramp (t = 1) fills the smoke."""
    from ugpcl.viewer.camera import OrbitCamera
    from ugpcl.viewer.offscreen import frame
    from ugpcl.viewer.views import create_view

    scene = get("stable_fluids_3d")
    shape = w, h, d = (20, 16, 12)
    sim = scene.create(runtime, width=w, height=h, depth=d, emitter=False)
    z, y, x = np.meshgrid((np.arange(d) + 0.5) / d, (np.arange(h) + 0.5) / h, (np.arange(w) + 0.5) / w, indexing="ij")

    def blob(centre, radius):
        return np.exp(-((x - centre[0]) ** 2 + (y - centre[1]) ** 2 + (z - centre[2]) ** 2) / (2 * radius**2))

    density = 0.05 * blob((0.45, 0.35, 0.5), 0.15) + 0.4 * blob((0.55, 0.75, 0.45), 0.1)
    velocity = smooth_field(np.random.default_rng(3), shape, 3, 1.0)
    if field == "uniform speed":
        velocity = np.broadcast_to(np.float32([0.6, 0.8, 0.0]), (d, h, w, 3)).copy()
    sim.set_fields(velocity=velocity, density=density)
    view = create_view(scene, gl, sim)
    view.field, view.show_box = field.split()[-1], False
    size = (96, 64)
    inside = OrbitCamera(target=(0.0, 0.1, 0.0), distance=0.3, yaw=140.0, pitch=-25.0, near=0.01, far=10.0)
    for camera in (view.png_camera(), inside):
        camera.aspect = size[0] / size[1]
        shader, device = [], []
        for picture, gl_smoke in ((shader, True), (device, False)):
            view.gl_smoke = gl_smoke
            view.upload()
            picture.append(frame(size).render(view, camera).astype(int))
        shader, device = shader[0], device[0]
        smoke = foreground(shader, view.background, 6) | foreground(device, view.background, 6)
        assert smoke.mean() > 0.05, "too little smoke in the frame to compare"
        diff = np.abs(shader - device).max(axis=-1)[smoke]
        assert (diff <= 3).mean() > 0.99 and diff.max() <= 12, (
            f"{field}: {(diff > 3).mean():.2%} of the smoke's pixels differ by more than 3 levels, at most {diff.max()}"
        )


@pytest.mark.gl
def test_png_of_the_scene_shows_smoke_above_the_emitter(runtime, gl, tmp_path):
    from PIL import Image

    from ugpcl.cli import main

    png = tmp_path / "sf3.png"
    argv = ["run", "stable_fluids_3d", "--steps", "90", "--out", str(tmp_path / "x.npz"), "--png", str(png)]
    argv += ["--png-size", "160x120", "--set", "width=24", "--set", "height=24", "--set", "depth=24"]
    assert main(argv) == 0
    pixels = np.asarray(Image.open(png).convert("RGB"))
    data = np.load(tmp_path / "x.npz")
    density = data["density"].astype(np.float64)
    com = [
        float((density.sum(axis=tuple(a for a in range(3) if a != 2 - i)) * (np.arange(24) + 0.5) / 24).sum())
        / density.sum()
        for i in range(3)
    ]  # density centroid in uvw (x, y, z)
    view_background = (0.12, 0.12, 0.13)
    lit = pixels.astype(int).sum(axis=-1) > 3 * 60  # background: 3 x 32
    # smoke = lit pixels whose 3x3 neighbourhood is lit too: erosion removes the box outline (1-2 px lines)
    padded = np.pad(lit, 1)
    smoke = np.ones_like(lit)
    for dy in range(3):
        for dx in range(3):
            smoke &= padded[dy : dy + lit.shape[0], dx : dx + lit.shape[1]]
    ys, xs = np.nonzero(smoke)
    assert len(xs) > 40, "no smoke in the picture"
    from ugpcl.viewer.views.stable_fluids_3d import start_camera

    camera = start_camera()
    camera.aspect = 160 / 120
    px, py = projected(camera, np.array(com) - 0.5, (160, 120))
    assert abs(xs.mean() - px) < 6 and abs(ys.mean() - py) < 6, "the smoke is not where the density is"
    emitter = np.array(Params().emitter_center)
    assert com[1] > emitter[1] + 0.05, "the smoke did not rise above the emitter"
    assert ys.mean() < projected(camera, emitter - 0.5, (160, 120))[1], "the picture's smoke is not above the emitter"
    corners = pixels[[0, 0, -1, -1], [0, -1, 0, -1]]
    assert not foreground(corners[None], view_background).any(), "the corners should show the background"


@pytest.mark.gl
def test_view_keys_change_the_simulation(runtime, gl):
    from ugpcl.viewer.views import create_view

    scene = get("stable_fluids_3d")
    sim = scene.create(runtime, width=8, height=8, depth=8)
    view = create_view(scene, gl, sim)
    view.toggle_variant()
    assert sim.params.variant == "book"
    view.more_iterations()
    assert sim.params.gs_iterations == 4
    view.toggle_emitter()
    assert sim.params.emitter is False
    view.emitter_right()
    assert sim.params.emitter_center[0] == pytest.approx(0.55)
    radius = sim.params.source_radius
    view.larger_source()
    assert sim.params.source_radius == pytest.approx(radius + 0.01)
    view.next_display()
    view.next_field()
    assert (view.display, view.field) == ("slice", "speed")
    assert {k.key for k in view.keys} >= {"tab", "f", "[", "]", "+", "-", "v", "d", "e", "left", "up"}


# }}}


@pytest.mark.parametrize("shape", [(4, 3, 3), (8, 5, 7), (12, 6, 9), (8, 3, 10), (16, 9, 17)])
def test_rows_sweep_is_project_step2_bit_for_bit(runtime, shape):
    """ProjectStep2Rows (strips of 4 x 1 x ROWS_PER_ITEM cells along z, what GPUs run) gives ProjectStep2's
    pressures, faces, edges and corners included, bit for bit. Depths that are not multiples of the strip end in a
    part strip."""
    w, h, d = shape
    pressures = {}
    for kernel in ("ProjectStep2", "ProjectStep2Rows"):  # the same fields for both
        sim = make(runtime, shape, local_size=(4, 4, 2))
        sim.sweep_kernel = kernel
        rng = np.random.default_rng(7)
        sim.project_step1()
        sim.pressure.read.set(rng.uniform(-1, 1, (d, h, w)).astype(np.float32))
        sim.divergence.set(rng.uniform(-1, 1, (d, h, w)).astype(np.float32))
        sim.project_step2(3)
        pressures[kernel] = sim.pressure.read.get()
    assert np.abs(pressures["ProjectStep2"]).max() > 0
    np.testing.assert_array_equal(pressures["ProjectStep2Rows"], pressures["ProjectStep2"])


@pytest.mark.parametrize("shape", [(12, 9, 7), (5, 4, 9), (3, 3, 3), (16, 8, 4), (9, 6, 6)])
def test_rows_diffusion_is_diffuse_fields_bit_for_bit(runtime, shape):
    """DiffuseFieldsRows (strips of FIELD_ROWS cells along z, what step() runs) gives DiffuseFields' fields, walls
    included, bit for bit, over frames with the source on (the first sweep adds it), off (prev's leftovers) and in
    density_only mode. Depths that are not multiples of the strip end in a part strip; (3, 3, 3) has one interior
    cell."""
    args = dict(emitter_center=(0.45, 0.4, 0.55), source_radius=0.35, velocity_coef=40.0, diff=0.5, visc=0.2)
    states = {}
    for kernel in ("DiffuseFields", "DiffuseFieldsRows"):
        sim = make(runtime, shape, local_size=(4, 3, 2), **args)
        sim.diffuse_kernel = kernel
        states[kernel] = []
        for frame in range(6):
            sim.update(**{3: {"emitter": False}, 4: {"density_only": True}}.get(frame, {}))
            sim.step(DT)
            states[kernel].append(sim.state())
    for frame, (expected, strips) in enumerate(zip(states["DiffuseFields"], states["DiffuseFieldsRows"], strict=True)):
        for key, value in strips.items():
            bits, expected_bits = (np.asarray(v).view(np.uint32) for v in (value, expected[key]))
            np.testing.assert_array_equal(bits, expected_bits, err_msg=f"{key} after frame {frame}")
    assert np.abs(states["DiffuseFields"][3]["velocity"]).max() > 0.001


@pytest.mark.parametrize("shape", [(12, 9, 7), (5, 4, 9), (3, 3, 3), (16, 8, 4), (9, 6, 6), (4, 3, 5)])
def test_rows_divergence_is_project_step1_bit_for_bit(runtime, shape, seed):
    """ProjectStep1Rows (strips of FIELD_ROWS cells along z, walls included, what step()'s projections run) writes
    the divergence and the first sweep's p of ProjectStep1 (first_sweep = 1), faces, edges and corners included, bit
    for bit; part strips at the far z wall."""
    w, h, d = shape
    sim = make(runtime, shape, local_size=(4, 3, 2))
    velocity, _, _ = random_fields(np.random.default_rng(seed), shape)
    sim.set_fields(velocity=velocity)
    fields = {}
    for kernel in ("ProjectStep1", "ProjectStep1Rows"):
        for field in (sim.divergence, sim.pressure.read):
            field.set(np.full((d, h, w), np.nan, np.float32))  # every cell must be written
        flags = (np.int32(0), np.int32(1)) if kernel == "ProjectStep1" else ()  # write_prev 0, first_sweep 1
        prev = (sim.prev.read,) if kernel == "ProjectStep1" else ()
        sim._grid(kernel, sim.velocity.read, *prev, sim.divergence, sim.pressure.read, *sim.dims, *flags)
        fields[kernel] = [field.get().view(np.uint32) for field in (sim.divergence, sim.pressure.read)]
    assert np.isfinite(fields["ProjectStep1"][0].view(np.float32)).all()
    for rows, expected in zip(fields["ProjectStep1Rows"], fields["ProjectStep1"], strict=True):
        np.testing.assert_array_equal(rows, expected)


def test_diffuse_kernel_is_checked(runtime):
    sim = make(runtime, (8, 5, 5))
    assert sim.diffuse_kernel == "DiffuseFieldsRows"  # on every device: faster on PoCL too
    with pytest.raises(ValueError, match="diffuse_kernel must be DiffuseFields or DiffuseFieldsRows"):
        sim.diffuse_kernel = "DiffuseVelocity"
    sim.diffuse_kernel = "DiffuseFields"
    sim.diffuse_kernel = None
    assert sim.diffuse_kernel == "DiffuseFieldsRows"


def test_sweep_kernel_is_chosen_by_device_and_checked(runtime):
    sim = make(runtime, (8, 5, 5))
    assert sim.sweep_kernel == "ProjectStep2Rows"  # on every device (strips_on_cpu): faster on PoCL too
    assert sim.stats()["sweep kernel"] == "ProjectStep2Rows"  # the run's summary names it
    assert make(runtime, (9, 5, 5)).sweep_kernel == "ProjectStep2"  # a width the strips cannot cover
    with pytest.raises(ValueError, match="sweep_kernel ProjectStep2Rows needs variant=fixed and a grid width"):
        make(runtime, (9, 5, 5)).sweep_kernel = "ProjectStep2Rows"
    sim.sweep_kernel = "ProjectStep2Rows"
    sim.update(variant="book")  # a live switch: the book's float4 sweep, as ProjectStep2Rows cannot run it
    assert sim.sweep_kernel == "ProjectStep2"


@pytest.mark.parametrize(("variant", "sweeps", "per_cell"), [("fixed", 2, 316), ("fixed", 3, 396), ("book", 2, 752)])
def test_bench_step_bytes_count_the_launches_of_a_step(runtime, variant, sweeps, per_cell):
    """The bench's least traffic of a step (source on): fixed, fused_step: 2 x 56 (DiffuseFieldsRows) + 2 x (24 + 12 +
    36) (the projections) + 36 + 24 (the advections); book: 80 + 2 x 48 + 2 x (48 + 2 x 32 + 48) + 48 + 32 (the
    velocity step) + 56 + 2 x 24 + 36 + 36 (the density step); each more sweep 80 (fixed), 136 (book)."""
    from ugpcl.bench.stable_fluids_3d import step_bytes

    sim = make(runtime, (8, 6, 5), variant=variant, gs_iterations=sweeps)
    assert step_bytes(sim) == per_cell * 8 * 6 * 5
    assert sim.steps == 1 and "_grid" not in vars(sim)  # one real step; the counter is gone


@pytest.mark.oclgrind
@pytest.mark.parametrize("variant", ["fixed", "book"])
def test_kernels_on_oclgrind(oclgrind, variant):
    # 9 x 6 x 5 with work-groups of 4 x 4 x 2: partial groups on every axis; every kernel runs in one step
    sim = Simulation(
        oclgrind,
        Params(
            width=9,
            height=6,
            depth=5,
            local_size=(4, 4, 2),
            variant=variant,
            emitter_center=(0.5, 0.3, 0.5),
            source_radius=0.4,
        ),
    )
    sim.step()
    sim.step()
    if variant == "fixed":  # step() ran the fused kernels: the book's one by one too, and a step without the source
        sim.velocity_step(DT, True)
        sim.density_step(DT, True)
        sim.update(emitter=False)
        sim.step()  # DiffuseFieldsRows from the split prev
        sim.update(emitter=True)
        sim.diffuse_kernel = "DiffuseFields"  # the fused sweep in the book's work-groups
        sim.step()
        sim.diffuse_kernel = None
    assert sim.state()["density"].max() > 0
    volume, max_density, _ = sim.draw_volume("speed")  # the view's: a reduction in local memory, partial groups
    assert max_density == sim.state()["density"].max()
    if variant == "fixed":  # the view's smoke (no variant in it): 13 x 7 pixels, partial work-groups on both axes
        from ugpcl.viewer.camera import OrbitCamera

        camera = OrbitCamera(distance=1.9, yaw=-30.0, pitch=20.0, near=0.05, far=50.0, aspect=13 / 7)
        inv_view_proj = np.linalg.inv(camera.projection() @ camera.view())
        for field in ("density", "speed"):
            image, _, _ = sim.ray_march(inv_view_proj, camera.eye(), (13, 7), field, light_dir=(0.0, 1.0, 0.0))
            assert image.shape == (7, 13, 4) and image[..., 3].max() > 0
    sim.update(density_only=True)
    sim.step()  # AdvectDensityFromExt
    sim.update(emitter=False)
    sim.step()  # AdvectDensityFromExt on the zero source (no AddSource kernels)
    assert np.isfinite(sim.state()["density"]).all()
    sim.project_step1()
    sim.set_boundary_p()  # fixed: on the pressure field (stride 1)
    sim.set_boundary_div()  # fixed: on prev.y and the divergence field
    sim.project_step2(1)
    sim.update(variant="book" if variant == "fixed" else "fixed")  # mid-solve: p moves to where the other reads it
    sim.project_step2(1)
    sim.project_step3()
    sim.set_boundary_p()  # on prev.x (stride 4)
    sim.set_boundary_div()
    sim.set_boundary_density()
    if variant == "fixed":  # the strip sweeps: ProjectStep2Rows 2 strips across, both a part strip along z
        strips = Simulation(oclgrind, Params(width=8, height=4, depth=6, local_size=(4, 4, 2), source_radius=0.4))
        strips.sweep_kernel = "ProjectStep2Rows"
        strips.step()
        assert np.isfinite(strips.state()["prev"]).all()
