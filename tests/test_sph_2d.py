"""SPH fluid 2D (vol.1 ch.5; docs/chapters/05-sph-2d.md, "Tests"): layout, the four kernels against numpy, physics
invariants, the grid variant against all pairs, headless CLI, view, Oclgrind."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from helpers import first_mismatch, foreground

from ugpcl.buffers import device_sizeof
from ugpcl.cli import main
from ugpcl.registry import get
from ugpcl.scenes.sph_2d import PARTICLE_DTYPE, Params, Simulation

SUB_DT = 1.0 / 240.0  # the scene's sub-step (max_allowable_timestep)

# {{{ numpy float64 reference, written from the book's SPH2D.compute listings 5.5-5.12


def coefficients(p: Params) -> tuple[float, float, float]:
    """Listing 5.2 (FluidBase.cs): densityCoef, gradPressureCoef, lapViscosityCoef with the mass folded in."""
    h, m = p.smoothlen, p.particle_mass
    return m * 4 / (np.pi * h**8), m * -30 / (np.pi * h**5), m * 20 / (3 * np.pi * h**5)


def pair_geometry(position: np.ndarray):
    """diff[i, j] = x_j - x_i (the book's N_position - P_position), r^2, and the j != i mask."""
    x = position.astype(np.float64)
    diff = x[None, :, :] - x[:, None, :]
    return diff, (diff**2).sum(-1), ~np.eye(len(x), dtype=bool)


def density_reference(position: np.ndarray, p: Params) -> np.ndarray:
    """DensityCS: sum over j != i with r^2 < h^2 of densityCoef (h^2 - r^2)^3 (own ID skipped, as the book)."""
    density_coef = coefficients(p)[0]
    _, r_sq, others = pair_geometry(position)
    h_sq = p.smoothlen**2
    return np.where(others & (r_sq < h_sq), density_coef * (h_sq - r_sq) ** 3, 0.0).sum(axis=1)


def pressure_reference(density: np.ndarray, p: Params) -> np.ndarray:
    """PressureCS / CalculatePressure: B max((rho / rho0)^7 - 1, 0)."""
    return p.pressure_stiffness * np.maximum((density.astype(np.float64) / p.rest_density) ** 7 - 1, 0.0)


def force_reference(position, velocity, density, pressure, p: Params, min_density: float = 0.0) -> np.ndarray:
    """ForceCS: pressure (CalculateGradPressure) and viscosity (CalculateLapVelocity) over j != i within h, divided by
    the own density; coincident pairs and density-0 particles contribute 0 (our guards)."""
    _, grad_coef, lap_coef = coefficients(p)
    diff, r_sq, others = pair_geometry(position)
    h = p.smoothlen
    r = np.sqrt(r_sq)
    rho = np.maximum(density.astype(np.float64), min_density)
    prs, vel = pressure.astype(np.float64), velocity.astype(np.float64)
    near = others & (r_sq < h * h) & (r >= 1e-6 * h) & (rho[None, :] > 0)
    safe_r = np.where(near, r, 1.0)
    safe_rho_j = np.where(near, rho[None, :], 1.0)
    avg_pressure = 0.5 * (prs[None, :] + prs[:, None])
    press_w = np.where(near, grad_coef * avg_pressure / safe_rho_j * (h - r) ** 2 / safe_r, 0.0)
    press = (press_w[..., None] * diff).sum(axis=1)
    visco_w = np.where(near, lap_coef / safe_rho_j * (h - r), 0.0)
    visco = (visco_w[..., None] * (vel[None, :, :] - vel[:, None, :])).sum(axis=1)
    force = press + p.viscosity * visco
    return np.where(rho[:, None] > 0, force / np.where(rho > 0, rho, 1.0)[:, None], 0.0)


def integrate_reference(position, velocity, acceleration, dt: float, p: Params, mouse=None):
    """IntegrateCS: mouse push, the four penalty planes, gravity, v += dt a, x += dt v (new v)."""
    x, v, a = (np.asarray(t, np.float64).copy() for t in (position, velocity, acceleration))
    if mouse is not None:
        d = x - np.asarray(mouse)
        dist = np.linalg.norm(d, axis=1)
        inside = (dist < p.mouse_interaction_radius) & (dist > 0)
        push = p.mouse_gain * (p.mouse_interaction_radius - dist) / np.where(inside, dist, 1.0)
        a += np.where(inside[:, None], push[:, None] * d, 0.0)
    k, (range_x, range_y) = p.wall_stiffness, p.range
    a[:, 0] += -k * np.minimum(x[:, 0], 0) + k * np.minimum(range_x - x[:, 0], 0)
    a[:, 1] += -k * np.minimum(x[:, 1], 0) + k * np.minimum(range_y - x[:, 1], 0)
    a += np.asarray(p.gravity)
    v += dt * a
    return x + dt * v, v


# }}}


def scene_params(n: int, **overrides) -> Params:
    """The scene's values with the disc shrunk to keep its number density: ball 5 sqrt(N / 8192)
    (docs/chapters/05-sph-2d.md, "Tests")."""
    return Params(particle_num=n, ball_radius=5.0 * math.sqrt(n / 8192), **overrides)


def make(runtime, n: int, seed: int = 0, **overrides) -> Simulation:
    return Simulation(runtime, scene_params(n, **overrides), seed)


def moving(runtime, n: int, seed: int, frames: int = 6, **overrides) -> Simulation:
    """A simulation a few frames after the start: compressed, moving, splashing off the floor (velocities != 0)."""
    sim = make(runtime, n, seed, **overrides)
    for _ in range(frames):
        sim.step()
    return sim


def read_force(sim: Simulation) -> np.ndarray:
    return sim.force.get().view(np.float32).reshape(-1, 2)


# {{{ layout


def test_particle_dtype_matches_the_device_struct(runtime):
    assert PARTICLE_DTYPE.itemsize == 16
    assert device_sizeof(runtime, "FluidParticle", "sph_2d.h") == PARTICLE_DTYPE.itemsize


# }}}

# {{{ kernels vs reference


@pytest.mark.parametrize("n", [2, 255, 256, 257, 1000])  # smallest, under/at/over one work-group, the chapter page's N
def test_density_cs_matches_reference(runtime, n, seed):
    sim = moving(runtime, n, seed, frames=2)
    sim.density_cs()
    expected = density_reference(sim.state()["position"], sim.params)
    actual = sim.density.get()
    # float32 sums of ~80 terms of one sign against float64: observed ~1e-6; the chapter page's rtol 1e-5
    assert np.allclose(actual, expected, rtol=1e-5, atol=1e-6 * expected.max()), first_mismatch(
        actual, expected, 1e-5, 0
    )


def test_pressure_cs_matches_reference(runtime, seed):
    sim = moving(runtime, 1000, seed)
    sim.density_cs()
    sim.pressure_cs()
    expected = pressure_reference(sim.density.get(), sim.params)
    actual = sim.pressure.get()
    assert (expected > 0).sum() > 100, "the state should be compressed somewhere"
    # gamma = 7 multiplies the float32 rounding of rho / rho0 by 7: the chapter page's rtol 1e-4
    assert np.allclose(actual, expected, rtol=1e-4, atol=1e-6), first_mismatch(actual, expected, 1e-4, 1e-6)


def test_pressure_is_zero_up_to_rest_density_and_increasing_above(runtime):
    sim = make(runtime, 400)
    rho0 = sim.params.rest_density
    density = np.linspace(0.0, 3.0 * rho0, 400).astype(np.float32)
    density[123] = rho0  # exactly the rest density
    density.sort()
    sim.density.set(density)
    sim.pressure_cs()
    pressure = sim.pressure.get()
    np.testing.assert_array_equal(pressure[density <= rho0], 0.0)
    above = pressure[density > rho0]
    assert (above > 0).all() and (np.diff(above) > 0).all(), "pressure must rise strictly with density above rho0"


@pytest.mark.parametrize("variant", ["fixed", "book"])
@pytest.mark.parametrize("n", [257, 1000])
def test_force_cs_matches_reference(runtime, n, variant, seed):
    sim = moving(runtime, n, seed, variant=variant)
    sim.density_cs()
    sim.pressure_cs()
    sim.force_cs()
    state = sim.state()
    assert np.abs(state["velocity"]).max() > 0.1, "viscosity needs moving particles to be tested"
    expected = force_reference(
        state["position"], state["velocity"], sim.density.get(), sim.pressure.get(), sim.params, sim.params.min_density
    )
    actual = read_force(sim)
    # float32 sums of terms of both signs: the chapter page's |a - a_ref| <= 1e-4 max |a_ref|
    atol = 1e-4 * np.abs(expected).max()
    assert np.allclose(actual, expected, rtol=0, atol=atol), first_mismatch(actual, expected, 0, atol)


def test_fixed_variant_only_changes_particles_below_the_self_density(runtime, seed):
    book, fixed = moving(runtime, 1000, seed, variant="book"), moving(runtime, 1000, seed, variant="fixed")
    fixed.set_particles(book.state()["position"], book.state()["velocity"])
    for sim in (book, fixed):
        sim.density_cs()
        sim.pressure_cs()
        sim.force_cs()
    density = book.density.get()
    self_density = book.params.self_density
    _, r_sq, others = pair_geometry(book.state()["position"])
    touches_light = ((r_sq < book.params.smoothlen**2) & others & (density[None, :] < self_density)).any(axis=1)
    untouched = (density >= self_density) & ~touches_light
    assert untouched.mean() > 0.9
    np.testing.assert_array_equal(read_force(book)[untouched], read_force(fixed)[untouched])


def test_integrate_cs_matches_reference(runtime, seed):
    n = 700
    sim = moving(runtime, n, seed)
    rng = np.random.default_rng(seed)
    state = sim.state()
    position = state["position"].copy()
    position[:20] = rng.uniform(-0.3, 0.3, (20, 2)) + rng.choice([[0, 0], [16, 9], [0, 9], [16, 0]], 20)  # outside
    sim.set_particles(position, state["velocity"])
    sim.density_cs()
    sim.pressure_cs()
    sim.force_cs()
    mouse = (8.3, 2.0)
    sim.push(*mouse)
    sim.integrate_cs(SUB_DT)
    out = sim.particles.write.get()  # IntegrateCS writes particles_out; the swap comes after
    x, v = integrate_reference(position, state["velocity"], read_force(sim), SUB_DT, sim.params, mouse)
    np.testing.assert_allclose(out["velocity"], v, rtol=1e-5, atol=1e-5)
    np.testing.assert_allclose(out["position"], x, rtol=1e-5, atol=1e-6)


# }}}

# {{{ invariants


def test_lattice_density_is_the_analytic_lattice_sum(runtime):
    spacing, side = 0.1, 31
    k = np.arange(side) - side // 2
    grid = np.stack(np.meshgrid(k, k, indexing="ij"), axis=-1).reshape(-1, 2)
    sim = Simulation(runtime, Params(particle_num=len(grid)), 0)
    # centred on the origin (DensityCS ignores the box): small coordinates keep float32 rounding of the positions
    # below the chapter page's 1e-6 spread (around x = 8 it alone gives ~1.3e-6)
    sim.set_particles(grid * spacing)
    sim.density_cs()
    density = sim.density.get()
    h = sim.params.smoothlen
    # the sum over the infinite lattice: offsets (a, b) != 0 with (a^2 + b^2) s^2 < h^2
    reach = int(h / spacing) + 1
    a, b = np.meshgrid(np.arange(-reach, reach + 1), np.arange(-reach, reach + 1))
    r_sq = ((a**2 + b**2) * spacing**2).ravel()
    r_sq = r_sq[(r_sq > 0) & (r_sq < h * h)]
    analytic = (coefficients(sim.params)[0] * (h * h - r_sq) ** 3).sum()
    interior = (np.abs(grid) * spacing <= (side // 2) * spacing - h - 1e-9).all(axis=1)
    assert interior.sum() >= 100
    np.testing.assert_allclose(density[interior], analytic, rtol=1e-5)
    spread = density[interior].max() / density[interior].min() - 1
    assert spread <= 1e-6, f"interior densities differ by {spread:.2e}"


@pytest.mark.parametrize("variant", ["fixed", "book"])
def test_forces_conserve_momentum(runtime, variant, seed):
    sim = moving(runtime, 1000, seed, variant=variant)
    sim.density_cs()
    sim.pressure_cs()
    sim.force_cs()
    acceleration = read_force(sim).astype(np.float64)
    # pressure term symmetric (mean pressure), viscosity antisymmetric, both over rho_i rho_j: sum a_i = 0 (equal m)
    assert np.abs(acceleration.sum(axis=0)).max() <= 1e-4 * np.abs(acceleration).sum()
    # and so a step without gravity, walls (all inside) or mouse keeps the total momentum at 0
    calm = Simulation(runtime, scene_params(1000, gravity=(0.0, 0.0), range=(40.0, 40.0)), seed)
    for _ in range(3):
        calm.step()
    velocity = calm.state()["velocity"].astype(np.float64)
    assert np.abs(velocity.sum(axis=0)).max() <= 1e-4 * np.abs(velocity).sum()


def test_isolated_particle_falls_freely(runtime):
    sim = Simulation(runtime, Params(particle_num=2), 0)
    y0 = 4.5
    sim.set_particles([[4.0, y0], [12.0, y0]])  # 8 apart, h = 0.5: both isolated, density 0
    steps = 20
    for _ in range(steps):
        sim.run_fluid_solver(SUB_DT)
    state = sim.state()
    np.testing.assert_array_equal(state["density"], 0.0)
    np.testing.assert_array_equal(state["acceleration"], 0.0)  # the guard: 0 instead of 0/0
    np.testing.assert_allclose(state["velocity"][:, 1], -10 * steps * SUB_DT, rtol=1e-5)
    np.testing.assert_allclose(state["position"][:, 1], y0 - 10 * SUB_DT**2 * steps * (steps + 1) / 2, rtol=1e-5)
    np.testing.assert_array_equal(state["velocity"][:, 0], 0.0)


@pytest.mark.parametrize(
    "where, axis, sign", [((-0.1, 4.5), 0, 1), ((16.1, 4.5), 0, -1), ((8.0, -0.1), 1, 1), ((8.0, 9.1), 1, -1)]
)
def test_penalty_walls_push_back(runtime, where, axis, sign):
    sim = Simulation(runtime, Params(particle_num=2, gravity=(0.0, 0.0)), 0)
    sim.set_particles([where, [8.0, 4.5]])  # 0.1 outside one wall; the other particle far away
    sim.run_fluid_solver(SUB_DT)
    velocity = sim.state()["velocity"][0]
    expected = np.zeros(2)
    expected[axis] = sign * 3000 * 0.1 * SUB_DT  # a = wall_stiffness * 0.1 = 300
    np.testing.assert_allclose(velocity, expected, rtol=1e-5, atol=1e-9)


def test_mouse_pushes_particles_outward(runtime, seed):
    free, pushed = make(runtime, 1000, seed), make(runtime, 1000, seed)
    mouse = (8.0, 4.0)
    pushed.push(*mouse)
    free.step()
    pushed.step()
    x0 = make(runtime, 1000, seed).state()["position"]
    gained = pushed.state()["velocity"] - free.state()["velocity"]
    offset = x0 - mouse
    near = np.linalg.norm(offset, axis=1) < pushed.params.mouse_interaction_radius * 0.9
    assert near.sum() > 50
    outward = (gained[near] * offset[near]).sum(axis=1)
    assert (outward > 0).all(), "a particle near the mouse did not gain outward velocity"
    pushed.release()
    assert not pushed.mouse_down and pushed.mouse_pos == mouse  # the book keeps the last position


def test_no_nan_from_coincident_particles_or_the_mouse_centre(runtime):
    sim = Simulation(runtime, Params(particle_num=4), 0)
    sim.set_particles([[8.0, 4.5], [8.0, 4.5], [8.2, 4.5], [3.0, 3.0]])  # a coincident pair, a neighbour, a loner
    sim.push(8.0, 4.5)  # exactly on the coincident pair
    sim.step()
    state = sim.state()
    for key in ("position", "velocity", "density", "pressure", "acceleration"):
        assert np.isfinite(state[key]).all(), key


@pytest.mark.parametrize("variant, search", [("fixed", "all_pairs"), ("fixed", "grid"), ("book", "all_pairs")])
def test_long_run_falls_and_spreads_into_a_layer(runtime, variant, search):
    if variant == "book" and runtime.is_gpu:
        # The book's ForceCS divides by a spray particle's density ~0: on NVIDIA one such particle was flung 0.5
        # past a wall here (x < -0.5), on PoCL none. That instability is why variant=fixed is the default.
        pytest.xfail("variant=book may fling a spray particle through a wall (the book's 0/0 guard is missing)")
    sim = make(runtime, 1024, 0, variant=variant, search=search)
    for _ in range(240):  # 960 sub-steps
        sim.step()
    state = sim.state()
    x = state["position"]
    assert np.isfinite(x).all() and np.isfinite(state["velocity"]).all()
    # numpy prototype: overshoot <= 0.16 through the penalty walls; the chapter page allows 0.5
    assert (x >= -0.5).all() and (x <= np.asarray(sim.params.range) + 0.5).all()
    assert x[:, 1].max() < 4.5, "the fluid should have fallen into a layer"
    assert np.ptp(x[:, 0]) > 12, "the fluid should have spread over the floor"
    assert (state["density"] > 0).all(), "no particle should be left alone"


@pytest.mark.slow
def test_scene_sized_run_stays_bounded(runtime):
    """The scene itself (N = 8192, ball 5), 1200 sub-steps. The book variant blew up here after ~500 sub-steps (two
    spray particles of density ~0 exchanging velocity); the fixed variant must not."""
    sim = Simulation(runtime, Params(search="grid"), 0)
    mean_density, overshoot = [], 0.0
    for frame in range(1, 301):
        sim.step()
        if frame % 20 == 0:
            state = sim.state()
            x = state["position"]
            assert np.isfinite(x).all() and np.isfinite(state["velocity"]).all()
            overshoot = max(overshoot, float(-x.min()), float((x - np.asarray(sim.params.range)).max()))
            mean_density.append(float(state["mean_density"]))
            assert np.abs(state["velocity"]).max() < 40, "a particle is running away"
    # numpy float64 prototype: overshoot 0.28, mean density 7.6-10.6 (about 2 rho0: the fluid is compressible);
    # this run: 0.29 and 7.4-10.6
    assert overshoot <= 0.35
    assert 7.0 <= min(mean_density) and max(mean_density) <= 11.0
    assert (sim.state()["density"] > 0).all(), "no particle should be left alone at the end"


def test_grid_equals_all_pairs(runtime, seed):
    brute, grid = moving(runtime, 1000, seed, search="all_pairs"), moving(runtime, 1000, seed, search="all_pairs")
    grid.update(search="grid")  # live: same particles, other kernels
    for sim in (brute, grid):
        sim.density_cs()
        sim.pressure_cs()
        sim.force_cs()
    # same pairs, other summation order
    np.testing.assert_allclose(grid.density.get(), brute.density.get(), rtol=1e-5, atol=1e-6)
    a_brute = read_force(brute)
    np.testing.assert_allclose(read_force(grid), a_brute, rtol=0, atol=1e-4 * np.abs(a_brute).max())
    for _ in range(10):  # sub-steps; longer horizons diverge chaotically
        brute.run_fluid_solver(SUB_DT)
        grid.run_fluid_solver(SUB_DT)
    np.testing.assert_allclose(grid.state()["position"], brute.state()["position"], rtol=0, atol=1e-4 * 16)
    assert grid.stats()["grid cells"] == 32 * 18  # cell = h = 0.5 over 16 x 9


@pytest.mark.parametrize("search", ["all_pairs", "grid"])
def test_same_seed_is_bitwise_identical(runtime, search):
    a, b = make(runtime, 500, 7, search=search), make(runtime, 500, 7, search=search)
    for _ in range(20):
        a.step()
        b.step()
    for key, value in a.state().items():
        np.testing.assert_array_equal(value, b.state()[key], err_msg=key)
    assert not np.array_equal(make(runtime, 500, 8).state()["position"], make(runtime, 500, 7).state()["position"])


def test_initial_state_is_the_books_disc(runtime):
    sim = make(runtime, 4000, 3)
    state = sim.state()
    radius = np.linalg.norm(state["position"] - np.asarray(sim.params.range) / 2, axis=1)
    assert radius.max() <= sim.params.ball_radius * (1 + 1e-6)
    assert abs(np.median(radius) / sim.params.ball_radius - math.sqrt(0.5)) < 0.03  # uniform in the disc
    np.testing.assert_array_equal(state["velocity"], 0.0)


def test_scripted_mouse_holds_then_releases(runtime):
    sim = make(runtime, 300, 0, mouse=(8.0, 4.5, 2))
    sim.step()
    assert sim.mouse_down and sim.mouse_pos == (8.0, 4.5)
    sim.step()
    sim.step()
    assert not sim.mouse_down


# }}}

# {{{ parameters


@pytest.mark.parametrize(
    "overrides, message",
    [
        ({"search": "octree"}, "search must be one of all_pairs\\|grid"),
        ({"variant": "new"}, "variant must be one of fixed\\|book"),
        ({"gravity": (0.0,)}, "gravity must be 2 numbers"),
        ({"viscosity": float("nan")}, "viscosity must be a finite number"),
        ({"local_size": 100}, "local_size must be one of"),
    ],
)
def test_bad_parameters_name_the_field_and_range(overrides, message):
    """What test_params does not try on every field: unknown choices, a tuple's arity, NaN (ranges and the mouse
    limit are tried there)."""
    with pytest.raises(ValueError, match=message):
        Params(**overrides)


def test_bad_dt_and_mouse_are_refused(runtime):
    sim = make(runtime, 4)
    for dt in (0.0, -1.0, float("nan")):
        with pytest.raises(ValueError, match="dt must be in \\(0, 1\\]"):
            sim.step(dt)
    with pytest.raises(ValueError, match="mouse position must be finite"):
        sim.push(float("nan"), 1.0)


def test_dt_is_capped_by_max_allowable_timestep(runtime):
    sim = make(runtime, 50)
    sim.step(1 / 30)  # a slow frame: still 4 sub-steps of 1/240
    assert sim.time == pytest.approx(4 / 240)
    sim.step(1 / 1000)  # a fast frame: sub-steps of the frame time
    assert sim.time == pytest.approx(4 / 240 + 4 / 1000)


# }}}

# {{{ headless CLI


def test_cli_run_writes_the_chapter_page_arrays(capsys, tmp_path):
    out, png = tmp_path / "sph.npz", tmp_path / "sph.png"
    argv = [
        "run",
        "sph_2d",
        "--steps",
        "4",
        "--every",
        "2",
        "--seed",
        "1",
        "--set",
        "particle_num=300",
        "--set",
        "ball_radius=0.95",
        "--set",
        "mouse=8,4.5,2",
        "--set",
        "search=grid",
        "--out",
        str(out),
        "--png",
        str(png),
        "--png-size",
        "160x90",
    ]
    assert main(argv) == 0
    printed = capsys.readouterr().out
    assert "mean density" in printed and "grid occupied cells" in printed
    data = np.load(out)
    for key, shape in (
        ("position", (300, 2)),
        ("velocity", (300, 2)),
        ("density", (300,)),
        ("pressure", (300,)),
        ("acceleration", (300, 2)),
        ("position_history", (3, 300, 2)),
        ("mean_density_history", (3,)),
        ("kinetic_energy_history", (3,)),
        ("time", (3,)),
    ):
        assert data[key].shape == shape and data[key].dtype == np.float32, key
    params = json.loads(str(data["params"]))
    assert params["particle_num"] == 300 and params["mouse"] == [8.0, 4.5, 2] and params["search"] == "grid"
    np.testing.assert_allclose(data["time"], [0, 2 * 4 / 240, 4 * 4 / 240], rtol=1e-6)
    assert data["kinetic_energy_history"][0] == 0 and data["kinetic_energy_history"][-1] > 0
    from PIL import Image

    pixels = np.asarray(Image.open(png).convert("RGB"))
    assert pixels.shape == (90, 160, 3) and (pixels[..., 2] > 128).any()


# }}}

# {{{ view


def blue(pixels: np.ndarray) -> np.ndarray:
    """Water-coloured pixels: blue well above red (the particles; the box outline is grey)."""
    p = pixels.astype(int)
    return (p[..., 2] > 100) & (p[..., 2] > p[..., 0] + 60)


def to_pixels(camera, size, xy):
    """World (x, y) to (column, row) of an image whose row 0 is the top."""
    ndc = camera.projection() @ camera.view() @ np.array([xy[0], xy[1], 0.0, 1.0])
    return (ndc[0] + 1) / 2 * size[0] - 0.5, (1 - ndc[1]) / 2 * size[1] - 0.5


@pytest.mark.gl
def test_view_at_reset_draws_the_disc_in_water_blue(runtime, gl):
    from ugpcl.viewer.offscreen import frame
    from ugpcl.viewer.views import create_view

    scene = get("sph_2d")
    sim = scene.create(runtime, particle_num=2000, ball_radius=2.5, particle_radius=0.08)
    view = create_view(scene, gl, sim)
    view.show_box = False
    size = (192, 108)
    camera = view.make_camera()
    camera.aspect = size[0] / size[1]
    view.upload()
    query = gl.query(primitives=True)
    with query:
        pixels = frame(size).render(view, camera)
    assert query.primitives == 2 * sim.n, "one billboard (a 2-triangle strip) per particle"
    water = blue(pixels)
    cx, cy = to_pixels(camera, size, (8.0, 4.5))
    rx = to_pixels(camera, size, (8.0 + 2.5, 4.5))[0] - cx
    yy, xx = np.mgrid[0 : size[1], 0 : size[0]]
    dist = np.hypot(xx - cx, yy - cy) / rx
    assert water[dist < 0.8].mean() > 0.5, "the disc should be mostly water-coloured"
    assert not water[dist > 1.15].any(), "water outside the initial disc"
    background = ~foreground(pixels, view.background)
    for corner in (background[:4, :4], background[:4, -4:], background[-4:, :4], background[-4:, -4:]):
        assert corner.all(), "corners should be black"


@pytest.mark.gl
def test_view_after_a_dam_break_shows_water_at_rest_on_the_floor(runtime, gl):
    from ugpcl.viewer.offscreen import frame
    from ugpcl.viewer.views import create_view

    scene = get("sph_2d")
    sim = scene.create(
        runtime,
        particle_num=1024,
        ball_radius=1.77,
        start="dam_break",
        range=(8.0, 4.5),
        search="grid",
        particle_radius=0.06,
    )
    start_top = sim.state()["position"][:, 1].max()
    energy = []
    for _ in range(400):
        sim.step()
        energy.append(float(sim.state()["kinetic_energy"]))
    assert energy[-1] < 0.1 * max(energy), "the water should have calmed down"
    size = (256, 144)
    view = create_view(scene, gl, sim)
    camera = view.png_camera()
    camera.aspect = size[0] / size[1]
    view.upload()
    pixels = frame(size).render(view, camera)
    water = blue(pixels)
    left, floor = to_pixels(camera, size, (0.0, 0.0))
    right, ceiling = to_pixels(camera, size, (8.0, 4.5))
    left, right, floor, ceiling = int(left), int(right), int(floor), int(ceiling)
    level = sim.state()["position"][:, 1].max()
    assert level < 0.5 * start_top, "the column should have collapsed"
    half = (floor + ceiling) // 2
    assert not water[:half].any(), "water in the upper half of the box"
    bottom = water[floor - (floor - ceiling) // 6 : floor + 1, left : right + 1]
    columns = bottom.any(axis=0)
    assert columns.mean() > 0.95, "the water layer should cover the whole floor"
    assert not foreground(pixels[:4, :4], (0, 0, 0)).any() and not foreground(pixels[:4, -4:], (0, 0, 0)).any()


@pytest.mark.gl
def test_view_keys_and_mouse_drive_the_simulation(runtime, gl):
    from ugpcl.viewer.views import create_view

    scene = get("sph_2d")
    sim = scene.create(runtime, particle_num=1024)
    view = create_view(scene, gl, sim)
    h, m = sim.params.smoothlen, sim.params.particle_mass
    view.more_particles()
    assert sim.n == 2048 and sim.params.smoothlen == pytest.approx(h / math.sqrt(2))
    assert sim.params.particle_mass == pytest.approx(m / 2)
    view.fewer_particles()
    assert sim.n == 1024 and sim.params.smoothlen == pytest.approx(h)
    view.toggle_gravity()
    assert sim.params.gravity == (0.0, 0.0)
    view.toggle_gravity()
    assert sim.params.gravity == (0.0, -10.0)
    view.next_search()
    assert sim.params.search == "grid"
    b, mu = sim.params.pressure_stiffness, sim.params.viscosity
    view.stiffer()
    view.more_viscous()
    assert sim.params.pressure_stiffness == pytest.approx(1.5 * b) and sim.params.viscosity == pytest.approx(2 * mu)
    steps_before = sim.steps
    view.next_color_mode()
    assert view.color_mode == "speed" and sim.steps == steps_before
    camera = view.make_camera()
    camera.aspect = 16 / 9
    view.on_drag(camera, 0.5, 0.5, 0.01, 0.0)
    assert sim.mouse_down and sim.mouse_pos == pytest.approx((8.0, 4.5), abs=1e-6)
    view.on_release(camera)
    assert not sim.mouse_down
    assert {k.key for k in view.keys} >= {"[", "]", "+", "-", ".", ",", "g", "k", "tab"}
    view.upload()
    assert len(view.status()) == 2


# }}}


@pytest.mark.oclgrind
@pytest.mark.parametrize("search", ["all_pairs", "grid"])
def test_kernels_on_oclgrind(oclgrind, search, seed):
    n = 45  # not a multiple of the local size: padding work-items must stay out
    params = Params(particle_num=n, ball_radius=0.4, local_size=16, search=search)
    sim = Simulation(oclgrind, params, seed)
    sim.push(8.0, 4.5)
    sim.run_fluid_solver(SUB_DT)  # DensityCS/PressureCS/ForceCS/IntegrateCS (or the grid build and grid kernels)
    assert np.isfinite(sim.state()["position"]).all()
    assert np.array_equal(sim.packed_positions().get(), sim.state()["position"])  # PackPositions, the view's copy


@pytest.mark.gl
def test_view_uploads_only_what_the_colour_mode_shows(runtime, gl):
    """The water colour needs positions only (PackPositions: 8 bytes a particle, the positions exactly); the speed
    colour whole records (16); density and pressure add their field (4). The mean density for the status line is
    read on top, through the device link and not into GL."""
    from ugpcl.viewer.views import create_view

    sim = get("sph_2d").create(runtime, particle_num=300)
    sim.step()
    view = create_view(get("sph_2d"), gl, sim)
    n = sim.n
    for mode, particle_bytes, field_bytes in (
        ("water", 8, 0),
        ("speed", 16, 0),
        ("density", 16, 4),
        ("pressure", 16, 4),
    ):
        view.color_mode = mode
        before = runtime.read_back_bytes
        view.upload()
        mean_read = 0 if mode == "density" else 4  # the density for the mean, when the mode did not read it
        assert runtime.read_back_bytes - before == n * (particle_bytes + field_bytes + mean_read), mode
        if mode == "water":
            uploaded = np.frombuffer(view.particles.buffer.read(n * 8), np.float32).reshape(n, 2)
            assert np.array_equal(uploaded, sim.state()["position"])
