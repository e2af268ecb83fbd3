"""GPU cloth (vol.4 ch.3; docs/chapters/14-cloth.md): CSInit/CSSimulation against numpy, the golden hanging run,
collision and stability invariants, ping-pong bookkeeping, the headless CLI, both views, Oclgrind."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from helpers import first_mismatch, foreground

from ugpcl.cli import main
from ugpcl.geometry.cloth import grid_triangles, spring_pairs
from ugpcl.registry import get
from ugpcl.scenes.cloth import MAIN_SCENE, SIMULATION_KERNELS, Params, Simulation

# {{{ numpy float64 reference, written from the book's Kernels.compute listing

DIRECTIONS = [(-1, -1), (0, -1), (1, -1), (1, 0), (1, 1), (0, 1), (-1, 1), (-1, 0), (-2, -2), (2, -2), (2, 2), (-2, 2)]
"""Book: m_Directions; k < 8 is the ring round the particle (normal), k >= 8 the bend springs."""


def init_reference(width: int, height: int, rest: float) -> np.ndarray:
    """CSInit's positions (H, W, 3): idx * rest - total_len / 2, z = 0."""
    y, x = np.mgrid[0:height, 0:width].astype(np.float64)
    return np.stack([x * rest - width * rest / 2, y * rest - height * rest / 2, np.zeros_like(x)], -1)


def cloth_step_reference(pos, prev, normal, *, rest, gravity, stiffness, damp, inv_mass, dt, sphere=None):
    """One CSSimulation substep for every particle, float64. Returns (pos, prev, normal) after the substep and a
    mask of particles whose ring has a pair of directions within 1e-4 of 90 degrees (float32 may decide the
    'dot > 0' test of the normal either way there)."""
    pos, prev, normal = (np.asarray(a, np.float64) for a in (pos, prev, normal))
    height, width, _ = pos.shape
    vel = (pos - prev) / dt
    force = np.broadcast_to(np.asarray(gravity, np.float64), pos.shape).copy()
    n = np.zeros_like(pos)
    last = np.zeros_like(pos)
    iters = np.zeros((height, width))
    ambiguous = np.zeros((height, width), bool)
    padded = np.full((height + 4, width + 4, 3), np.nan)
    padded[2:-2, 2:-2] = pos
    y, x = np.mgrid[0:height, 0:width]
    for k, (dx, dy) in enumerate(DIRECTIONS):
        valid = (x + dx >= 0) & (x + dx < width) & (y + dy >= 0) & (y + dy < height)
        diff = padded[2 + dy : 2 + dy + height, 2 + dx : 2 + dx + width] - pos
        length = np.linalg.norm(diff, axis=-1)
        direction = diff / np.where(valid, length, 1.0)[..., None]
        v = valid[..., None]
        if k < 8:
            cosine = np.sum(direction * last, axis=-1)
            counts = valid & (iters > 0)
            ambiguous |= counts & (np.abs(cosine) < 1e-4)
            add = (counts & (cosine > 0))[..., None]
            n = np.where(add, n + np.cross(last, direction), n)
        last = np.where(v, direction, last)
        rest_length = rest * math.hypot(dx, dy)
        force = np.where(v, force + direction * (length - rest_length)[..., None] * stiffness - vel * damp, force)
        if k < 8:
            iters += valid
    n = n / -(iters - 1.0)[..., None]
    n = n / np.linalg.norm(n, axis=-1, keepdims=True)
    new = 2.0 * pos - prev + force * inv_mass * dt * dt
    if sphere is not None:
        center, radius = np.asarray(sphere[:3], np.float64), float(sphere[3])
        offset = new - center
        dist = np.linalg.norm(offset, axis=-1, keepdims=True)
        new = np.where(dist < radius, center + offset / dist * radius, new)
    pinned = (y == height - 1)[..., None]  # the book returns before writing anything
    return np.where(pinned, pos, new), np.where(pinned, prev, pos), np.where(pinned, normal, n), ambiguous


def pack_surface_reference(pos, normal) -> np.ndarray:
    """PackSurface's (..., 4) uint32 words: the positions' float32 bits, then the normal as round(n * 511) + 511 in
    10 bits a component (x lowest; a NaN component as 0), rounded half to even as the kernel's _rte."""
    normal = np.nan_to_num(np.asarray(normal, np.float32), nan=0.0)
    q = (np.clip(np.rint(normal * np.float32(511.0)), -511, 511) + 511).astype(np.uint32)
    word = q[..., 0] | q[..., 1] << 10 | q[..., 2] << 20
    return np.concatenate([np.asarray(pos, np.float32).view(np.uint32), word[..., None]], axis=-1)


def reference_args(p: Params, sphere=None) -> dict:
    return {
        "rest": p.rest_length,
        "gravity": p.gravity,
        "stiffness": p.stiffness,
        "damp": p.damp,
        "inv_mass": 1.0 / p.mass,
        "dt": p.substep_dt,
        "sphere": sphere if p.sphere else None,
    }


# }}}


def make(runtime, res=(16, 16), kernel=None, **overrides) -> Simulation:
    """A cloth of res particles; kernel picks the substep's kernel (default: the one the device gets)."""
    sim = Simulation(runtime, Params(res=res, **overrides))
    if kernel is not None:
        sim.simulation_kernel = kernel
    return sim


def perturbed(width: int, height: int, rest: float, seed: int, amount: float = 0.2):
    """Init positions moved by up to +-amount*rest in x, y, z, and previous positions moved again (velocities)."""
    rng = np.random.default_rng(seed)
    base = init_reference(width, height, rest)
    pos = base + rng.uniform(-amount, amount, base.shape) * rest
    prev = pos + rng.uniform(-0.02, 0.02, base.shape) * rest
    pos[-1], prev[-1] = base[-1], base[-1]  # the pinned row stays where CSInit put it
    return pos, prev


# {{{ layout and init (checks 1, 2)


@pytest.mark.parametrize("res", [(2, 2), (15, 15), (16, 16), (17, 17), (33, 7)])  # tiny, block-1, block, block+1, odd
def test_cs_init_lays_the_grid_out_as_the_book(runtime, res):
    width, height = res
    rest = 0.05
    sim = make(runtime, res, rest_length=rest)
    # the kernel's float32 arithmetic: idx * rest - float32(total_len) * 0.5
    y, x = np.mgrid[0:height, 0:width].astype(np.float32)
    r = np.float32(rest)
    half = np.float32(width * rest) * np.float32(0.5), np.float32(height * rest) * np.float32(0.5)
    expected = np.stack([x * r - half[0], y * r - half[1], np.zeros_like(x)], -1)
    for name in ("pos", "prev", "pos_write", "prev_write"):  # CSInit + the two Blits
        data = sim.read(name)
        np.testing.assert_array_equal(data[..., :3], expected, err_msg=name)
        np.testing.assert_array_equal(data[..., 3], 1.0)
    np.testing.assert_array_equal(sim.read("normal"), np.broadcast_to([0.0, 0.0, -1.0, 1.0], (height, width, 4)))
    np.testing.assert_allclose(expected, init_reference(width, height, rest), atol=1e-6)


def test_buffers_are_float4_rows_of_w(runtime):
    sim = make(runtime, (5, 3))
    for name in ("pos", "prev", "normal"):
        assert sim.read(name).shape == (3, 5, 4) and sim.read(name).dtype == np.float32
    assert grid_triangles(5, 3).shape == (2 * 4 * 2, 3)
    pairs = spring_pairs(5, 3)
    assert len(pairs["structural"]) == 4 * 3 + 5 * 2
    assert len(pairs["shear"]) == 2 * 4 * 2
    assert len(pairs["bend"]) == 2 * 3 * 1


# }}}

# {{{ CSSimulation against the reference (check 3)


# both substep kernels on every device: the book's work-item per particle and the CPU's 16 lanes per work-item
# (17 and 33 wide: a row's last work-item holds 1 particle; 2 and 15: fewer than 16)
@pytest.mark.parametrize("kernel", SIMULATION_KERNELS)
@pytest.mark.parametrize("res", [(2, 2), (15, 15), (16, 16), (17, 17), (33, 7)])
def test_cs_simulation_matches_reference(runtime, res, kernel, seed):
    width, height = res
    rest = 0.05
    sim = make(runtime, res, kernel, rest_length=rest, timestep=0.005, substeps=1, stiffness=1e4)
    pos, prev = perturbed(width, height, rest, seed)
    sim.set_positions(pos, prev)
    # a sphere overlapping the cloth's lower half: some particles end inside it and are pushed out
    sim.sphere_params = np.array([0.0, -0.3 * height * rest, 0.02, 0.25 * max(width, height) * rest], np.float32)
    normal_before = sim.read("normal")[..., :3]
    state_before = sim.state()
    sim.cs_simulation()
    expected_pos, expected_prev, expected_normal, ambiguous = cloth_step_reference(
        state_before["pos"], state_before["prev_last"], normal_before, **reference_args(sim.params, sim.sphere_params)
    )
    after = sim.state()
    assert after["pos"].shape == expected_pos.shape
    # float32 kernel vs float64: positions ~0.5 m carry ~3e-8 rounding, forces ~1e2 N scaled by dt^2 = 2.5e-5
    for name, actual, expected in (
        ("pos", after["pos"], expected_pos),
        ("prev", after["prev_last"], expected_prev),
        ("normal", after["normal"][~ambiguous], expected_normal[~ambiguous]),
    ):
        assert np.allclose(actual, expected, rtol=1e-5, atol=1e-6), f"{name}: " + first_mismatch(
            actual.reshape(-1, 3), expected.reshape(-1, 3), 1e-5, 1e-6
        )
    assert ambiguous.mean() < 0.05
    if width * height > 4:
        moved = np.linalg.norm(expected_pos - (2 * state_before["pos"] - state_before["prev_last"]), axis=-1)
        assert moved.max() > 1e-4, "the sphere and springs should move some particles measurably"


@pytest.mark.parametrize("variant", ["fixed", "book"])
def test_both_substep_kernels_agree(runtime, variant, seed):
    """CSSimulation and CSSimulation_cpu on a 50 x 37 cloth (4 lane groups per row, the last with 2 particles),
    4 substeps through a sphere: the same sums in the same order, equal up to float rounding."""
    width, height, rest = 50, 37, 0.05
    sims = [make(runtime, (width, height), k, rest_length=rest, variant=variant) for k in SIMULATION_KERNELS]
    pos, prev = perturbed(width, height, rest, seed)
    for sim in sims:
        sim.set_positions(pos, prev)
        sim.sphere_params = np.array([0.1, -0.4, 0.05, 0.5], np.float32)
        sim.step()
    a, b = (sim.state() for sim in sims)
    for key in ("pos", "prev_last"):
        np.testing.assert_allclose(a[key], b[key], rtol=1e-6, atol=1e-6, err_msg=key)
    # a normal may flip where two ring directions are 90 degrees apart to rounding (cloth_step_reference's mask)
    assert np.mean(np.abs(a["normal"] - b["normal"]).max(axis=-1) < 1e-4) > 0.99
    assert np.abs(a["pos"] - pos).max() > 1e-3, "the substeps should move the cloth"


def test_substep_kernel_is_chosen_by_device_type(runtime):
    sim = make(runtime, (20, 20))
    expected = "CSSimulation" if runtime.is_gpu else "CSSimulation_cpu"  # the fixture's devices: PoCL or a GPU
    assert sim.stats()["CSSimulation kernel"] == expected == sim.simulation_kernel
    with pytest.raises(ValueError, match="simulation_kernel must be one of CSSimulation\\|CSSimulation_cpu"):
        sim.simulation_kernel = "CSSimulationCPU"


@pytest.mark.parametrize("kernel", SIMULATION_KERNELS)
def test_live_parameters_and_a_new_sphere_reach_the_next_substep(runtime, kernel, seed):
    """CSSimulation's scalar arguments are made once per Params object and sphere array: an update() of live
    fields, or a new sphere_params, must still reach the very next launch (checked against the reference)."""
    width, height, rest = 15, 11, 0.05
    sim = make(runtime, (width, height), kernel, rest_length=rest, timestep=0.005, substeps=1)
    pos, prev = perturbed(width, height, rest, seed)
    sim.set_positions(pos, prev)
    sim.cs_simulation()
    sim.update(stiffness=2500.0, damp=0.5, mass=2.0, gravity=(0.5, -3.0, 1.0), timestep=0.004)
    sim.sphere_params = np.array([0.0, -0.2 * height * rest, 0.02, 0.25 * width * rest], np.float32)
    normal_before = sim.read("normal")[..., :3]
    before = sim.state()
    sim.cs_simulation()
    expected_pos, expected_prev, _, _ = cloth_step_reference(
        before["pos"], before["prev_last"], normal_before, **reference_args(sim.params, sim.sphere_params)
    )
    after = sim.state()
    for name, actual, expected in (("pos", after["pos"], expected_pos), ("prev", after["prev_last"], expected_prev)):
        assert np.allclose(actual, expected, rtol=1e-5, atol=1e-6), f"{name}: " + first_mismatch(
            actual.reshape(-1, 3), expected.reshape(-1, 3), 1e-5, 1e-6
        )


@pytest.mark.parametrize("kernel", SIMULATION_KERNELS)
def test_a_frame_writes_the_normal_on_its_last_substep_only(runtime, kernel, seed):
    """step() skips the normal's store on all but a frame's last substep: positions and the frame's normal are those
    of substeps that all write it, bit for bit, and a substep without the store leaves the normal as it was."""
    width, height, rest = 15, 11, 0.05
    frames = [make(runtime, (width, height), kernel, rest_length=rest, substeps=4) for _ in range(2)]
    for sim in frames:
        sim.set_positions(*perturbed(width, height, rest, seed))
    frames[0].step()
    for _ in range(4):
        frames[1].cs_simulation()  # write_normal: every substep, as the book
    for name in ("pos", "prev", "normal"):
        np.testing.assert_array_equal(frames[0].read(name), frames[1].read(name), err_msg=name)
    normal, pos = frames[0].read("normal"), frames[0].read("pos")
    frames[0].cs_simulation(write_normal=False)
    np.testing.assert_array_equal(frames[0].read("normal"), normal)
    assert not np.array_equal(frames[0].read("pos"), pos)


@pytest.mark.parametrize("kernel", SIMULATION_KERNELS)
def test_collision_pushes_particles_to_the_sphere_surface(runtime, kernel):
    sim = make(runtime, (16, 16), kernel, rest_length=0.05, timestep=0.005, substeps=1, gravity=(0.0, 0.0, 0.0))
    sim.sphere_params = np.array([0.0, -0.1, 0.05, 0.3], np.float32)  # centre just behind the flat cloth
    sim.cs_simulation()
    pos = sim.state()["pos"][:-1]
    dist = np.linalg.norm(pos - sim.sphere_params[:3], axis=-1)
    inside_before = np.linalg.norm(init_reference(16, 16, 0.05)[:-1] - sim.sphere_params[:3], axis=-1) < 0.3
    assert inside_before.sum() > 10
    np.testing.assert_allclose(dist[inside_before], 0.3, rtol=1e-5)  # moved along (p - c) onto the surface
    assert (pos[inside_before][:, 2] < 0).all(), "pushed towards -z, away from the centre behind the cloth"


# }}}

# {{{ invariants (checks 4, 6, 7, 8 and the golden run, check 5)


@pytest.mark.parametrize("kernel", SIMULATION_KERNELS)
def test_rest_state_stays_at_rest(runtime, kernel):
    sim = make(runtime, (16, 16), kernel, rest_length=0.05, gravity=(0.0, 0.0, 0.0), sphere=False, timestep=0.02)
    init = sim.state()["pos"]
    for _ in range(100):  # 100 frames x 4 substeps = 400 substeps
        sim.step()
    drift = np.abs(sim.state()["pos"] - init).max()
    assert drift <= 1e-5, f"max |pos - init| = {drift:.3g} (measured: 1.2e-7)"


@pytest.fixture(scope="module")
def golden_run(runtime):
    """The main scene for 1800 frames at 60 fps (sphere sweeps through the cloth and back), checked every frame."""
    sim = get("cloth").create(runtime)
    init_top = sim.read("pos")[-1].copy()
    record = {"z_before_550": 0.0, "normal_dev_before_550": 0.0, "collision": np.inf, "pinned_ok": True}
    record["length_range"] = [np.inf, 0.0]
    record["finite"] = True
    for frame in range(1, 1801):
        sim.step(1.0 / 60.0)
        state = sim.state()
        pos, normal, sphere = state["pos"], state["normal"], state["sphere"]
        if frame < 550:
            record["z_before_550"] = max(record["z_before_550"], float(np.abs(pos[..., 2]).max()))
            dev = np.abs(normal[:-1] - [0.0, 0.0, -1.0]).max()  # the pinned row keeps CSInit's normal
            record["normal_dev_before_550"] = max(record["normal_dev_before_550"], float(dev))
        if frame == 300:
            record["at_300"] = (pos.copy(), float(np.linalg.norm(pos - state["prev_last"], axis=-1).max()))
        record["collision"] = min(
            record["collision"], float((np.linalg.norm(pos[:-1] - sphere[:3], axis=-1)).min() - sphere[3])
        )
        record["finite"] &= bool(np.isfinite(pos).all() and np.isfinite(normal).all())
        record["pinned_ok"] &= bool(np.array_equal(sim.read("pos")[-1], init_top))
        structural = np.concatenate([np.linalg.norm(np.diff(pos, axis=a), axis=-1).ravel() for a in (0, 1)])
        record["length_range"] = [
            min(record["length_range"][0], structural.min()),
            max(record["length_range"][1], structural.max()),
        ]
    record["sim"] = sim
    return record


def test_golden_hanging_cloth_after_300_frames(golden_run):
    pos, max_step = golden_run["at_300"]
    bottom = pos[0]
    rest = MAIN_SCENE["rest_length"]
    # golden values measured with a float32 numpy port of the kernels
    assert bottom[:, 1].mean() == pytest.approx(-2.194, abs=0.005)
    assert bottom[31:33, 1].mean() == pytest.approx(-2.237, abs=0.005)
    assert bottom[-1, 0] - bottom[0, 0] == pytest.approx(2.910, abs=0.005)
    assert max_step / (MAIN_SCENE["timestep"] / 4) < 1e-3, "max speed (one substep's displacement / dt)"
    mirror = pos[:, :, 0] + pos[:, ::-1, 0]
    np.testing.assert_allclose(mirror, -rest, atol=1e-5)  # the cloth's centre is at x = -rest/2
    np.testing.assert_array_equal(pos[..., 2], 0.0)
    # structural springs of the hanging cloth, from cloth_step_reference (float64, 1200 substeps, same bottom-row
    # numbers as above): longest 0.10309 (the two vertical springs below the pinned corners), shortest 0.02745
    # (rows squeezed sideways near the bottom). A bound of 0.027-0.060 (1.2 x rest) cannot hold with these numbers:
    # the mean vertical spring is already (1.55 + 2.194) / 63 = 0.0594
    vertical = np.linalg.norm(np.diff(pos, axis=0), axis=-1)
    horizontal = np.linalg.norm(np.diff(pos, axis=1), axis=-1)
    assert vertical.max() == pytest.approx(0.10309, abs=3e-4)
    assert {tuple(np.unravel_index(np.argmax(vertical), vertical.shape))} <= {(62, 0), (62, 63)}
    assert min(vertical.min(), horizontal.min()) == pytest.approx(0.02745, abs=3e-4)
    assert horizontal.max() == pytest.approx(rest, abs=1e-6), "no row is stretched sideways (the pinned row)"


def test_no_contact_before_frame_550(golden_run):
    assert golden_run["z_before_550"] == 0.0, "z must stay exactly 0 before the sphere reaches the cloth"
    assert golden_run["normal_dev_before_550"] <= 1e-6


def test_pinned_row_never_moves(golden_run):
    assert golden_run["pinned_ok"], "the top row of the read buffer changed bits"


def test_collision_invariant_every_frame(golden_run):
    assert golden_run["collision"] >= -1e-4, f"a particle sat {-golden_run['collision']:.3g} inside the sphere"


def test_stable_through_the_sphere_sweep(golden_run):
    assert golden_run["finite"]
    lo, hi = golden_run["length_range"]
    rest = MAIN_SCENE["rest_length"]
    # measured here 0.0267 - 0.112: the top corners carry an edge column's weight on two springs (0.103 already
    # while hanging still, as the numpy reference: test_golden_hanging_cloth_after_300_frames). [0.5, 1.5] * rest
    # does not hold for the book's cloth (docs/chapters/14-cloth.md, "Known limits").
    assert 0.5 * rest <= lo and hi <= 2.5 * rest, (lo, hi)
    assert np.abs(golden_run["sim"].state()["pos"][..., 2]).max() > 0.1, "the sphere reached the cloth"


def test_frames_of_substeps_equal_single_substeps(runtime, seed):
    """Check 8: N frames of S substeps == N*S launches of one substep; after an odd count the pairs are swapped."""
    frames, substeps = 3, 3
    a = make(runtime, (17, 9), rest_length=0.05, substeps=substeps, timestep=0.015, sphere_motion=False)
    b = make(runtime, (17, 9), rest_length=0.05, substeps=1, timestep=0.005, sphere_motion=False)
    pos, prev = perturbed(17, 9, 0.05, seed, amount=0.05)
    a.set_positions(pos, prev)
    b.set_positions(pos, prev)
    first_read = a.pos.read
    for _ in range(frames):
        a.step()
    for _ in range(frames * substeps):
        b.cs_simulation()
    assert a.pos.read is not first_read and a.pos.write is first_read, "9 substeps: the references are swapped"
    for key in ("pos", "prev_last", "normal"):
        np.testing.assert_array_equal(a.state()[key], b.state()[key], err_msg=key)
    # the write halves hold the state one substep earlier (never the same buffer as the read halves)
    assert not np.array_equal(a.read("pos_write"), a.read("pos"))


@pytest.mark.parametrize("kernel", SIMULATION_KERNELS)
def test_frames_with_a_sweeping_sphere_match_the_reference(runtime, kernel):
    """Checks 3 and 8 together through the scene's own step(): 8 frames of 4 substeps while the sphere (placed by
    the wrapper at the book's ColliderTranslate position for each frame) sweeps into the hanging cloth, against
    cloth_step_reference fed with the sphere computed here. Later the draped cloth amplifies float32 rounding
    (1e-4 after 17 frames), so the horizon is short."""
    center_z, length_z, frame_dt = -0.1, 0.35, 0.5  # sphere z 0.25 -> 0.21, radius 0.26: contact from frame 0
    sim = make(
        runtime,
        (16, 16),
        kernel,
        rest_length=0.05,
        timestep=0.02,
        sphere_scale=0.5,
        translate_center_z=center_z,
        translate_length_z=length_z,
    )
    pos = init_reference(16, 16, 0.05)
    prev, normal = pos.copy(), np.broadcast_to([0.0, 0.0, -1.0], pos.shape)
    for frame in range(8):
        sim.step(frame_dt)
        sphere = [0.0, 0.0, center_z + length_z * math.cos(0.125 * frame * frame_dt), 0.5 * 0.5 + 0.01]
        np.testing.assert_allclose(sim.state()["sphere"], sphere, rtol=1e-6, atol=1e-7)
        args = reference_args(sim.params, sphere)
        for _ in range(4):
            pos, prev, normal, ambiguous = cloth_step_reference(pos, prev, normal, **args)
        state = sim.state()
        # float32 against float64 through the contact: observed 1.1e-6 at frame 8
        np.testing.assert_allclose(state["pos"], pos, rtol=0, atol=1e-5, err_msg=f"frame {frame}")
        np.testing.assert_allclose(state["prev_last"], prev, rtol=0, atol=1e-5, err_msg=f"frame {frame}")
    assert -pos[..., 2].min() > 0.05, "the sphere should have pushed the cloth towards -z"
    assert ambiguous.mean() < 0.05
    np.testing.assert_allclose(state["normal"][~ambiguous], normal[~ambiguous], rtol=0, atol=1e-4)


def test_mass_scales_gravity_as_the_book_unless_physical(runtime):
    """Book: gravity is a force (a = g / m); physical_gravity makes it an acceleration."""

    def first_drop(**overrides) -> float:
        sim = make(runtime, (8, 8), rest_length=0.05, sphere=False, substeps=1, timestep=0.005, **overrides)
        sim.cs_simulation()
        return float(sim.state()["pos"][0, 4, 1] - init_reference(8, 8, 0.05)[0, 4, 1])

    drop = first_drop(mass=1.0)
    assert drop == pytest.approx(-9.81 * 0.005**2, rel=1e-3)
    assert first_drop(mass=2.0) == pytest.approx(drop / 2, rel=1e-3)
    assert first_drop(mass=2.0, physical_gravity=True) == pytest.approx(drop, rel=1e-3)


@pytest.mark.parametrize("kernel", SIMULATION_KERNELS)
def test_coincident_particles_nan_in_book_variant_only(runtime, kernel):
    pos = init_reference(6, 6, 0.05)
    pos[2, 3] = pos[2, 2]  # two particles on top of each other: a spring of length 0
    fixed = make(runtime, (6, 6), kernel, rest_length=0.05)
    book = make(runtime, (6, 6), kernel, rest_length=0.05, variant="book")
    for sim in (fixed, book):
        sim.set_positions(pos)
        sim.step()
    assert np.isfinite(fixed.state()["pos"]).all() and np.isfinite(fixed.state()["normal"]).all()
    assert np.isnan(book.state()["pos"][2, 2]).any(), "book: normalize(0) of a zero-length spring is NaN"


def test_divergence_is_reported_not_silent(runtime):
    sim = make(runtime, (16, 16), rest_length=0.05, timestep=0.1, substeps=1)  # dt*sqrt(12k/m) = 34.6
    for _ in range(50):
        sim.step()
    assert sim.params.stability > 2
    assert str(sim.stats()["diverged"]).startswith("yes")
    stable = make(runtime, (16, 16), rest_length=0.05, timestep=0.02)
    stable.step()
    assert stable.stats()["diverged"] is False and stable.params.stability < 2


def test_same_params_same_device_is_bitwise_identical(runtime):
    a, b = make(runtime, (20, 20), rest_length=0.05), make(runtime, (20, 20), rest_length=0.05)
    for _ in range(20):
        a.step()
        b.step()
    for key, value in a.state().items():
        np.testing.assert_array_equal(value, b.state()[key])


# }}}

# {{{ parameters


# out-of-range values (every field of every scene) and the res[0]*res[1] limit: tests/test_params.py
@pytest.mark.parametrize(
    "overrides, message",
    [
        ({"stiffness": float("nan")}, "stiffness must be a finite number"),
        ({"num_threads_xy": 3}, "num_threads_xy must be one of"),
        ({"variant": "x"}, "variant must be one of book\\|fixed"),
        ({"gravity": (0.0, -9.81)}, "gravity must be 3 numbers"),
    ],
)
def test_bad_parameters_name_the_field(overrides, message):
    with pytest.raises(ValueError, match=message):
        Params(**overrides)


def test_collider_follows_the_book(runtime):
    sim = make(runtime, (8, 8), translate_center_z=0.5, translate_length_z=3.0, sphere_scale=2.0)
    np.testing.assert_allclose(sim.sphere_params, [0.0, 0.0, 3.5, 1.01], rtol=1e-6)  # starts at centre + length
    for _ in range(60):
        sim.step(0.5)
    np.testing.assert_allclose(sim.state()["sphere"][2], 0.5 + 3.0 * math.cos(0.125 * 59 * 0.5), rtol=1e-5)
    sim.update(sphere_motion=False)
    z = sim.sphere_params[2]
    sim.step(0.5)
    sim.step(0.5)
    assert sim.sphere_params[2] != z and sim.state()["sphere"][2] == sim.collider(60 * 0.5)[2]
    sim.step(0.5)
    assert sim.state()["sphere"][2] == sim.collider(60 * 0.5)[2], "frozen while sphere_motion is off"


# }}}

# {{{ headless CLI


def test_cli_run_writes_the_chapter_page_arrays(capsys, tmp_path):
    out, png, mesh = tmp_path / "c.npz", tmp_path / "c.png", tmp_path / "c.obj"
    argv = ["run", "cloth", "--steps", "6", "--every", "3", "--set", "res=12,10", "--set", "substeps=2"]
    code = main([*argv, "--out", str(out), "--png", str(png), "--png-size", "64x48", "--mesh", str(mesh)])
    _, err = capsys.readouterr()
    assert code == 0, err
    data = np.load(out)
    for key in ("pos", "normal", "prev_last"):
        assert data[key].shape == (10, 12, 3) and data[key].dtype == np.float32
    assert data["sphere"].shape == (4,) and int(data["frame"]) == 6
    assert data["pos_history"].shape == (3, 10, 12, 3) and data["normal_history"].shape == (3, 10, 12, 3)
    assert data["sphere_history"].shape == (3, 4) and data["frame_history"].tolist() == [0, 3, 6]
    params = json.loads(str(data["params"]))
    assert params["res"] == [12, 10] and params["substeps"] == 2 and params["timestep"] == 0.02
    assert png.stat().st_size > 0
    assert sum(line.startswith("f ") for line in mesh.read_text().splitlines()) == 2 * 11 * 9
    assert main(["run", "cloth", "--set", "substeps=0", "--out", str(out)]) == 2
    assert "substeps must be in [1, 16]" in capsys.readouterr().err


# }}}

# {{{ views


@pytest.mark.parametrize("res", [(17, 17), (33, 7)])  # 289 and 231 particles: a part group of 256 either way
def test_pack_surface_keeps_positions_exact_and_normals_to_10_bits(runtime, res, seed):
    """PackSurface (the views' upload): the positions' float32 bits and the normals as 10-bit signed components."""
    sim = make(runtime, res)
    sim.set_positions(*perturbed(*res, 0.02, seed))
    sim.cs_simulation()  # every particle gets a ring normal
    state = sim.state()
    packed = sim.pack_surface().get()
    assert packed.dtype == np.uint32 and packed.shape == (res[1], res[0], 4)
    np.testing.assert_array_equal(packed[..., :3].view(np.float32), state["pos"])
    np.testing.assert_array_equal(packed, pack_surface_reference(state["pos"], state["normal"]))
    decoded = ((packed[..., 3:] >> np.array([0, 10, 20], np.uint32)) & 1023) / 511.0 - 1.0  # as cloth.vert
    assert np.abs(decoded - state["normal"]).max() <= 0.5 / 511 + 1e-6


@pytest.fixture(scope="module")
def draped(runtime):
    """A 32 x 32 cloth (3.2 m, as the main scene) after the sphere has pushed through it (frame 1000: z = -1.47)."""
    sim = get("cloth").create(runtime, res=(32, 32), rest_length=0.1)
    for _ in range(1000):
        sim.step()
    return sim


def project(camera, points: np.ndarray, size) -> tuple[np.ndarray, np.ndarray]:
    clip = (camera.projection() @ camera.view() @ np.column_stack([points, np.ones(len(points))]).T).T
    ndc = clip[:, :2] / clip[:, 3:]
    px = np.round((ndc[:, 0] + 1) / 2 * size[0] - 0.5).astype(int)
    py = np.round((1 - ndc[:, 1]) / 2 * size[1] - 0.5).astype(int)
    return px, py


@pytest.mark.gl
def test_surface_view_shows_the_cloth_draped_over_the_sphere(runtime, gl, draped):
    from ugpcl.viewer.offscreen import frame
    from ugpcl.viewer.views import create_view

    scene = get("cloth")
    view = create_view(scene, gl, draped)
    camera = view.png_camera()
    size = (160, 120)
    camera.aspect = size[0] / size[1]
    view.upload()
    query = gl.query(primitives=True)
    with query:
        pixels = frame(size).render(view, camera)
    sphere_triangles = view.sphere_ibo.size // 12
    assert query.primitives == 2 * 31 * 31 + sphere_triangles
    pos = draped.state()["pos"]
    assert pos[..., 2].min() < -1.0, "the sphere pushed the cloth towards the camera"
    px, py = project(camera, pos.reshape(-1, 3), size)
    inside = (px >= 0) & (px < size[0]) & (py >= 0) & (py < size[1])
    assert inside.all()
    mask = foreground(pixels, view.background)
    rgb = pixels[py, px].astype(int)
    cloth_coloured = mask[py, px] & (rgb[:, 2] > rgb[:, 0] + 40)  # blue albedo (0, 0.27, 1)
    assert cloth_coloured.mean() > 0.9, "most cloth vertices should show the cloth's blue"
    red = (pixels[..., 0].astype(int) > pixels[..., 2].astype(int) + 40).sum()
    assert red > 0, "the red sphere shows under the cloth's hem"
    assert mask.mean() > 0.1


@pytest.mark.gl
def test_surface_is_lit_on_both_sides(runtime, gl):
    """Two-sided lighting: the picture does not depend on which way the stored normals point; the front (facing
    the book's camera and the light) is bright, the back only gets ambient light."""
    from ugpcl.viewer.camera import OrbitCamera
    from ugpcl.viewer.offscreen import frame
    from ugpcl.viewer.views import create_view

    scene = get("cloth")
    sim = scene.create(runtime, res=(16, 16), rest_length=0.2, sphere=False)  # flat, 3.2 m, no sphere
    view = create_view(scene, gl, sim)
    size = (64, 64)
    pictures = {}
    stored = sim.normal.get()
    for side, yaw in (("front", 0.0), ("back", 180.0)):
        camera = OrbitCamera(target=(-0.1, -0.1, 0.0), distance=4.0, yaw=yaw)
        camera.aspect = 1.0
        view.upload()
        pictures[side] = frame(size).render(view, camera)
        sim.normal.set(stored * np.array([-1, -1, -1, 1], np.float32))  # normals pointing the other way
        view.upload()
        np.testing.assert_array_equal(frame(size).render(view, camera), pictures[side])
        sim.normal.set(stored)
    centre = slice(24, 40)
    front = pictures["front"][centre, centre].reshape(-1, 3).mean(axis=0)
    back = pictures["back"][centre, centre].reshape(-1, 3).mean(axis=0)
    # lighting.glsl: ambient (0.212, 0.227, 0.259), light (1, 0.957, 0.839) at cos 0.557 to the front normal
    assert front[2] == pytest.approx(255 * (0.259 + 0.839 * 0.557), abs=12)
    assert back[2] == pytest.approx(255 * 0.259, abs=12)
    assert front[0] < 10 and back[0] < 10  # albedo red = 0


@pytest.mark.gl
def test_debug_view_draws_points_and_three_spring_families(runtime, gl, draped):
    from ugpcl.viewer.offscreen import frame
    from ugpcl.viewer.views import create_view

    scene = get("cloth_debug")
    view = create_view(scene, gl, draped)
    assert view.debug and view.background == (0.0, 0.0, 0.0)
    camera = view.make_camera()
    size = (160, 120)
    camera.aspect = size[0] / size[1]
    view.upload()
    counts = {family: lines.count // 2 for family, lines in view.springs.items()}
    assert counts == {"structural": 2 * 31 * 32, "shear": 2 * 31 * 31, "bend": 2 * 30 * 30}
    query = gl.query(primitives=True)
    with query:
        pixels = frame(size).render(view, camera)
    assert query.primitives == sum(counts.values()) + 2 * 32 * 32  # lines + two triangles per point sprite
    mask = foreground(pixels, view.background)
    px, py = project(camera, draped.state()["pos"].reshape(-1, 3), size)
    assert mask[py, px].mean() > 0.95, "lines and points where the particles are"
    lit = pixels[mask].astype(int)
    assert (lit[:, 0] > 30).any() and (lit[:, 1] > 30).any() and (lit[:, 2] > 30).any()  # red, green, blue families
    # far from the cloth nothing is drawn
    assert not mask[:, :10].any() and not mask[:, -10:].any()


@pytest.mark.gl
def test_view_keys_change_the_simulation(runtime, gl):
    from ugpcl.viewer.views import create_view

    scene = get("cloth")
    sim = scene.create(runtime, res=(16, 16))
    view = create_view(scene, gl, sim)
    assert {k.key for k in view.keys} >= {"c", "m", "[", "]", "+", "-", "d", "w", "g", "1", "2"}
    view.toggle_sphere()
    assert sim.params.sphere is False
    view.more_substeps()
    assert sim.params.substeps == 5
    view.fewer_substeps()
    view.fewer_substeps()
    assert sim.params.substeps == 3
    view.stiffer()
    assert sim.params.stiffness == pytest.approx(12500.0)
    view.longer_timestep()
    assert sim.params.timestep == pytest.approx(0.025)
    view.toggle_debug()
    assert view.debug and view.background == (0.0, 0.0, 0.0)
    view.toggle_buffers()
    view.upload()
    from ugpcl.viewer.offscreen import frame

    pixels = frame((96, 64)).render(view, view.make_camera())
    assert foreground(pixels[-10:-2, 2:40], view.background).mean() > 0.5, "buffer thumbnails bottom-left"
    view.debug_preset()
    assert sim.params.res == (64, 64) and sim.params.timestep == 0.01 and sim.steps == 0


@pytest.mark.gl
def test_views_upload_16_bytes_a_particle(runtime, gl):
    """The surface and the debug render get PackSurface's 16 bytes a particle, not pos and normal's 32; the G key's
    thumbnails add the five float4 buffers."""
    from ugpcl.viewer.views import create_view

    scene = get("cloth")
    sim = scene.create(runtime, res=(24, 20))
    view = create_view(scene, gl, sim)
    for expected in (16, 16, 16 + 5 * 16):  # surface, debug render, debug render with thumbnails
        before = runtime.read_back_bytes
        view.upload()
        assert runtime.read_back_bytes - before == 24 * 20 * expected, (view.debug, view.show_buffers)
        if not view.debug:
            view.toggle_debug()
        else:
            view.toggle_buffers()
    assert view.finite
    sim.set_positions(np.full((20, 24, 3), np.inf))  # the status line's DIVERGED reads the packed positions
    view.upload()
    assert not view.finite


# }}}


@pytest.mark.oclgrind
@pytest.mark.parametrize("kernel", SIMULATION_KERNELS)
def test_kernels_on_oclgrind(oclgrind, runtime, kernel, seed):
    """CSInit and CSSimulation (CSSimulation_cpu) on a 9 x 6 cloth in 4 x 4 groups (padding in both axes; one
    work-item of 16 lanes per row, 9 used), sphere overlapping."""
    results = {}
    for name, rt in (("oclgrind", oclgrind), ("pocl", runtime)):
        for variant in ("fixed", "book"):
            sim = Simulation(rt, Params(res=(9, 6), rest_length=0.05, num_threads_xy=4, variant=variant))
            sim.simulation_kernel = kernel
            pos, prev = perturbed(9, 6, 0.05, seed)
            sim.set_positions(pos, prev)
            sim.sphere_params = np.array([0.0, -0.05, 0.03, 0.1], np.float32)
            sim.cs_simulation()
            sim.cs_simulation()
            results[name, variant] = state = sim.state()
            packed = sim.pack_surface().get()  # PackSurface: 54 particles of a group of 256
            np.testing.assert_array_equal(packed, pack_surface_reference(state["pos"], state["normal"]))
        fresh = Simulation(rt, Params(res=(9, 6), rest_length=0.05, num_threads_xy=4))  # CSInit + copies
        results[name, "init"] = fresh.state()
    for key in ("fixed", "book", "init"):
        for array in ("pos", "prev_last", "normal"):
            np.testing.assert_allclose(
                results["oclgrind", key][array], results["pocl", key][array], rtol=1e-5, atol=1e-6
            )
