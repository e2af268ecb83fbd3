"""Compute intro (vol.1 ch.2; docs/chapters/02-compute-intro.md): array sample, texture sample, dispatch semantics,
view."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import foreground

from ugpcl.registry import get
from ugpcl.scenes.compute_intro import Params, Simulation


def make(runtime, **overrides) -> Simulation:
    return Simulation(runtime, Params(**overrides))


# {{{ array sample


@pytest.mark.parametrize(
    "int_value, after_a, after_b", [(1, [0, 1, 2, 3], [1, 2, 3, 4]), (3, [0, 3, 6, 9], [1, 4, 7, 10])]
)
def test_array_sample_reproduces_the_book(runtime, int_value, after_a, after_b):
    state = make(runtime, sample="array", int_value=int_value).state()  # Start() ran the sample once
    np.testing.assert_array_equal(state["array_after_a"], after_a)
    np.testing.assert_array_equal(state["array_after_b"], after_b)


@pytest.mark.parametrize("groups", [1, 2, 4])
def test_atomic_b_adds_exactly_one_per_group(runtime, groups):
    sim = make(runtime, sample="array", int_value=5, groups=groups)
    after_a = sim.kernel_function_a_array()
    np.testing.assert_array_equal(after_a, [0, 5, 10, 15])  # every group writes the same values
    np.testing.assert_array_equal(sim.kernel_function_b_array(atomic=True), after_a + groups)


# }}}

# {{{ texture sample


def expected_gradient(n: int, denominator: int) -> np.ndarray:
    """write_imagef on UNORM8: round-half-to-even of v * 255 with v = i / denominator (float32 as the kernel)."""
    v = np.arange(n, dtype=np.float32) / np.float32(denominator)
    return np.rint(v * np.float32(255)).astype(np.uint8)


@pytest.mark.parametrize("width, height", [(512, 512), (100, 37)])  # the book's size; one that is not a multiple of 8
def test_texture_kernels_write_the_gradients(runtime, width, height):
    sim = make(runtime, sample="texture", tex_width=width, tex_height=height)
    sim.step()
    state = sim.state()
    tex_a, tex_b = state["tex_a"], state["tex_b"]
    assert tex_a.shape == (height, width, 4) and tex_a.dtype == np.uint8
    # A: a function of x only; B: of y only, divided by the *width* as the book does
    ramp_a = expected_gradient(width, width)
    ramp_b = expected_gradient(height, width)
    assert np.abs(tex_a[:, :, :3].astype(int) - ramp_a[None, :, None]).max() <= 1
    assert np.abs(tex_b[:, :, :3].astype(int) - ramp_b[:, None, None]).max() <= 1
    assert (tex_a[..., 3] == 255).all() and (tex_b[..., 3] == 255).all()
    assert (tex_a == tex_a[:1]).all(), "texture A rows differ"
    assert (tex_b == tex_b[:, :1]).all(), "texture B columns differ"
    assert tex_a[0, 0, 0] == 0 and tex_b[0, 0, 0] == 0  # black on the left / at the bottom (row 0)
    if width == 512:
        assert tex_a[0, -1, 0] in (254, 255)  # 511/512 * 255 = 254.50...


def test_image_and_buffer_paths_agree(runtime):
    if not runtime.image_support:
        pytest.fail(f"{runtime.label} has no images: the image path of this test cannot run")
    image = make(runtime, sample="texture", use_images="image", tex_width=77, tex_height=64)
    buffer = make(runtime, sample="texture", use_images="buffer", tex_width=77, tex_height=64)
    image.step()
    buffer.step()
    # the buffer path rounds half to even exactly (convert_uchar4_sat_rte); write_imagef may be 0.6 ulp off by the
    # OpenCL spec (NVIDIA writes 16 for 16.56), so the image path is held to 1 LSB
    np.testing.assert_array_equal(buffer.state()["tex_a"][0, :, 0], expected_gradient(77, 77))
    np.testing.assert_array_equal(buffer.state()["tex_b"][:, 0, 0], expected_gradient(64, 77))
    for name in ("tex_a", "tex_b"):
        difference = image.state()[name].astype(int) - buffer.state()[name]
        assert np.abs(difference).max() <= 1, name


@pytest.mark.parametrize("use_images", ["image", "buffer"])
def test_1d_launch_gives_bitwise_the_2d_result(runtime, use_images):
    sim = make(runtime, sample="texture", use_images=use_images)
    sim.step()
    np.testing.assert_array_equal(sim.kernel_function_a_1d(), sim.state()["tex_a"])


@pytest.mark.parametrize("shape", [(8, 8), (16, 4), (1, 64)])
def test_compiled_work_group_size_is_numthreads(runtime, shape):
    assert make(runtime, sample="texture", local_size=shape).kernel_work_group_size() == (*shape, 1)


# }}}

# {{{ dispatch semantics


def test_probe_reproduces_the_books_worked_examples(runtime):
    probe = make(runtime).dispatch_probe(numthreads=(4, 1, 1), groups=(2, 2, 1))
    group, local, glob, flat = (probe[k] for k in ("probe_group", "probe_local", "probe_global", "probe_flat"))
    assert len(glob) == 16
    np.testing.assert_array_equal(glob, group * [4, 1, 1] + local)  # SV_DispatchThreadID = group * numthreads + local
    rows = {(tuple(g), tuple(loc)): tuple(gl) for g, loc, gl in zip(group, local, glob, strict=True)}
    assert rows[((0, 1, 0), (2, 0, 0))] == (2, 1, 0)  # book example (1)
    assert rows[((1, 1, 0), (3, 0, 0))] == (7, 1, 0)  # book example (2): the last thread
    assert len({tuple(g) for g in glob}) == 16  # every global id once


@pytest.mark.parametrize("numthreads, groups", [((4, 4, 1), (2, 1, 1)), ((2, 2, 1), (4, 4, 1)), ((3, 2, 2), (2, 3, 2))])
def test_probe_ids_cover_the_grid(runtime, numthreads, groups):
    probe = make(runtime).dispatch_probe(numthreads=numthreads, groups=groups)
    t = np.array(numthreads)
    group, local, glob, flat = (probe[k] for k in ("probe_group", "probe_local", "probe_global", "probe_flat"))
    assert len(glob) == np.prod(t) * np.prod(groups)  # e.g. (4,4,1) x (2,1,1) = 32 items (seed line 1060)
    np.testing.assert_array_equal(glob, group * t + local)
    np.testing.assert_array_equal(flat, local[:, 2] * t[0] * t[1] + local[:, 1] * t[0] + local[:, 0])
    assert group.max(axis=0).tolist() == [g - 1 for g in groups]
    assert local.max(axis=0).tolist() == [n - 1 for n in numthreads]
    assert len({tuple(g) for g in glob}) == len(glob)


# }}}

# {{{ parameters, view, Oclgrind


# out-of-range values: tests/test_params.py, for every field of every scene
@pytest.mark.parametrize(
    "overrides, message",
    [
        ({"use_images": "maybe"}, "use_images must be one of auto\\|image\\|buffer"),
        ({"local_size": (8, 8, 1)}, "local_size must be 2 numbers"),
    ],
)
def test_bad_parameters_name_the_field(overrides, message):
    with pytest.raises(ValueError, match=message):
        Params(**overrides)


@pytest.mark.gl
def test_view_shows_the_two_gradients(runtime, gl):
    from ugpcl.viewer.offscreen import render

    scene = get("compute_intro_texture")
    sim = scene.create(runtime)
    sim.step()
    pixels = render(scene, sim, (192, 108)).astype(int)
    mask = foreground(pixels, (0.192, 0.302, 0.475), tolerance=40)
    columns = np.flatnonzero(mask.any(axis=0))
    left = columns[columns < 96]
    right = columns[columns >= 96]
    assert len(left) > 10 and len(right) > 10, "a quad is missing"
    rows = np.flatnonzero(mask[:, left].any(axis=1))
    mid = rows[len(rows) // 2]
    luminance = pixels.sum(axis=-1)
    assert luminance[mid, left[1]] + 60 < luminance[mid, left[-2]], "left quad is not dark left -> white right"
    top, bottom = rows[1], rows[-2]  # image row 0 is the top
    x = right[len(right) // 2]
    assert luminance[bottom, x] + 60 < luminance[top, x], "right quad is not dark bottom -> white top"


@pytest.mark.gl
def test_array_view_draws_the_results_as_cells_coloured_by_value(runtime, gl):
    from ugpcl.viewer.offscreen import render
    from ugpcl.viewer.views.compute_intro import HIGH, LOW

    scene = get("compute_intro_array")
    sim = scene.create(runtime, int_value=2)  # A: 0 2 4 6, B and B_atomic: 2 4 6 8
    sim.step()
    pixels = render(scene, sim, (640, 360)).astype(int)
    cell = 0.65 * 360 / (3.5 * 150 + 30) * 150 - 6  # a cell's side at this size (the panel fills 65 % of the height)

    def cells_of(colour) -> float:
        return (np.abs(pixels - colour).sum(axis=-1) < 12).sum() / cell**2

    assert 0.6 < cells_of(LOW) < 1.2, "one cell (A[0] = 0) in the lowest colour"
    assert 1.2 < cells_of(HIGH) < 2.4, "two cells (B[3] = B_atomic[3] = 8) in the highest colour"


@pytest.mark.oclgrind
def test_kernels_on_oclgrind(oclgrind):
    sim = Simulation(oclgrind, Params(tex_width=20, tex_height=12, local_size=(8, 4)))
    sim.step()
    state = sim.state()
    np.testing.assert_array_equal(state["array_after_b"], [1, 2, 3, 4])
    np.testing.assert_array_equal(sim.kernel_function_a_1d(), state["tex_a"])
    buffer = Simulation(oclgrind, Params(sample="texture", tex_width=20, tex_height=12, use_images="buffer"))
    buffer.step()
    np.testing.assert_array_equal(buffer.state()["tex_b"], state["tex_b"])
    sim.kernel_function_a_array()
    sim.kernel_function_b_array(atomic=True)
    sim.update(groups=2)
    sim.kernel_function_b_array(atomic=True)  # atomics across groups: no race to report


# }}}
