"""Space colonization views (vol.4 ch.1): the book's Line and TubularEdge scenes. ``EdgeRenderer``, ``Points`` and
the distance keys (``TunableDistances``) are shared with the skinned view (space_colonization_skinned.py) and the
CPU view (space_colonization_cpu.py).

Node and edge records go to SSBOs unchanged (std430 packs the 32-byte Node and 8-byte Edge as OpenCL does); one
2-vertex segment is drawn instanced once per live edge, and the vertex stage reads its two nodes (Edge.shader).
Each frame moves only the live records (``live_records``: the node slots up to the last live one, which the pool
hands out from slot 0, and the live edges) through the page-locked copies of ``Runtime.read_back``; the attractions
cross only while they are drawn, and otherwise the status line's count of the active ones comes from
``count_active_attractions`` (on a GPU 4 bytes).
Tubes: a geometry shader turns each segment into a capsule (TubularEdge.shader).
"""

from __future__ import annotations

from pathlib import Path

import moderngl
import numpy as np

from ..camera import OrbitCamera
from ..gl import GrowableBuffer, load_program, set_camera, set_uniform
from . import Key
from . import View as BaseView

BACKGROUND = (0.067, 0.092, 0.132)
"""The book's camera background (Line and TubularEdge scenes)."""
TUNABLE = ("influence_distance", "growth_distance", "kill_distance")
"""What keys 1/2/3 select for +/- (book: the three density parameters of the summary)."""
SIDE_STEP = 4
"""[ and ] change side by this (a new cloud)."""


def scale_matrix(s: float) -> np.ndarray:
    return np.diag([s, s, s, 1.0])


class EdgeRenderer:
    """Nodes + edges in SSBOs; draws the live edges as additive lines or as lit capsules."""

    def __init__(
        self,
        ctx: moderngl.Context,
        geometry: str = "space_colonization_tube",
        tube_fragment: str = "space_colonization_tube",
        vertex: str = "space_colonization",
    ):
        self.ctx = ctx
        self.line_program = load_program(ctx, vertex, vertex=vertex, fragment="space_colonization_line")
        self.tube_program = load_program(ctx, vertex, vertex=vertex, geometry=geometry, fragment=tube_fragment)
        self.line_vao = ctx.vertex_array(self.line_program, [])
        self.tube_vao = ctx.vertex_array(self.tube_program, [])
        self.nodes = GrowableBuffer(ctx, headroom=2.0)
        self.edges = GrowableBuffer(ctx, headroom=2.0)
        self.edge_count = 0

    def set(self, nodes: np.ndarray, edges: np.ndarray) -> None:
        self.nodes.write(nodes)  # storage buffers are bound at draw time: no vertex array to rebuild
        self.edges.write(edges)
        self.edge_count = len(edges)

    def _bind(self) -> None:
        self.nodes.buffer.bind_to_storage_buffer(0)
        self.edges.buffer.bind_to_storage_buffer(1)

    def draw_lines(self, camera, model: np.ndarray, color=(1.0, 1.0, 1.0, 1.0)) -> None:
        if not self.edge_count:
            return
        self._bind()
        set_camera(self.line_program, camera)
        set_uniform(self.line_program, "m_model", model)
        set_uniform(self.line_program, "color", tuple(color))
        self.ctx.disable(moderngl.DEPTH_TEST)  # book: ZTest off, Blend One One
        self.ctx.enable(moderngl.BLEND)
        self.ctx.blend_func = moderngl.ONE, moderngl.ONE
        self.line_vao.render(moderngl.LINES, vertices=2, instances=self.edge_count)
        self.ctx.disable(moderngl.BLEND)
        self.ctx.blend_func = moderngl.SRC_ALPHA, moderngl.ONE_MINUS_SRC_ALPHA

    def draw_tubes(self, camera, model: np.ndarray, thickness: float, program=None, **uniforms) -> None:
        if not self.edge_count:
            return
        program = program or self.tube_program
        self._bind()
        set_camera(program, camera)
        set_uniform(program, "m_model", model)
        set_uniform(program, "thickness", float(thickness))
        for name, value in uniforms.items():
            set_uniform(program, name, value)
        self.ctx.enable(moderngl.DEPTH_TEST)
        vao = self.tube_vao if program is self.tube_program else self.ctx.vertex_array(program, [])
        vao.render(moderngl.LINES, vertices=2, instances=self.edge_count)


class Points:
    """GL_POINTS in one colour and size (attraction points, the blog's vertices)."""

    def __init__(self, ctx: moderngl.Context):
        self.ctx = ctx
        self.program = load_program(ctx, "space_colonization_points")
        self.vbo = GrowableBuffer(ctx, headroom=2.0, min_bytes=12)
        self.count = 0

    def set(self, positions: np.ndarray) -> None:
        data = np.ascontiguousarray(positions, "f4").reshape(-1, 3)
        if self.vbo.write(data):
            self.vao = self.ctx.vertex_array(self.program, [(self.vbo.buffer, "3f", "in_position")])
        self.count = len(data)

    def draw(self, camera, model: np.ndarray, color, size: float) -> None:
        if not self.count:
            return
        set_camera(self.program, camera)
        set_uniform(self.program, "m_model", model)
        set_uniform(self.program, "color", tuple(color))
        set_uniform(self.program, "point_size", float(size))
        self.ctx.enable(moderngl.PROGRAM_POINT_SIZE)
        self.vao.render(moderngl.POINTS, vertices=self.count)
        self.ctx.disable(moderngl.PROGRAM_POINT_SIZE)


class TunableDistances:
    """Keys 1/2/3 select one of the three distances, + and - scale it (the sphere and the skinned views)."""

    selected: str = TUNABLE[0]

    def select_influence(self) -> None:
        self.selected = TUNABLE[0]

    def select_growth(self) -> None:
        self.selected = TUNABLE[1]

    def select_kill(self) -> None:
        self.selected = TUNABLE[2]

    def scale_up(self) -> None:
        self.sim.update(**{self.selected: getattr(self.sim.params, self.selected) * 1.1})

    def scale_down(self) -> None:
        self.sim.update(**{self.selected: getattr(self.sim.params, self.selected) / 1.1})


class View(TunableDistances, BaseView):
    title = "Space colonization (vol.4 ch.1)"
    background = BACKGROUND
    keys = (
        Key("tab", "line / tube rendering", "toggle_tubes"),
        Key("a", "show active attractions on/off", "toggle_attractions"),
        Key("1", "select influence_distance for + and -", "select_influence"),
        Key("2", "select growth_distance for + and -", "select_growth"),
        Key("3", "select kill_distance for + and -", "select_kill"),
        Key("+", "selected distance x 1.1", "scale_up"),
        Key("-", "selected distance / 1.1", "scale_down"),
        Key("[", "side - 4 (a new, coarser cloud)", "smaller_side"),
        Key("]", "side + 4 (a new, finer cloud)", "larger_side"),
        Key("f", "frame skip: run every 1..5 frames", "next_frame"),
        Key("i", "iterations per run: 1..5", "next_iterations"),
        Key("g", "repeat guard on/off", "toggle_repeat_guard"),
        Key("c", "search: all pairs / uniform grid", "toggle_search"),
        Key("e", "export the tree to out/space_colonization.obj", "export"),
    )

    def __init__(self, ctx: moderngl.Context, sim):
        super().__init__(ctx, sim)
        self.edges = EdgeRenderer(ctx)
        self.points = Points(ctx)
        self.show_attractions = False
        self.active_attractions = 0

    def make_camera(self):
        return OrbitCamera(target=(0.0, 0.0, 0.0), distance=10.0, fov=40.0)  # book: FOV 40 at (0, 0, -10)

    def upload(self) -> None:
        sim = self.sim
        self.edges.set(*sim.live_records())
        if not self.show_attractions:
            self.active_attractions = sim.count_active_attractions()  # on a GPU 4 bytes, not every record
            return
        attractions = sim.runtime.read_back(sim.attractions)
        active = attractions["active"] != 0
        self.points.set(attractions["position"][active])
        self.active_attractions = int(active.sum())

    def model(self) -> np.ndarray:
        return scale_matrix(self.sim.params.object_scale)

    def draw(self, camera) -> None:
        p = self.sim.params
        if p.render == "tubes":
            self.edges.draw_tubes(camera, self.model(), p.tube_radius * p.object_scale, color=(1.0, 1.0, 1.0, 1.0))
        else:
            self.edges.draw_lines(camera, self.model())
        if self.show_attractions:
            self.points.draw(camera, self.model(), (0.3, 0.9, 0.4, 1.0), 2.0)

    def status(self) -> list[str]:
        sim, p = self.sim, self.sim.params
        return [
            f"A = {sim.attraction_count} ({self.active_attractions} active)  nodes {sim.live_nodes} live / "
            f"{sim.free_slots} free slots  edges {sim.live_edges}  steps {sim.steps}",
            f"{p.render}  search {p.search}  guard {'on' if p.repeat_guard else 'off'}  "
            f"frame {p.frame} x {p.iterations}  [{self.selected} = {getattr(p, self.selected):.3g}]",
        ]

    # {{{ key actions

    def toggle_tubes(self) -> None:
        self.sim.update(render="tubes" if self.sim.params.render == "lines" else "lines")

    def toggle_attractions(self) -> None:
        self.show_attractions = not self.show_attractions

    def smaller_side(self) -> None:
        self.sim.update(side=max(8, self.sim.params.side - SIDE_STEP))

    def larger_side(self) -> None:
        self.sim.update(side=min(160, self.sim.params.side + SIDE_STEP))

    def next_frame(self) -> None:
        self.sim.update(frame=self.sim.params.frame % 5 + 1)

    def next_iterations(self) -> None:
        self.sim.update(iterations=self.sim.params.iterations % 5 + 1)

    def toggle_repeat_guard(self) -> None:
        self.sim.update(repeat_guard=not self.sim.params.repeat_guard)

    def toggle_search(self) -> None:
        self.sim.update(search="grid" if self.sim.params.search == "all_pairs" else "all_pairs")

    def export(self) -> None:
        path = Path("out") / "space_colonization.obj"
        self.sim.export_mesh(path)
        print(f"ugpcl-view: wrote {path}")

    # }}}
