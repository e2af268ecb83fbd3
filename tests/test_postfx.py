"""Full-screen passes (viewer/postfx.py) and their OpenCL side (clkernels/include/image.h): exact copies, GL_LINEAR
sampling against image_sample_bilinear, row order, ping-pong, blend states, and state restored around a pass."""

from __future__ import annotations

from functools import cache

import moderngl
import numpy as np
import pytest
from helpers import build_kernel_source, compare_images, linear_filter_error, run_pass
from ugpcl.viewer.postfx import (
    BLEND_ADD,
    BLEND_ALPHA,
    BLEND_SCREEN,
    FloatTarget,
    FullscreenPass,
    PingPong,
    float_texture,
)

from ugpcl.runtime import Kernel

IMAGE_TEST_KERNELS = """
#include "image.h"

__kernel void SampleBilinear(__global const float4* source, int w, int h, __global const float2* coords,
                             __global float4* out, int n) {
    const int i = get_global_id(0);
    if (i >= n) return;
    out[i] = image_sample_bilinear(source, w, h, coords[i]);
}

__kernel void LoadClamped(__global const float4* source, int w, int h, __global const int2* texels,
                          __global float4* out, int n) {
    const int i = get_global_id(0);
    if (i >= n) return;
    out[i] = image_load_clamped(source, w, h, texels[i].x, texels[i].y);
}

__kernel void TexelUV(__global float4* out, int w, int h) {
    const int x = get_global_id(0), y = get_global_id(1);
    if (x >= w || y >= h) return;
    out[image_index(x, y, w)] = (float4)(image_uv(x, y, w, h), x + 0.5f, y + 0.5f);
}
"""


# {{{ the OpenCL side


@cache
def image_kernel(runtime, name: str) -> Kernel:
    return build_kernel_source(runtime, IMAGE_TEST_KERNELS).kernel(name)


def cl_sample(runtime, source: np.ndarray, coords: np.ndarray) -> np.ndarray:
    """image_sample_bilinear of an (h, w, 4) image at (..., 2) uv coordinates."""
    h, w = source.shape[:2]
    flat = np.ascontiguousarray(coords, np.float32).reshape(-1, 2)
    out = runtime.zeros((len(flat), 4), np.float32)
    sample = image_kernel(runtime, "SampleBilinear")
    sample.over(
        len(flat),
        16,
        runtime.to_device(source),
        np.int32(w),
        np.int32(h),
        runtime.to_device(flat),
        out,
        np.int32(len(flat)),
    )
    return out.get().reshape(*coords.shape[:-1], 4)


def numpy_bilinear(source: np.ndarray, coords: np.ndarray) -> np.ndarray:
    """GL_LINEAR with CLAMP_TO_EDGE in float64 (OpenGL 4.6 section 8.14.2)."""
    h, w = source.shape[:2]
    p = coords.astype(np.float64) * (w, h) - 0.5
    base = np.floor(p)
    t = p - base
    x0, y0 = base[..., 0].astype(int), base[..., 1].astype(int)

    def texel(x, y):
        return source[np.clip(y, 0, h - 1), np.clip(x, 0, w - 1)].astype(np.float64)

    tx, ty = t[..., :1], t[..., 1:]
    bottom = texel(x0, y0) * (1 - tx) + texel(x0 + 1, y0) * tx
    top = texel(x0, y0 + 1) * (1 - tx) + texel(x0 + 1, y0 + 1) * tx
    return bottom * (1 - ty) + top * ty


def random_coords(rng, shape) -> np.ndarray:
    """uv in [-0.5, 1.5]^2 (a quarter outside the image on each side), plus exact texel centres and edges."""
    coords = rng.uniform(-0.5, 1.5, (*shape, 2)).astype(np.float32)
    coords[0, :4] = [(0.0, 0.0), (1.0, 1.0), (0.0, 1.0), (1.0, 0.0)]
    return coords


# }}}


@pytest.mark.oclgrind
def test_image_kernels_under_oclgrind(oclgrind, seed):
    rng = np.random.default_rng(seed)
    source = rng.random((5, 7, 4), dtype=np.float32)
    coords = random_coords(rng, (3, 6))
    got = cl_sample(oclgrind, source, coords)
    assert np.allclose(got, numpy_bilinear(source, coords), atol=1e-5), compare_images(
        got, numpy_bilinear(source, coords), 1e-5
    )

    texels = rng.integers(-3, 10, (20, 2)).astype(np.int32)
    out = oclgrind.zeros((20, 4), np.float32)
    image_kernel(oclgrind, "LoadClamped").over(
        20, 8, oclgrind.to_device(source), np.int32(7), np.int32(5), oclgrind.to_device(texels), out, np.int32(20)
    )
    expected = source[np.clip(texels[:, 1], 0, 4), np.clip(texels[:, 0], 0, 6)]
    np.testing.assert_array_equal(out.get(), expected)

    uv = oclgrind.zeros((5, 7, 4), np.float32)
    image_kernel(oclgrind, "TexelUV")((8, 8), None, uv, np.int32(7), np.int32(5))
    assert np.allclose(uv.get()[2, 3], [3.5 / 7, 2.5 / 5, 3.5, 2.5])


def test_sample_bilinear_matches_numpy(runtime, seed):
    rng = np.random.default_rng(seed)
    source = (rng.random((9, 11, 4), dtype=np.float32) * 8 - 2).astype(np.float32)  # HDR and negative values
    coords = random_coords(rng, (12, 16))
    got, expected = cl_sample(runtime, source, coords), numpy_bilinear(source, coords)
    assert np.allclose(got, expected, atol=1e-5), compare_images(got, expected, 1e-5)
    # at texel centres the sample is the texel itself (uv * size - 0.5 rounds to a whole number within 1 ulp)
    centres = np.stack(np.meshgrid((np.arange(11) + 0.5) / 11, (np.arange(9) + 0.5) / 9), axis=-1)
    np.testing.assert_allclose(cl_sample(runtime, source, centres), source, atol=1e-5)


def test_copy_pass_returns_its_input_exactly(gl, seed):
    source = np.random.default_rng(seed).normal(0, 100, (7, 13, 4)).astype(np.float32)  # beyond half precision
    got = run_pass(gl, "postfx_copy", {"source": source})
    assert np.array_equal(got, source), compare_images(got, source, 0)


def test_bilinear_pass_matches_the_opencl_twin(gl, runtime, seed):
    rng = np.random.default_rng(seed)
    source = rng.random((9, 11, 4), dtype=np.float32)
    coords = random_coords(rng, (12, 16))
    got = run_pass(gl, "postfx_sample", {"source": source, "coords": coords}, size=(16, 12))
    twin = cl_sample(runtime, source, coords)
    # values in [0, 1]: the device's weight rounding (0 on llvmpipe) bounds the difference. The step probe sees
    # half a rounding step at most (1/1024 on the H100), a random uv up to a whole one (1/512), on each of 2 axes
    atol = 1e-5 + 4 * linear_filter_error(gl)
    assert np.abs(got - twin).max() <= atol, compare_images(got, twin, atol)


def test_row_zero_is_the_bottom_row_in_gl_and_opencl(gl, runtime):
    w, h = 7, 5
    got = run_pass(gl, "postfx_uv", {}, size=(w, h))
    assert np.allclose(got[0, :, 1], 0.5 / h) and np.allclose(got[0, :, 3], 0.5), "row 0 of read() is not the bottom"
    assert np.allclose(got[:, 0, 0], 0.5 / w) and np.allclose(got[:, 0, 2], 0.5)
    twin = runtime.zeros((h, w, 4), np.float32)
    image_kernel(runtime, "TexelUV")((8, 8), None, twin, np.int32(w), np.int32(h))
    assert np.allclose(got, twin.get(), atol=1e-6), compare_images(got, twin.get(), 1e-6)
    # an uploaded array's row 0 is where uv.y is smallest
    rows = np.repeat(np.arange(h, dtype=np.float32)[:, None, None], w, axis=1)
    bottom = np.full((1, 1, 2), (0.5, 0.5 / h), np.float32)
    assert run_pass(gl, "postfx_sample", {"source": rows, "coords": bottom}, size=(1, 1))[0, 0, 0] == 0.0


def test_ping_pong_swaps_read_and_write(gl, seed):
    rng = np.random.default_rng(seed)
    a, b = rng.random((2, 4, 6, 4), dtype=np.float32)
    pair = PingPong(gl, (6, 4))
    copy = FullscreenPass(gl, "postfx_copy")
    first, second = pair.read, pair.write
    pair.write.write(a)
    pair.swap()
    assert pair.read is second and pair.write is first
    assert np.array_equal(pair.read.read(), a)
    pair.write.write(b)
    copy.run(pair.write, {"source": pair.read}, blend=BLEND_ADD)  # write = b + read
    pair.swap()
    np.testing.assert_allclose(pair.read.read(), a + b, rtol=1e-6)
    assert np.array_equal(pair.write.read(), a), "the pass changed the target it read"
    copy.release()
    pair.release()


BLEND_CASES = {
    "screen": (BLEND_SCREEN, lambda s, d: 1 - (1 - s) * (1 - d)),
    "add": (BLEND_ADD, lambda s, d: s + d),
    "alpha": (BLEND_ALPHA, lambda s, d: s * s[3] + d * (1 - s[3])),
    "none": (None, lambda s, d: s),
}


@pytest.mark.parametrize("mode", BLEND_CASES)
def test_blend_constants_give_their_equation(gl, mode, seed):
    blend, equation = BLEND_CASES[mode]
    rng = np.random.default_rng(seed)
    fill = FullscreenPass(gl, "postfx_fill")
    target = FloatTarget(gl, (3, 2))
    for _ in range(4):
        source, destination = rng.random((2, 4), dtype=np.float32)
        target.write(np.broadcast_to(destination, target.shape))
        fill.run(target, uniforms={"color": tuple(source)}, blend=blend)
        expected = np.broadcast_to(equation(source.astype(np.float64), destination.astype(np.float64)), target.shape)
        assert np.allclose(target.read(), expected, atol=1e-6), compare_images(target.read(), expected, 1e-6)
    fill.run(target, uniforms={"color": (0.25, 0.5, 0.75, 1.0)})  # blending was switched off again
    assert np.allclose(target.read(), (0.25, 0.5, 0.75, 1.0))
    fill.release()
    target.release()


def test_pass_restores_framebuffer_viewport_and_flags(gl):
    """A view running passes in draw(): the caller's framebuffer, viewport and depth test survive them."""
    size = (8, 6)
    color = gl.texture(size, 4, dtype="f4")
    caller = gl.framebuffer([color], gl.depth_renderbuffer(size))
    caller.use()
    gl.viewport = (2, 1, 4, 3)
    gl.enable(moderngl.DEPTH_TEST)
    caller.clear(0.0, 0.0, 0.0, 0.0, depth=0.0)  # depth 0: with the depth test on, no triangle would pass
    fill, side = FullscreenPass(gl, "postfx_fill"), FloatTarget(gl, (3, 3))
    fill.run(side, uniforms={"color": (1.0, 0.0, 0.0, 1.0)})
    assert gl.fbo is caller and gl.viewport == (2, 1, 4, 3)
    assert np.allclose(side.read(), (1, 0, 0, 1)), "the pass did not cover its whole target"
    fill.run(None, uniforms={"color": (0.0, 1.0, 0.0, 1.0)})  # into the caller's framebuffer, its viewport only
    pixels = np.frombuffer(caller.read(components=4, dtype="f4", viewport=(0, 0, *size)), "f4").reshape(6, 8, 4)
    inside = np.zeros((6, 8), bool)
    inside[1:4, 2:6] = True
    assert np.allclose(pixels[inside], (0, 1, 0, 1)) and np.allclose(pixels[~inside], 0), "wrong region drawn"
    assert gl.fbo is caller and gl.viewport == (2, 1, 4, 3)
    # the depth test is on again: a triangle at depth 0.5 fails against the cleared depth 0
    probe = gl.program(
        vertex_shader="#version 430\nvoid main() { vec2 c = vec2((gl_VertexID << 1) & 2, gl_VertexID & 2);"
        " gl_Position = vec4(c * 2.0 - 1.0, 0.0, 1.0); }",
        fragment_shader="#version 430\nout vec4 f; void main() { f = vec4(0.0, 0.0, 1.0, 1.0); }",
    )
    gl.vertex_array(probe, []).render(vertices=3)
    after = np.frombuffer(caller.read(components=4, dtype="f4", viewport=(0, 0, *size)), "f4").reshape(6, 8, 4)
    assert np.array_equal(after, pixels), "depth test not restored after the pass"
    gl.disable(moderngl.DEPTH_TEST)
    gl.detect_framebuffer(0).use()  # never release the bound framebuffer: moderngl would rebind it later
    for obj in (probe, fill, side, caller, color):
        obj.release()


def test_pass_inside_an_offscreen_view_draw(gl):
    """``ugpcl run --png``'s path: a view whose draw() blends a pass over the background of the offscreen frame."""
    from ugpcl.viewer.offscreen import frame
    from ugpcl.viewer.views import View

    class TintView(View):
        background = (0.2, 0.4, 0.6)

        def __init__(self, ctx):
            super().__init__(ctx, None)
            self.tint = FullscreenPass(ctx, "postfx_fill")

        def draw(self, camera) -> None:
            self.tint.run(None, uniforms={"color": (1.0, 0.0, 0.0, 0.5)}, blend=BLEND_ALPHA)

    pixels = frame((16, 12)).render(TintView(gl), None)
    expected = np.round((np.array([1.0, 0.0, 0.0]) * 0.5 + np.array(TintView.background) * 0.5) * 255)
    assert np.abs(pixels.astype(int) - expected).max() <= 1, compare_images(
        pixels, np.broadcast_to(expected, pixels.shape), 1
    )


def test_float_texture_and_target_shapes(gl):
    texture = float_texture(gl, np.zeros((3, 5, 3), np.float32))
    assert texture.size == (5, 3) and texture.components == 3 and texture.filter == (moderngl.LINEAR, moderngl.LINEAR)
    target = FloatTarget(gl, (5, 3), components=2, dtype="f2")
    target.write(np.full((3, 5, 2), 0.5))
    assert target.read().shape == (3, 5, 2) and np.all(target.read() == 0.5)
    with pytest.raises(ValueError, match="shape"):
        target.write(np.zeros((5, 3, 2)))
    texture.release()
    target.release()
