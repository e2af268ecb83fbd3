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

    from ugpcl.scenes import get

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
    bg = np.round(np.asarray(background) * 255).astype(int)
    return np.abs(pixels.astype(int) - bg).sum(axis=-1) > tolerance


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
