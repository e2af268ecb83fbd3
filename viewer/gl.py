"""GL helpers every view shares: shader files with ``#include``, the text overlay, screenshots."""

from __future__ import annotations

from pathlib import Path

import moderngl
import numpy as np
from PIL import Image, ImageDraw, ImageFont

SHADER_DIR = Path(__file__).resolve().parent / "shaders"


def register_includes(ctx: moderngl.Context) -> None:
    """Serve ``#include "name.glsl"`` from viewer/shaders/include/ (moderngl's ``ctx.includes``)."""
    for path in sorted((SHADER_DIR / "include").glob("*.glsl")):
        ctx.includes[path.name] = path.read_text()


def load_program(
    ctx: moderngl.Context,
    stem: str,
    *,
    vertex: str | None = None,
    fragment: str | None = None,
    geometry: str | None = None,
    tess_control: str | None = None,
    tess_evaluation: str | None = None,
    varyings=(),
    defines: dict | None = None,
) -> moderngl.Program:
    """Build ``viewer/shaders/<stem>.{vert,frag,geom,tesc,tese}``; each keyword names another stem for that stage,
    and a stage file that does not exist is left out."""
    register_includes(ctx)

    def source(name: str | None, ext: str) -> str | None:
        path = SHADER_DIR / f"{name or stem}.{ext}"
        if not path.exists():
            return None
        text = path.read_text()
        if defines:
            head, _, rest = text.partition("\n")  # '#version' must stay the first line
            text = head + "\n" + "".join(f"#define {k} {v}\n" for k, v in defines.items()) + rest
        return text

    return ctx.program(
        vertex_shader=source(vertex, "vert"),
        fragment_shader=source(fragment, "frag"),
        geometry_shader=source(geometry, "geom"),
        tess_control_shader=source(tess_control, "tesc"),
        tess_evaluation_shader=source(tess_evaluation, "tese"),
        varyings=varyings,
    )


def set_uniform(program: moderngl.Program, name: str, value) -> None:
    """Set a uniform if the linked program kept it (unused uniforms are optimised away)."""
    if name not in program:
        return
    if isinstance(value, np.ndarray) and value.shape == (4, 4):
        program[name].write(np.ascontiguousarray(value.T, dtype="f4").tobytes())
    else:
        program[name].value = value


class ImageOverlay:
    """A Pillow image drawn over the scene on a screen rectangle, alpha-blended (text panels, the array's cells)."""

    def __init__(self, ctx: moderngl.Context, scaled: bool = False):
        self.ctx = ctx
        self.filter = moderngl.LINEAR if scaled else moderngl.NEAREST  # text at 1:1 stays sharp unfiltered
        self.program = load_program(ctx, "overlay")
        quad = np.array([0, 0, 1, 0, 0, 1, 1, 1], "f4")
        self.vbo = ctx.buffer(quad.tobytes())
        self.vao = ctx.vertex_array(self.program, [(self.vbo, "2f", "in_corner")])
        self.texture = None

    def set_image(self, image: Image.Image | None) -> None:
        """Show ``image`` (RGBA, top row first) from the next draw on; None shows nothing."""
        if self.texture is not None:
            self.texture.release()
            self.texture = None
        if image is None:
            return
        flipped = image.transpose(Image.Transpose.FLIP_TOP_BOTTOM)  # GL textures start at the bottom row
        self.texture = self.ctx.texture(image.size, 4, flipped.tobytes())
        self.texture.filter = (self.filter, self.filter)

    def draw_rect(self, rect: tuple[float, float, float, float]) -> None:
        """Draw the image on ``rect`` = (x, y, width, height) in clip space, (x, y) its bottom-left corner."""
        if self.texture is None:
            return
        self.program["rect"].value = rect
        self.texture.use(0)
        self.ctx.enable(moderngl.BLEND)
        self.ctx.blend_func = moderngl.SRC_ALPHA, moderngl.ONE_MINUS_SRC_ALPHA
        self.ctx.disable(moderngl.DEPTH_TEST)
        self.vao.render(moderngl.TRIANGLE_STRIP)
        self.ctx.disable(moderngl.BLEND)


class TextOverlay(ImageOverlay):
    """Lines of text drawn top-left on a translucent panel (help overlay, status); rendered with Pillow."""

    def __init__(self, ctx: moderngl.Context, font_size: int = 14):
        super().__init__(ctx)
        self.font = ImageFont.load_default(size=font_size)
        self.lines: list[str] = []

    def set_lines(self, lines: list[str]) -> None:
        if lines == self.lines and self.texture is not None:
            return
        self.lines = list(lines)
        if not lines:
            self.set_image(None)
            return
        spacing = int(self.font.size * 1.35)
        width = int(max(self.font.getlength(line) for line in lines)) + 16
        image = Image.new("RGBA", (width, spacing * len(lines) + 12), (0, 0, 0, 170))
        draw = ImageDraw.Draw(image)
        for i, line in enumerate(lines):
            draw.text((8, 6 + i * spacing), line, font=self.font, fill=(255, 255, 255, 255))
        self.set_image(image)

    def draw(self, viewport: tuple[int, int], corner: str = "top-left") -> None:
        if self.texture is None:
            return
        w, h = self.texture.size
        vw, vh = viewport
        x = 8 if corner.endswith("left") else vw - w - 8
        y = vh - h - 8 if corner.startswith("top") else 8
        self.draw_rect((2 * x / vw - 1, 2 * y / vh - 1, 2 * w / vw, 2 * h / vh))


def read_pixels(fbo: moderngl.Framebuffer) -> np.ndarray:
    """(H, W, 3) uint8 with row 0 at the top, as image files store it."""
    w, h = fbo.size
    data = np.frombuffer(fbo.read(components=3, alignment=1), np.uint8).reshape(h, w, 3)
    return np.ascontiguousarray(data[::-1])


def save_png(pixels: np.ndarray, path) -> None:
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    Image.fromarray(pixels).save(path)


def set_camera(program: moderngl.Program, camera) -> None:
    """m_proj, m_view and (for lit shaders) the eye position of ``camera``."""
    set_uniform(program, "m_proj", camera.projection())
    set_uniform(program, "m_view", camera.view())
    if hasattr(camera, "eye"):
        set_uniform(program, "eye", tuple(float(v) for v in camera.eye()))


class GrowableBuffer:
    """A GL buffer reallocated only when what is written no longer fits; then it gets ``headroom`` times the need,
    so a growing tree or mesh does not reallocate every frame. ``write`` returns True when the buffer is new:
    vertex arrays built on the old one must be rebuilt."""

    def __init__(self, ctx: moderngl.Context, headroom: float = 1.0, min_bytes: int = 16):
        self.ctx, self.headroom, self.min_bytes = ctx, headroom, min_bytes
        self.buffer: moderngl.Buffer | None = None

    def write(self, data) -> bool:
        # an array is written through its buffer as bytes, without the host copy tobytes() would make
        raw = data if isinstance(data, bytes) else np.ascontiguousarray(data).reshape(-1).view(np.uint8)
        need = max(len(raw), self.min_bytes)
        grown = self.buffer is None or self.buffer.size < need
        if grown:
            if self.buffer is not None:
                self.buffer.release()
            self.buffer = self.ctx.buffer(reserve=int(need * self.headroom))
        if len(raw):
            self.buffer.write(raw)
        return grown


class Lines:
    """World-space line segments in one colour (wall boxes, debug springs, edges)."""

    def __init__(self, ctx: moderngl.Context, vertices: np.ndarray | None = None, color=(0.0, 1.0, 1.0, 1.0)):
        self.ctx, self.color = ctx, color
        self.program = load_program(ctx, "lines")
        self.vbo = GrowableBuffer(ctx)
        self.count = 0
        if vertices is not None:
            self.set(vertices)

    def set(self, vertices: np.ndarray) -> None:
        data = np.ascontiguousarray(vertices, "f4").reshape(-1, 3)
        if self.vbo.write(data):
            self.vao = self.ctx.vertex_array(self.program, [(self.vbo.buffer, "3f", "in_position")])
        self.count = len(data)

    def draw(self, camera) -> None:
        if not self.count:
            return
        set_camera(self.program, camera)
        self.program["color"].value = tuple(self.color)
        self.vao.render(moderngl.LINES, vertices=self.count)


class Discs:
    """Filled circles drawn instanced (2D particles): per instance x, y, radius, r, g, b, a (7 floats)."""

    FLOATS = 7

    def __init__(self, ctx: moderngl.Context):
        self.ctx = ctx
        self.program = load_program(ctx, "discs")
        corners = np.array([-1, -1, 1, -1, -1, 1, 1, 1], "f4")
        self.quad = ctx.buffer(corners.tobytes())
        self.instances = GrowableBuffer(ctx, min_bytes=4 * self.FLOATS)
        self.count = 0

    def set(self, data: np.ndarray) -> None:
        data = np.ascontiguousarray(data, "f4").reshape(-1, self.FLOATS)
        if self.instances.write(data):
            self.vao = self.ctx.vertex_array(
                self.program,
                [
                    (self.quad, "2f", "in_corner"),
                    (self.instances.buffer, "2f 1f 4f/i", "in_center", "in_radius", "in_color"),
                ],
            )
        self.count = len(data)

    def draw(self, camera) -> None:
        if not self.count:
            return
        set_camera(self.program, camera)
        self.ctx.enable(moderngl.BLEND)
        self.ctx.blend_func = moderngl.SRC_ALPHA, moderngl.ONE_MINUS_SRC_ALPHA
        self.vao.render(moderngl.TRIANGLE_STRIP, instances=self.count)
        self.ctx.disable(moderngl.BLEND)
