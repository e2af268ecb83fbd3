"""Full-screen passes over float framebuffers: the post-process and per-pixel chapters (StarGlow, Kleinian limit
sets, projection spray) draw with these, in the window and offscreen (``ugpcl run --png``) alike.

A pass is one triangle covering its target, drawn with ``viewer/shaders/fullscreen.vert`` (``in vec2 uv`` in the
fragment shader, (0, 0) at the bottom-left texel corner) and a fragment shader of the chapter. Targets are float
textures read back in GL row order (row 0 = bottom), the order of ``clkernels/include/image.h``, so a pass and its
OpenCL twin compare element for element.
"""

from __future__ import annotations

import moderngl
import numpy as np

from .gl import load_program, set_uniform

BLEND_SCREEN = (moderngl.ONE_MINUS_DST_COLOR, moderngl.ONE)
"""Screen: src + dst - src*dst = 1 - (1 - src)(1 - dst) for values in [0, 1] (the book's StarGlow composition)."""
BLEND_ADD = (moderngl.ONE, moderngl.ONE)
"""Additive: src + dst."""
BLEND_ALPHA = (moderngl.SRC_ALPHA, moderngl.ONE_MINUS_SRC_ALPHA)
"""Alpha: src * src.a + dst * (1 - src.a)."""

_NUMPY_DTYPES = {"f1": np.uint8, "f2": np.float16, "f4": np.float32}


class FloatTarget:
    """A texture of ``size`` = (width, height) with a framebuffer drawing into it. The texture filters linearly
    and clamps to edge (GL_LINEAR + CLAMP_TO_EDGE, what ``image_sample_bilinear`` reproduces)."""

    def __init__(self, ctx: moderngl.Context, size: tuple[int, int], components: int = 4, dtype: str = "f4"):
        if dtype not in _NUMPY_DTYPES:
            raise ValueError(f"dtype must be one of {sorted(_NUMPY_DTYPES)}, got {dtype!r}")
        self.ctx, self.size, self.components, self.dtype = ctx, (int(size[0]), int(size[1])), components, dtype
        self.texture = _linear_clamped(ctx.texture(self.size, components, dtype=dtype))
        _bind_default_if_released(ctx)  # creating a framebuffer rebinds the bound one afterwards
        self.fbo = ctx.framebuffer(color_attachments=[self.texture])

    @property
    def shape(self) -> tuple[int, int, int]:
        """The shape of ``read()`` and ``write()`` arrays: (height, width, components)."""
        return (self.size[1], self.size[0], self.components)

    def read(self) -> np.ndarray:
        """(h, w, components) float32, row 0 = the bottom row (GL order; ``[::-1]`` for image files)."""
        data = self.fbo.read(components=self.components, dtype="f4", alignment=1)
        return np.frombuffer(data, np.float32).reshape(self.shape).copy()

    def write(self, array: np.ndarray) -> None:
        """Upload (h, w, components) values, row 0 = bottom; (h, w) is accepted for one component. For "f1"
        targets the values are in [0, 1] and are rounded to bytes."""
        array = np.asarray(array)
        if array.ndim == 2 and self.components == 1:
            array = array[..., None]
        if array.shape != self.shape:
            raise ValueError(f"array of shape {array.shape} written to a target of shape {self.shape}")
        if self.dtype == "f1":
            array = np.round(np.clip(array, 0.0, 1.0) * 255.0)
        self.texture.write(np.ascontiguousarray(array, _NUMPY_DTYPES[self.dtype]).tobytes())

    def clear(self, *color: float) -> None:
        """Fill with ``color`` (one value per component; zeros when none are given)."""
        rgba = (tuple(color) + (0.0, 0.0, 0.0, 0.0))[:4]
        self.fbo.clear(*rgba)

    def release(self) -> None:
        self.fbo.release()
        self.texture.release()


def float_texture(ctx: moderngl.Context, array: np.ndarray) -> moderngl.Texture:
    """An (h, w[, components]) array, row 0 = bottom, as a float32 texture filtered like a FloatTarget's (for
    inputs such as a user's image; unlike a FloatTarget it has no framebuffer, so 3 components are fine)."""
    array = np.asarray(array, np.float32)
    array = array[..., None] if array.ndim == 2 else array
    if array.ndim != 3 or not 1 <= array.shape[2] <= 4:
        raise ValueError(f"an image array is (h, w) or (h, w, 1..4), got shape {array.shape}")
    texture = ctx.texture((array.shape[1], array.shape[0]), array.shape[2], np.ascontiguousarray(array), dtype="f4")
    return _linear_clamped(texture)


def _linear_clamped(texture: moderngl.Texture) -> moderngl.Texture:
    texture.filter = (moderngl.LINEAR, moderngl.LINEAR)
    texture.repeat_x = texture.repeat_y = False
    return texture


class PingPong:
    """Two FloatTargets a sequence of passes alternates between: read ``read``, draw into ``write``, ``swap()``."""

    def __init__(self, ctx: moderngl.Context, size: tuple[int, int], components: int = 4, dtype: str = "f4"):
        self.read = FloatTarget(ctx, size, components, dtype)
        self.write = FloatTarget(ctx, size, components, dtype)

    @property
    def size(self) -> tuple[int, int]:
        return self.read.size

    def swap(self) -> None:
        self.read, self.write = self.write, self.read

    def release(self) -> None:
        self.read.release()
        self.write.release()


class FullscreenPass:
    """The fragment shader ``viewer/shaders/<fragment>.frag`` run over every pixel of a target."""

    def __init__(self, ctx: moderngl.Context, fragment: str, defines: dict | None = None):
        self.ctx = ctx
        self.program = load_program(ctx, fragment, vertex="fullscreen", defines=defines)
        self.vao = ctx.vertex_array(self.program, [])  # no attributes: fullscreen.vert builds from gl_VertexID

    def run(
        self,
        target: FloatTarget | moderngl.Framebuffer | None = None,
        textures: dict | None = None,
        uniforms: dict | None = None,
        blend: tuple | None = None,
    ) -> None:
        """Draw into ``target`` (its whole area), or, for None, into the framebuffer bound now with its current
        viewport. ``textures`` maps sampler names to textures (or FloatTargets), bound to units 0, 1, ... in order;
        ``uniforms`` maps names to values (names the shader does not use are skipped, as GLSL drops them). ``blend``
        is a (source, destination) factor pair such as BLEND_SCREEN; None draws without blending. Depth test and
        face culling are off during the pass; the framebuffer, viewport and enable flags bound before are restored
        afterwards, so a view can run passes inside its ``draw()``."""
        ctx = self.ctx
        fbo = target.fbo if isinstance(target, FloatTarget) else target
        viewport = None if fbo is None else (0, 0, *fbo.size)
        _bind_default_if_released(ctx)
        fbo = fbo or ctx.fbo
        for unit, (name, texture) in enumerate((textures or {}).items()):
            (texture.texture if isinstance(texture, FloatTarget) else texture).use(unit)
            set_uniform(self.program, name, unit)
        for name, value in (uniforms or {}).items():
            set_uniform(self.program, name, _uniform_value(value))
        # The scope binds fbo and sets the enable flags, and on exit rebinds the previous framebuffer (with its
        # viewport) and restores the previous flags. Released at once: with gc_mode None nothing else would.
        scope = ctx.scope(fbo, enable=moderngl.BLEND if blend else moderngl.NOTHING)
        try:
            with scope:
                if viewport is not None:
                    ctx.viewport = viewport
                if blend:
                    ctx.blend_equation = moderngl.FUNC_ADD
                    ctx.blend_func = blend
                self.vao.render(moderngl.TRIANGLES, vertices=3)
        finally:
            scope.release()

    def release(self) -> None:
        self.vao.release()
        self.program.release()


def _bind_default_if_released(ctx: moderngl.Context) -> None:
    """Bind the default framebuffer when moderngl's bound one is None (a fresh standalone context) or released
    (GL fell back to the default then, but moderngl rebinds the dead one after a scope or a framebuffer creation,
    raising GL_INVALID_OPERATION)."""
    if ctx.fbo is None or isinstance(ctx.fbo.mglo, moderngl.InvalidObject):
        ctx.detect_framebuffer().use()


def _uniform_value(value):
    """numpy scalars and vectors as the Python numbers and tuples moderngl takes (4x4 matrices stay arrays)."""
    if isinstance(value, np.ndarray) and value.shape != (4, 4):
        return value.item() if value.ndim == 0 else tuple(value.ravel().tolist())
    if isinstance(value, np.generic):
        return value.item()
    return value
