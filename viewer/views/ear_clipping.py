"""Ear clipping view (vol.4 ch.5, the DrawTest and TriangulationTest scenes): the triangles filled with a UV
checkerboard, their edges in magenta (the sample's gizmos), the input rings in green, and the ear list of the replay:
the head ear (clipped next) in yellow with its triangle, the other ears in cyan. Left clicks draw a new ring."""

from __future__ import annotations

import colorsys
import math
import time
from pathlib import Path

import moderngl
import numpy as np

from ugpcl.geometry.ear_clipping_input import load_rings, save_rings

from ..camera import FlatCamera
from ..gl import Discs, GrowableBuffer, Lines, load_program, set_camera, set_uniform
from . import Key
from . import View as BaseView

DRAW_RECT = (-5.0 * 16 / 9, 5.0 * 16 / 9, -4.0, 6.0)
"""The DrawTest camera: orthographic size 5 around (0, 1), for a scene with nothing in it yet."""
RINGS_FILE = Path("out") / "ear_clipping_rings.json"
"""Where o saves and i loads the rings."""
PRESET_KEYS = ("nested", "example", "star5", "star12", "comb", "holes", "notch", "glyph", "draw")
"""Presets of the keys 1 .. 9."""


def outline_segments(rings) -> np.ndarray:
    """Closed rings as GL_LINES vertices (x, y, 0)."""
    parts = [np.stack([r, np.roll(r, -1, axis=0)], axis=1).reshape(-1, 2) for r in rings if len(r) >= 2]
    points = np.concatenate(parts) if parts else np.zeros((0, 2))
    return np.column_stack([points, np.zeros(len(points))])


def triangle_segments(vertices: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """The three edges of every triangle as GL_LINES vertices (x, y, 0)."""
    corners = vertices[triangles[:, [0, 1, 1, 2, 2, 0]]].reshape(-1, 2)
    return np.column_stack([corners, np.zeros(len(corners))])


class View(BaseView):
    title = "Triangulation by ear clipping (vol.4 ch.5)"
    background = (0.0, 0.0, 0.0)  # DrawTest's camera clears to black
    keys = (
        Key(".", "clip the next ear (pause with space to go one at a time)", "next_clip"),
        Key(",", "undo the last clip", "previous_clip"),
        Key("0", "replay the clipping from the first ear", "restart_replay"),
        Key("k", "close the drawn ring and triangulate (the sample's right click)", "close_ring"),
        Key("u", "undo: remove the last ring", "undo_ring"),
        Key("c", "clear all rings", "clear_rings"),
        Key("1", "preset nested (TriangulationTest)", "preset_1"),
        Key("2", "preset example (the chapter's 7-vertex ear list, fig. 5.6)", "preset_2"),
        Key("3", "preset star5", "preset_3"),
        Key("4", "preset star12", "preset_4"),
        Key("5", "preset comb", "preset_5"),
        Key("6", "preset holes", "preset_6"),
        Key("7", "preset notch", "preset_7"),
        Key("8", "preset glyph (the text parameter)", "preset_8"),
        Key("9", "preset draw (empty, as DrawTest)", "preset_9"),
        Key("d", "constrained Delaunay flips on/off", "toggle_delaunay"),
        Key("v", "variant: robust / fixed / book (the chapter's clipper as written)", "toggle_variant"),
        Key("f", "fill on/off", "toggle_fill"),
        Key("w", "triangle edges on/off", "toggle_wire"),
        Key("l", "ear list markers on/off", "toggle_ears"),
        Key("e", "mapbox-earcut's triangles over ours (cyan) on/off", "toggle_earcut"),
        Key("o", "save the rings to out/ear_clipping_rings.json", "save"),
        Key("i", "load the rings from out/ear_clipping_rings.json", "load"),
    )

    def __init__(self, ctx: moderngl.Context, sim):
        super().__init__(ctx, sim)
        self.program = load_program(ctx, "ear_clipping")
        self.vbo = GrowableBuffer(ctx)
        self.ibo = GrowableBuffer(ctx)
        self.vao = None
        self.wire = Lines(ctx, color=(1.0, 0.0, 1.0, 1.0))
        self.outline = Lines(ctx, color=(0.0, 1.0, 0.0, 1.0))
        self.head = Lines(ctx, color=(1.0, 0.9, 0.0, 1.0))
        self.earcut_lines = Lines(ctx, color=(0.0, 0.9, 1.0, 1.0))
        self.drawing = Lines(ctx)
        self.markers = Discs(ctx)
        self.show_fill = self.show_wire = self.show_outline = self.show_ears = True
        self.show_earcut = False
        self.pending: list[tuple[float, float]] = []  # the ring being drawn
        self.uploaded = None
        self.index_count = 0
        self.start = time.monotonic()

    # {{{ camera and upload

    def rect(self) -> tuple[float, float, float, float]:
        """The rings' bounding box with a 12% margin (DrawTest's camera when there is nothing yet)."""
        rings = [r for r in self.sim.rings if len(r)]
        if not rings:
            return DRAW_RECT
        points = np.concatenate(rings)
        (x0, y0), (x1, y1) = points.min(axis=0), points.max(axis=0)
        margin = 0.12 * max(x1 - x0, y1 - y0, 1e-6)
        return (x0 - margin, x1 + margin, y0 - margin, y1 + margin)

    def make_camera(self):
        return FlatCamera(rect=self.rect())

    def shown_triangles(self) -> np.ndarray:
        """The clipped ears so far; once all are clipped, the scene's result (Delaunay-flipped if asked)."""
        sim = self.sim
        return sim.triangles if sim.done else sim.ear_triangles[: sim.clips]

    def upload(self) -> None:
        sim = self.sim
        r = sim.result
        key = (id(r), sim.clips, sim.params.delaunay, self.show_earcut)
        if key == self.uploaded:
            return
        self.uploaded = key
        vertices = np.column_stack([r.vertices, r.uv]).astype("f4") if len(r.vertices) else np.zeros((0, 4), "f4")
        triangles = self.shown_triangles()
        grown = self.vbo.write(vertices)
        if self.ibo.write(np.ascontiguousarray(triangles, "u4")) or grown or self.vao is None:
            self.vao = self.ctx.vertex_array(
                self.program, [(self.vbo.buffer, "2f 2f", "in_position", "in_uv")], index_buffer=self.ibo.buffer
            )
        self.index_count = 3 * len(triangles)
        self.wire.set(triangle_segments(r.vertices, triangles))
        self.outline.set(outline_segments(sim.rings))
        # the head of the ear list is the middle vertex of the next triangle of the replay
        upcoming = sim.ear_triangles[sim.clips : sim.clips + 1]
        self.head.set(triangle_segments(r.vertices, upcoming))
        x0, x1, y0, y1 = self.rect()
        size = 0.012 * max(x1 - x0, y1 - y0)
        markers = [(*r.vertices[e], size * (1.6 if k == 0 else 1.0), *((1, 0.9, 0) if k == 0 else (0, 0.9, 1)), 1.0)
                   for k, e in enumerate(sim.ear_list())]  # fmt: skip
        self.markers.set(np.asarray(markers, "f4").reshape(-1, Discs.FLOATS))
        if self.show_earcut:
            vertices, _ = sim.input_arrays()
            self.earcut_lines.set(triangle_segments(vertices, sim.earcut()) if len(vertices) else np.zeros((0, 3)))

    # }}}

    def draw(self, camera) -> None:
        if not self.pending:  # the frame holds still while a ring is drawn: clicks map to where they were seen
            camera.rect = self.rect()
        self.ctx.disable(moderngl.DEPTH_TEST)
        self.ctx.disable(moderngl.CULL_FACE)  # the book's triangles are clockwise: draw both faces
        if self.show_fill and self.index_count:
            set_camera(self.program, camera)
            set_uniform(self.program, "checker_cells", 8.0)
            set_uniform(self.program, "opacity", 1.0)
            self.vao.render(moderngl.TRIANGLES, vertices=self.index_count)
        if self.show_wire:
            self.wire.draw(camera)
        if self.show_earcut:
            self.earcut_lines.draw(camera)
        if self.show_outline:
            self.outline.draw(camera)
        if self.show_ears:
            self.head.draw(camera)
            self.markers.draw(camera)
        if self.pending:
            hue = 0.5 + 0.5 * math.sin(0.5 * (time.monotonic() - self.start))  # DrawTest's line colour
            self.drawing.color = (*colorsys.hsv_to_rgb(hue % 1.0, 1.0, 1.0), 1.0)
            self.drawing.set(outline_segments([np.asarray(self.pending, float)]))
            self.drawing.draw(camera)

    def status(self) -> list[str]:
        sim = self.sim
        s = sim.stats()
        ears = sim.ear_list()
        shown = " ".join(str(e) for e in ears[:16]) + (" ..." if len(ears) > 16 else "")
        lines = [
            f"{sim.params.preset if not sim.params.input else sim.params.input}: rings {s['rings']}  groups "
            f"{s['groups']}  vertices {s['vertices']}  triangles {s['triangles']}  variant {sim.params.variant}"
            f"{'  delaunay' if sim.params.delaunay else ''}{'' if s['complete'] else '  INCOMPLETE'}",
            f"clip {sim.clips}/{len(sim.ear_triangles)}  ear list: {shown or '-'}",
            "left click: add vertex, right click or k: close ring, u: undo, c: clear (the sample's DrawTest)",
        ]
        if self.show_earcut:
            lines.append(f"earcut: {len(sim.earcut())} triangles (ours {len(sim.triangles)})")
        return lines

    # {{{ mouse: DrawTest's left click adds a vertex, its right click closes the ring

    def on_drag(self, camera, u: float, v: float, du: float, dv: float) -> None:
        if du == 0.0 and dv == 0.0:  # a click, not a drag
            self.pending.append(camera.to_world(u, v))

    def on_right_click(self, camera, u: float, v: float) -> None:
        """DrawTest's right click closes the ring (as the k key does)."""
        self.close_ring()

    # }}}

    # {{{ key actions

    def next_clip(self) -> None:
        self.sim.seek(self.sim.clips + 1)

    def previous_clip(self) -> None:
        self.sim.seek(self.sim.clips - 1)

    def restart_replay(self) -> None:
        self.sim.seek(0)

    def close_ring(self) -> None:
        if len(self.pending) >= 3:
            self.sim.add_ring(self.pending)
        self.pending = []

    def undo_ring(self) -> None:
        self.sim.undo_ring()

    def clear_rings(self) -> None:
        self.pending = []
        self.sim.clear_rings()

    def _preset(self, number: int) -> None:
        self.pending = []
        self.sim.update(input="", preset=PRESET_KEYS[number - 1])

    def preset_1(self) -> None:
        self._preset(1)

    def preset_2(self) -> None:
        self._preset(2)

    def preset_3(self) -> None:
        self._preset(3)

    def preset_4(self) -> None:
        self._preset(4)

    def preset_5(self) -> None:
        self._preset(5)

    def preset_6(self) -> None:
        self._preset(6)

    def preset_7(self) -> None:
        self._preset(7)

    def preset_8(self) -> None:
        self._preset(8)

    def preset_9(self) -> None:
        self._preset(9)

    def toggle_delaunay(self) -> None:
        rings = list(self.sim.rings)
        self.sim.update(delaunay=not self.sim.params.delaunay)
        self._keep(rings)

    def toggle_variant(self) -> None:
        rings = list(self.sim.rings)
        order = ("robust", "fixed", "book")
        self.sim.update(variant=order[(order.index(self.sim.params.variant) + 1) % len(order)])
        self._keep(rings)

    def _keep(self, rings) -> None:
        """A parameter change resets to the preset: keep the rings drawn by hand."""
        if [r.tolist() for r in rings] != [r.tolist() for r in self.sim.rings]:
            self.sim.rings = rings
            self.sim.triangulate()

    def toggle_fill(self) -> None:
        self.show_fill = not self.show_fill

    def toggle_wire(self) -> None:
        self.show_wire = not self.show_wire

    def toggle_ears(self) -> None:
        self.show_ears = not self.show_ears

    def toggle_earcut(self) -> None:
        self.show_earcut = not self.show_earcut

    def save(self) -> None:
        save_rings(RINGS_FILE, self.sim.rings)
        print(f"ugpcl-view: wrote {RINGS_FILE}")

    def load(self) -> None:
        if RINGS_FILE.is_file():
            self.sim.rings = load_rings(RINGS_FILE)
            self.sim.triangulate()

    # }}}
