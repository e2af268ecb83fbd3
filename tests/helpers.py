"""Small helpers several test modules share (importable because pytest puts tests/ on sys.path)."""

from __future__ import annotations

import numpy as np


def run_cli(capsys, *argv) -> tuple[int, str]:
    """``ugpcl ARGV`` in this process: (exit code, stdout + stderr)."""
    from ugpcl.cli import main

    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out + err


def render_view(gl, scene_name: str, sim, size=(160, 120), **view_state):
    """Draw ``sim`` through the view of ``scene_name`` offscreen, the view's attributes set from ``view_state``:
    (pixels, primitives the GL query counted, view, camera)."""
    from ugpcl.viewer.offscreen import frame
    from ugpcl.viewer.views import create_view

    from ugpcl.registry import get

    view = create_view(get(scene_name), gl, sim)
    for key, value in view_state.items():
        setattr(view, key, value)
    camera = view.png_camera()
    camera.aspect = size[0] / size[1]
    view.upload()
    query = gl.query(primitives=True)
    with query:
        pixels = frame(size).render(view, camera)
    return pixels, query.primitives, view, camera


def foreground(pixels: np.ndarray, background, tolerance: int = 12) -> np.ndarray:
    """Boolean mask of pixels that differ from the background colour (floats in [0, 1]) by more than tolerance."""
    bg = np.round(np.asarray(background) * 255).astype(np.int16)
    return np.abs(pixels.astype(np.int16) - bg).sum(axis=-1) > tolerance  # |difference| sums to 765 at most


def most_common_colour(pixels: np.ndarray) -> np.ndarray:
    """The most common RGB colour of (..., 3) uint8 pixels, as floats in [0, 1] (the background of a picture the
    subject does not fill), the lowest packed colour of equals: np.unique over packed colours, far quicker than
    over rows or a bincount (which allocates a count for each of 2**24 colours)."""
    rgb = pixels.reshape(-1, 3).astype(np.int32)
    colours, counts = np.unique((rgb[:, 0] << 16) | (rgb[:, 1] << 8) | rgb[:, 2], return_counts=True)
    top = int(colours[counts.argmax()])
    return np.array([top >> 16, (top >> 8) & 255, top & 255]) / 255.0


def subject(pixels: np.ndarray) -> tuple[float, tuple[int, int, int, int]]:
    """Share of the pixels that differ from the most common colour (the background wherever the subject does not
    fill the picture) and the bounding box (x0, y0, x1, y1) of those pixels."""
    mask = foreground(pixels, most_common_colour(pixels))
    ys, xs = np.nonzero(mask)
    return float(mask.mean()), (xs.min(), ys.min(), xs.max(), ys.max()) if len(xs) else (0, 0, 0, 0)


def judge_picture(pixels: np.ndarray, check, what: str) -> None:
    """Assert that a picture shows its subject as a scene's ``preview_check`` asks: more than ``min_subject`` of
    the frame, its bounding box clear of the frame's edge unless ``fills_frame`` says why it may not."""
    share, (x0, y0, x1, y1) = subject(pixels)
    assert share > check.min_subject, (
        f"{what}: the subject covers {share:.1%} of the frame (needs > {check.min_subject:.1%})"
    )
    if not check.fills_frame:
        h, w = pixels.shape[:2]
        assert x0 > 0 and y0 > 0 and x1 < w - 1 and y1 < h - 1, (
            f"{what}: the subject's box ({x0}, {y0})-({x1}, {y1}) touches the frame's edge (cut off)"
        )


def first_mismatch(actual: np.ndarray, expected: np.ndarray, rtol: float, atol: float) -> str:
    """Where an allclose check fails first: index, value and expected value (for assertion messages)."""
    bad = ~np.isclose(actual, expected, rtol=rtol, atol=atol)
    if not bad.any():
        return "all close"
    index = np.argwhere(bad)[0]
    row = index[0]
    return f"{bad.sum()} mismatches; first at {tuple(index)}: got {actual[row]}, expected {expected[row]}"


def linear_filter_error(ctx) -> float:
    """Largest error of the GL device's bilinear filtering on a 0 -> 1 texel step: 0 where it filters in float
    (llvmpipe), 1/1024 measured on an H100, whose texture unit rounds the sub-texel weights to 1/512."""
    import moderngl

    texture = ctx.texture((2, 1), 1, np.array([0.0, 1.0], "f4").tobytes(), dtype="f4")
    texture.filter = (moderngl.LINEAR, moderngl.LINEAR)
    texture.repeat_x = texture.repeat_y = False
    target = ctx.texture((512, 1), 1, dtype="f4")
    fbo = ctx.framebuffer(color_attachments=[target])
    program = ctx.program(
        vertex_shader="#version 330\nin vec2 p; void main() { gl_Position = vec4(p, 0.0, 1.0); }",
        fragment_shader="""#version 330
            uniform sampler2D step_map; out float value;
            void main() { value = texture(step_map, vec2((0.5 + gl_FragCoord.x / 512.0), 0.5) * vec2(0.5, 1.0)).r; }""",
    )
    quad = ctx.buffer(np.array([-1, -1, 1, -1, -1, 1, 1, 1], "f4").tobytes())
    vao = ctx.vertex_array(program, [(quad, "2f", "p")])
    fbo.use()
    texture.use(0)
    vao.render(moderngl.TRIANGLE_STRIP)
    got = np.frombuffer(target.read(), "f4")
    u = (0.5 + (np.arange(512) + 0.5) / 512.0) * 0.5  # texel centres at u = 0.25 and 0.75
    expected = np.clip((u - 0.25) * 2.0, 0.0, 1.0)
    for obj in (vao, quad, program, fbo, target, texture):
        obj.release()
    return float(np.abs(got - expected).max())


def gl_context():
    """The process's standalone EGL context (the one the ``gl`` fixture checks for errors; prefer the fixture)."""
    from ugpcl.viewer.offscreen import context

    return context()


def compare_images(a: np.ndarray, b: np.ndarray, atol: float) -> str:
    """How two float images of one shape (h, w[, c]) differ: the count of pixels with a channel off by more than
    ``atol`` and the worst pixel (row, column, both values); "all within atol" when none is (assertion messages)."""
    a, b = np.asarray(a, np.float64), np.asarray(b, np.float64)
    if a.shape != b.shape:
        return f"shapes differ: {a.shape} vs {b.shape}"
    error = np.abs(a - b)
    error[np.isnan(a) != np.isnan(b)] = np.inf  # a NaN on one side only is the worst mismatch
    error = np.nan_to_num(error, nan=0.0, posinf=np.inf)  # NaN on both sides agrees
    if error.ndim == 3:
        error = error.max(axis=-1)
    over = int((error > atol).sum())
    row, col = np.unravel_index(np.argmax(error), error.shape)
    worst = f"worst at row {row}, column {col} (row 0 = bottom): {a[row, col]} vs {b[row, col]}"
    if not over:
        return f"all within atol {atol:g}; {worst}"
    return f"{over} of {error.size} pixels differ by more than {atol:g}; {worst}"


def run_pass(gl, fragment: str, textures: dict, uniforms: dict | None = None, size=None, defines=None) -> np.ndarray:
    """``viewer/shaders/<fragment>.frag`` run as a FullscreenPass into a float32 RGBA target of ``size`` (width,
    height; default the size of the first texture): its (h, w, 4) pixels, row 0 = bottom, the layout of the OpenCL
    twin's ``image.h`` buffers. ``textures`` maps sampler names to (h, w[, c]) arrays in the same row order
    (c = 1 to 4 components), uploaded with ``postfx.float_texture``."""
    from ugpcl.viewer.postfx import FloatTarget, FullscreenPass, float_texture

    inputs = {name: float_texture(gl, array) for name, array in textures.items()}
    if size is None and not inputs:
        raise ValueError("run_pass needs a size when it has no textures")
    target = FloatTarget(gl, size or next(iter(inputs.values())).size)
    step = FullscreenPass(gl, fragment, defines)
    try:
        step.run(target, inputs, uniforms or {})
        return target.read()
    finally:
        for obj in (step, target, *inputs.values()):
            obj.release()


def build_kernel_source(runtime, source: str):
    """A ``Program`` built from ``source`` as a ``clkernels/`` file is (include path, checked launches): test kernels
    that exercise a header (the ``image.h`` twin checks)."""
    return runtime.program_from_source(source, "test_kernels.cl")


def to_pixels(camera, points: np.ndarray, size) -> tuple[np.ndarray, np.ndarray]:
    """World points (n, 3) through ``camera``'s projection and view: (pixel x y with pixel centres at integers and
    the top row 0, in front of the camera)."""
    w, h = size
    clip = (camera.projection() @ camera.view() @ np.column_stack([points, np.ones(len(points))]).T).T
    ndc = clip[:, :2] / clip[:, 3:4]
    return np.column_stack([(ndc[:, 0] + 1) / 2 * w - 0.5, (1 - ndc[:, 1]) / 2 * h - 0.5]), clip[:, 3] > 0


def rasterize_triangles(corners: np.ndarray, size) -> np.ndarray:
    """(H, W) mask of the pixel centres inside any of the (t, 3, 2) pixel-space triangles (either winding): the
    test's own rasterizer, to compare a drawn picture with a projection of the state."""
    w, h = size
    mask = np.zeros((h, w), bool)
    for a, b, c in corners:
        x0, y0 = np.floor(np.minimum(np.minimum(a, b), c)).astype(int)
        x1, y1 = np.ceil(np.maximum(np.maximum(a, b), c)).astype(int)
        x0, y0, x1, y1 = max(x0, 0), max(y0, 0), min(x1, w - 1), min(y1, h - 1)
        if x0 > x1 or y0 > y1:
            continue
        ys, xs = np.mgrid[y0 : y1 + 1, x0 : x1 + 1]
        e = np.stack([(q[0] - p[0]) * (ys - p[1]) - (q[1] - p[1]) * (xs - p[0]) for p, q in ((a, b), (b, c), (c, a))])
        mask[y0 : y1 + 1, x0 : x1 + 1] |= (e >= 0).all(axis=0) | (e <= 0).all(axis=0)
    return mask


def rasterize_segments(ends: np.ndarray, size) -> np.ndarray:
    """(H, W) mask of the pixels that (n, 2, 2) pixel-space segments pass through (sampled every half pixel)."""
    w, h = size
    mask = np.zeros((h, w), bool)
    for p, q in ends:
        t = np.linspace(0.0, 1.0, int(np.ceil(2 * np.linalg.norm(q - p))) + 2)[:, None]
        x, y = np.round(p + t * (q - p)).astype(int).T
        keep = (x >= 0) & (x < w) & (y >= 0) & (y < h)
        mask[y[keep], x[keep]] = True
    return mask


def dilate(mask: np.ndarray, pixels: int = 1) -> np.ndarray:
    """``mask`` grown by ``pixels`` in every direction (a square neighbourhood)."""
    out = mask.copy()
    for _ in range(pixels):
        grown = out.copy()
        grown[1:] |= out[:-1]
        grown[:-1] |= out[1:]
        grown[:, 1:] |= grown[:, :-1].copy()
        grown[:, :-1] |= grown[:, 1:].copy()
        out = grown
    return out
