"""Compute intro views (vol.1 ch.2): the two gradient textures on quads, the array results, the dispatch probe."""

from __future__ import annotations

import moderngl
import numpy as np
from PIL import Image, ImageDraw, ImageFont

from ..camera import OrbitCamera
from ..gl import ImageOverlay, TextOverlay, load_program, set_camera
from . import Key
from . import View as BaseView

QUADS = {"tex_a": -1.0, "tex_b": 1.0}
"""x of each texture's quad centre; both at y = 1, z = -1 (the book's scene: plane_A left, plane_B right)."""
LOCAL_SHAPES = ((8, 8), (16, 16), (64, 1), (1, 64))
"""numthreads shapes the [ and ] keys cycle through."""
MODES = ("texture", "array", "probe")
ARRAY_ROWS = (
    ("KernelFunction_A", "array_after_a"),
    ("KernelFunction_B", "array_after_b"),
    ("KernelFunction_B_atomic", "array_after_b_atomic"),
)
"""The array sample's three results, in the book's Debug.Log order: one row of cells each."""
CELL = 150
"""Side in pixels of one cell of the array panel (drawn at 1280x720 about as large)."""
LOW, HIGH = np.array([40, 60, 150]), np.array([255, 200, 40])
"""Cell colours of the smallest and the largest value shown (a value's colour is the mix between them)."""


def array_panel(state) -> Image.Image:
    """The array sample as a picture: each kernel's label, then its 4 ints as cells coloured by value and headed
    by their index, on a translucent panel (RGBA, top row first)."""
    font = ImageFont.load_default(size=34)
    label_width = int(max(font.getlength(label) for label, _ in ARRAY_ROWS)) + 40
    width, height = label_width + 4 * CELL + 30, (len(ARRAY_ROWS) + 0.5) * CELL + 30
    image = Image.new("RGBA", (width, int(height)), (0, 0, 0, 140))
    draw = ImageDraw.Draw(image)
    values = np.concatenate([np.asarray(state[key]) for _, key in ARRAY_ROWS])
    low, span = values.min(), max(values.max() - values.min(), 1)
    for i in range(4):
        draw.text((label_width + (i + 0.5) * CELL, 15 + CELL // 4), f"[{i}]", font=font, anchor="mm", fill="white")
    for row, (label, key) in enumerate(ARRAY_ROWS):
        top = 15 + CELL // 2 + row * CELL
        draw.text((20, top + CELL // 2), label, font=font, anchor="lm", fill="white")
        for i, value in enumerate(np.asarray(state[key])):
            colour = tuple(int(c) for c in LOW + (HIGH - LOW) * (value - low) / span)
            box = (label_width + i * CELL + 6, top + 6, label_width + (i + 1) * CELL - 6, top + CELL - 6)
            draw.rectangle(box, fill=(*colour, 255), outline="white", width=3)
            ink = "black" if sum(colour) > 400 else "white"
            draw.text(((box[0] + box[2]) / 2, (box[1] + box[3]) / 2), str(value), font=font, anchor="mm", fill=ink)
    return image


class View(BaseView):
    title = "Compute intro (vol.1 ch.2)"
    keys = (
        Key("tab", "switch texture / array / probe view", "next_mode"),
        Key("[", "previous numthreads shape of the texture kernels", "previous_shape"),
        Key("]", "next numthreads shape of the texture kernels", "next_shape"),
        Key("+", "int_value + 1 (array sample)", "more_int_value"),
        Key("-", "int_value - 1 (array sample)", "less_int_value"),
        Key("g", "groups 1 -> 2 -> 4 (array sample: the local-id race)", "next_groups"),
    )
    start_mode = "texture"

    def __init__(self, ctx: moderngl.Context, sim):
        super().__init__(ctx, sim)
        self.mode = self.start_mode
        self.program = load_program(ctx, "compute_intro")
        # unit quad in the xy plane facing the camera (-z), uv (0, 0) at the bottom-left
        quad = np.array([[-0.5, -0.5, 0, 0, 0], [0.5, -0.5, 0, 1, 0], [-0.5, 0.5, 0, 0, 1], [0.5, 0.5, 0, 1, 1]], "f4")
        self.vbo = ctx.buffer(quad.tobytes())
        self.vao = ctx.vertex_array(self.program, [(self.vbo, "3f 2f", "in_position", "in_uv")])
        self.textures: dict[str, moderngl.Texture] = {}
        self.text = TextOverlay(ctx, font_size=18)
        self.panel = ImageOverlay(ctx, scaled=True)  # the array view's cells, remade when the values change
        self.panel_state: tuple = ()

    def make_camera(self):
        # book: camera at (0, 1, -3) looking along +z, FOV 60
        return OrbitCamera(target=(0.0, 1.0, 0.0), distance=3.0)

    def upload(self) -> None:
        state = self.sim.state()
        for name in QUADS:
            if name not in state:
                continue
            pixels = state[name]
            h, w = pixels.shape[:2]
            texture = self.textures.get(name)
            if texture is None or texture.size != (w, h):
                texture = self.ctx.texture((w, h), 4)
                texture.filter = (moderngl.NEAREST, moderngl.NEAREST)  # keep the 1/512 steps exact
                self.textures[name] = texture
            texture.write(pixels.tobytes())  # row 0 = bottom, as GL expects
        self.text.set_lines(self._text_lines(state))
        if "array_after_a" in state:
            key = tuple(tuple(np.asarray(state[k]).tolist()) for _, k in ARRAY_ROWS)
            if key != self.panel_state:
                self.panel.set_image(array_panel(state))
                self.panel_state = key

    def _text_lines(self, state) -> list[str]:
        if self.mode == "array" and "array_after_a" in state:
            p = self.sim.params
            lines = [
                "RESULT : KernelFunction_A " + " ".join(map(str, state["array_after_a"])),
                "RESULT : KernelFunction_B " + " ".join(map(str, state["array_after_b"])),
                "RESULT : KernelFunction_B_atomic " + " ".join(map(str, state["array_after_b_atomic"])),
                f"intValue = {p.int_value}, groups = {p.groups} x numthreads(4, 1, 1)",
            ]
            if p.groups > 1:
                lines.append("groups > 1: every group writes elements 0..3 (KernelFunction_B races)")
            return lines
        if self.mode == "probe" and "probe_global" in state:
            p = self.sim.params
            lines = [
                f"numthreads{p.probe_numthreads} x Dispatch{p.probe_groups}",
                "group      local      global     index",
            ]
            for g, loc, glob, flat in zip(
                state["probe_group"], state["probe_local"], state["probe_global"], state["probe_flat"], strict=True
            ):
                lines.append(f"{tuple(g)!s:10s} {tuple(loc)!s:10s} {tuple(glob)!s:10s} {flat}")
            return lines[:40]
        return []

    def draw(self, camera) -> None:
        if self.mode == "texture":
            self.ctx.enable(moderngl.DEPTH_TEST)
            set_camera(self.program, camera)
            for name, x in QUADS.items():
                if name in self.textures:
                    model = np.identity(4)
                    model[:3, 3] = (x, 1.0, -1.0)
                    self.program["m_model"].write(np.ascontiguousarray(model.T, "f4").tobytes())
                    self.textures[name].use(0)
                    self.vao.render(moderngl.TRIANGLE_STRIP)
        else:
            if self.mode == "array" and self.panel.texture is not None:
                self._draw_panel()
            self.text.draw(self.ctx.viewport[2:], corner="top-left")

    def _draw_panel(self) -> None:
        """The array panel centred below the log, scaled to 80 % of the width or 65 % of the height."""
        w, h = self.panel.texture.size
        vw, vh = self.ctx.viewport[2:]
        scale = min(0.8 * vw / w, 0.65 * vh / h)
        sw, sh = 2 * w * scale / vw, 2 * h * scale / vh  # clip-space size
        self.panel.draw_rect((-sw / 2, -0.92, sw, sh))  # bottom edge just above the frame's

    def status(self) -> list[str]:
        tx, ty = self.sim.params.local_size
        return [f"view: {self.mode}   numthreads({tx}, {ty}, 1)"]

    # {{{ key actions

    def next_mode(self) -> None:
        self.mode = MODES[(MODES.index(self.mode) + 1) % len(MODES)]

    def _shift_shape(self, step: int) -> None:
        current = tuple(self.sim.params.local_size)
        index = LOCAL_SHAPES.index(current) if current in LOCAL_SHAPES else 0
        self.sim.update(local_size=LOCAL_SHAPES[(index + step) % len(LOCAL_SHAPES)])

    def previous_shape(self) -> None:
        self._shift_shape(-1)

    def next_shape(self) -> None:
        self._shift_shape(1)

    def more_int_value(self) -> None:
        self.sim.update(int_value=self.sim.params.int_value + 1)

    def less_int_value(self) -> None:
        self.sim.update(int_value=self.sim.params.int_value - 1)

    def next_groups(self) -> None:
        self.sim.update(groups={1: 2, 2: 4}.get(self.sim.params.groups, 1))

    # }}}


class ArrayView(View):
    start_mode = "array"
