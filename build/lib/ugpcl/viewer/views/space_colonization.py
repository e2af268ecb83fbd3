"""Space colonization views (vol.4 ch.1): the book's Line and TubularEdge scenes, the blog's CPU tree, and the
skinned figure (SkinnedAnimation scene).

Node and edge records go to SSBOs unchanged (std430 packs the 32-byte Node and 8-byte Edge as OpenCL does); one
2-vertex segment is drawn instanced once per live edge, and the vertex stage reads its two nodes (Edge.shader).
Tubes: a geometry shader turns each segment into a capsule (TubularEdge.shader).
"""

from __future__ import annotations

from pathlib import Path

import moderngl
import numpy as np

from ..camera import OrbitCamera, orthographic
from ..gl import Lines, load_program, set_camera, set_uniform
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
        self.nodes = self.edges = None
        self.edge_count = 0

    def _fit(self, buffer, data: bytes):
        if buffer is None or buffer.size < max(len(data), 16):
            if buffer is not None:
                buffer.release()
            buffer = self.ctx.buffer(reserve=max(len(data), 16) * 2)
        if data:
            buffer.write(data)
        return buffer

    def set(self, nodes: np.ndarray, edges: np.ndarray) -> None:
        self.nodes = self._fit(self.nodes, nodes.tobytes())
        self.edges = self._fit(self.edges, edges.tobytes())
        self.edge_count = len(edges)

    def _bind(self) -> None:
        self.nodes.bind_to_storage_buffer(0)
        self.edges.bind_to_storage_buffer(1)

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
        self.vbo = None
        self.count = 0

    def set(self, positions: np.ndarray) -> None:
        data = np.ascontiguousarray(positions, "f4").reshape(-1, 3)
        if self.vbo is None or self.vbo.size < max(data.nbytes, 12):
            if self.vbo is not None:
                self.vbo.release()
            self.vbo = self.ctx.buffer(reserve=max(data.nbytes, 12) * 2)
            self.vao = self.ctx.vertex_array(self.program, [(self.vbo, "3f", "in_position")])
        if data.nbytes:
            self.vbo.write(data.tobytes())
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


class View(BaseView):
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
        self.selected = TUNABLE[0]

    def make_camera(self):
        return OrbitCamera(target=(0.0, 0.0, 0.0), distance=10.0, fov=40.0)  # book: FOV 40 at (0, 0, -10)

    def upload(self) -> None:
        self.edges.set(self.sim.read_nodes(), self.sim.read_edges())
        attractions = self.sim.read_attractions()
        live = attractions["active"] != 0
        self.active_attractions = int(live.sum())
        if self.show_attractions:
            self.points.set(attractions["position"][live])

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
            f"A = {sim.count} ({self.active_attractions} active)  nodes {sim.capacity - sim.nodes_count} used / "
            f"{sim.nodes_count} free  edges {sim.edges_count}  steps {sim.steps}",
            f"{p.render}  search {p.search}  guard {'on' if p.repeat_guard else 'off'}  "
            f"frame {p.frame} x {p.iterations}  [{self.selected} = {getattr(p, self.selected):.3g}]",
        ]

    # {{{ key actions

    def toggle_tubes(self) -> None:
        self.sim.update(render="tubes" if self.sim.params.render == "lines" else "lines")

    def toggle_attractions(self) -> None:
        self.show_attractions = not self.show_attractions

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


class CpuView(BaseView):
    """The blog's demo: green attraction points, brown vertices and segments, turning 50 degrees/s about y."""

    title = "Space colonization on the CPU (the blog)"
    background = (0.0, 0.0, 0.0)
    keys = (
        Key("a", "attraction points on/off", "toggle_points"),
        Key("o", "auto-rotation on/off", "toggle_rotation"),
        Key("g", "repeat guard on/off (restarts)", "toggle_repeat_guard"),
        Key("c", "clear the crown's leftover points before the roots on/off (restarts)", "toggle_clear"),
        Key("+", "branch size x 1.25 (restarts)", "longer_branches"),
        Key("-", "branch size / 1.25 (restarts)", "shorter_branches"),
        Key("e", "export the segments to out/space_colonization_cpu.obj", "export"),
    )
    ROTATION_PER_FRAME = 50.0 / 60.0
    """Degrees per drawn frame (the blog demo: 50 degrees/s)."""

    def __init__(self, ctx: moderngl.Context, sim):
        super().__init__(ctx, sim)
        self.segments = Lines(ctx, color=(204 / 256, 102 / 256, 0.0, 1.0))
        self.vertices = Points(ctx)
        self.attractions = Points(ctx)
        self.show_points, self.rotate = True, True

    def make_camera(self):
        # the blog: FOV 45, the tree moved by (0, -150, -400) in front of a GL (right-handed) camera; looking at
        # y = 120 instead of 150 keeps the roots in a 4:3 window
        return OrbitCamera(
            target=(0.0, 120.0, 0.0), distance=400.0, yaw=180.0, fov=45.0, near=1.0, far=2000.0, left_handed=False
        )

    def png_camera(self):
        return OrbitCamera(
            target=(0.0, 105.0, 0.0),
            distance=330.0,
            yaw=150.0,
            pitch=8.0,
            fov=45.0,
            near=1.0,
            far=2000.0,
            left_handed=False,
        )

    def upload(self) -> None:
        tree = self.sim.tree
        segments = np.asarray(tree.segments, np.int64).reshape(-1, 2)
        self.segments.set(tree.vertices[segments].reshape(-1, 3))
        self.vertices.set(tree.vertices)
        self.attractions.set(tree.points)

    def draw(self, camera) -> None:
        identity = np.identity(4)
        self.ctx.enable(moderngl.DEPTH_TEST)
        self.segments.draw(camera)
        self.vertices.draw(camera, identity, (170 / 256, 80 / 256, 0.0, 1.0), 3.0)
        if self.show_points:
            self.attractions.draw(camera, identity, (0.0, 1.0, 0.0, 1.0), 2.0)
        if self.rotate:
            camera.yaw += self.ROTATION_PER_FRAME

    def status(self) -> list[str]:
        s = self.sim.stats()
        return [
            f"stage {s['stage']}  vertices {s['vertices']}  points left {s['points left']}  "
            f"iterations {s['iterations (crown, roots)']}  stalled {s['stalled (crown, roots)']}"
        ]

    def toggle_points(self) -> None:
        self.show_points = not self.show_points

    def toggle_rotation(self) -> None:
        self.rotate = not self.rotate

    def toggle_repeat_guard(self) -> None:
        self.sim.update(repeat_guard=not self.sim.params.repeat_guard)

    def toggle_clear(self) -> None:
        self.sim.update(clear_leftovers=not self.sim.params.clear_leftovers)

    def longer_branches(self) -> None:
        self.sim.update(branch_size=self.sim.params.branch_size * 1.25)

    def shorter_branches(self) -> None:
        self.sim.update(branch_size=self.sim.params.branch_size / 1.25)

    def export(self) -> None:
        path = Path("out") / "space_colonization_cpu.obj"
        self.sim.export_mesh(path)
        print(f"ugpcl-view: wrote {path}")


# {{{ the skinned figure (book section 1.4, SkinnedAnimation scene)

LIGHT_DIRECTION = np.array([0.247, -0.499, 0.831])
"""The SkinnedAnimation scene's directional light travels this way (Unity coordinates, kept as the world's)."""
LIGHT_INTENSITY = 0.8
AMBIENT = (0.212, 0.227, 0.259)
TUBE_ALBEDO, TUBE_SMOOTHNESS, TUBE_EMISSION = (0.726, 0.726, 0.726), 0.5, (2.0, 2.0, 2.0)
FLOOR_ALBEDO, FLOOR_SIZE = (0.868, 0.868, 0.868), 20.0
SHADOW_SIZE = 2048
"""Shadow map resolution (the scene's light: soft shadows, strength 1)."""


class LightCamera:
    """The directional light as a camera for the shadow pass: orthographic, looking along the light at `target`."""

    def __init__(self, target, half: float = 1.5, distance: float = 6.0):
        from ..camera import look_at

        self.target = np.asarray(target, float)
        self.position = self.target - LIGHT_DIRECTION / np.linalg.norm(LIGHT_DIRECTION) * distance
        self._view = look_at(self.position, self.target)
        self._projection = orthographic(-half, half, -half, half, 0.1, 2 * distance)

    def view(self) -> np.ndarray:
        return self._view

    def projection(self) -> np.ndarray:
        return self._projection

    def eye(self) -> np.ndarray:
        return self.position


class SkinnedView(BaseView):
    """Lit capsules on the skinned node positions, glowing where they grow, over a floor that takes their shadow."""

    title = "Space colonization in a dancing figure (vol.4 ch.1)"
    keys = (
        Key("tab", "tubes / lines", "toggle_tubes"),
        Key("p", "pause / play the animation", "toggle_animation"),
        Key("b", "body mesh on/off", "toggle_body"),
        Key("l", "shadows on/off", "toggle_shadows"),
        Key("g", "repeat guard on/off", "toggle_repeat_guard"),
        Key("1", "select influence_distance for + and -", "select_influence"),
        Key("2", "select growth_distance for + and -", "select_growth"),
        Key("3", "select kill_distance for + and -", "select_kill"),
        Key("+", "selected distance x 1.1", "scale_up"),
        Key("-", "selected distance / 1.1", "scale_down"),
        Key("e", "export the tubes at this pose to out/space_colonization_skinned.obj", "export"),
    )

    def __init__(self, ctx: moderngl.Context, sim):
        super().__init__(ctx, sim)
        self.edges = EdgeRenderer(ctx, vertex="space_colonization_skinned", tube_fragment="space_colonization_skinned")
        self.floor_program = load_program(ctx, "space_colonization_floor")
        half = FLOOR_SIZE / 2
        quad = np.array([[-half, 0, -half], [half, 0, -half], [-half, 0, half], [half, 0, half]], "f4")
        self.floor_vbo = ctx.buffer(quad.tobytes())
        self.floor_vao = ctx.vertex_array(self.floor_program, [(self.floor_vbo, "3f", "in_position")])
        self.body_program = load_program(ctx, "space_colonization_body")
        vertices = sim.mesh_vertices.astype("f4")
        self.body_vbo = ctx.buffer(vertices.tobytes())
        self.bone_vbo = ctx.buffer(sim.mesh_bone.astype("i4").tobytes())
        self.body_ibo = ctx.buffer(sim.mesh_triangles.astype("i4").tobytes())
        self.body_vao = ctx.vertex_array(
            self.body_program,
            [(self.body_vbo, "3f", "in_position"), (self.bone_vbo, "1i", "in_bone")],
            index_buffer=self.body_ibo,
        )
        self.shadow_map = ctx.depth_texture((SHADOW_SIZE, SHADOW_SIZE))
        self.shadow_map.compare_func = "<="
        self.shadow_map.repeat_x = self.shadow_map.repeat_y = False
        self.shadow_fbo = ctx.framebuffer(depth_attachment=self.shadow_map)
        self.light = LightCamera(target=(0.0, 0.9, 0.0))
        self.lines_mode, self.show_body, self.shadows = False, False, True
        self.selected = TUNABLE[0]

    def make_camera(self):
        # the book: FOV 23, pitched 10.23 degrees down, the whole character in view
        return OrbitCamera(target=(0.0, 0.95, 0.0), distance=6.0, pitch=10.23, fov=23.0)

    def upload(self) -> None:
        self.edges.set(self.sim.read_nodes(), self.sim.read_edges())

    def _tube_uniforms(self) -> dict:
        return {
            "albedo": TUBE_ALBEDO,
            "smoothness": TUBE_SMOOTHNESS,
            "emission": TUBE_EMISSION,
            "light_direction": tuple(LIGHT_DIRECTION),
            "light_intensity": LIGHT_INTENSITY,
            "ambient": AMBIENT,
        }

    def _skin(self) -> bytes:
        skin = self.sim.figure.skinning(self.sim.anim_time)
        return np.ascontiguousarray(np.transpose(skin, (0, 2, 1)), "f4").tobytes()  # column-major per matrix

    def _draw_shadow_pass(self) -> None:
        target, viewport = self.ctx.fbo, self.ctx.viewport
        self.shadow_fbo.use()
        self.ctx.viewport = (0, 0, SHADOW_SIZE, SHADOW_SIZE)
        self.shadow_fbo.clear(depth=1.0)
        thickness = self.sim.params.tube_radius
        self.edges.draw_tubes(self.light, np.identity(4), thickness, **self._tube_uniforms())
        if self.show_body:
            self._draw_body(self.light, opaque=True)
        target.use()
        self.ctx.viewport = viewport

    def _draw_body(self, camera, opaque: bool = False) -> None:
        set_camera(self.body_program, camera)
        self.body_program["skin"].write(self._skin())
        set_uniform(self.body_program, "light_direction", tuple(LIGHT_DIRECTION))
        set_uniform(self.body_program, "color", (0.75, 0.8, 0.9, 1.0 if opaque else 0.25))
        self.ctx.enable(moderngl.DEPTH_TEST)
        if not opaque:
            self.ctx.enable(moderngl.BLEND)
            self.ctx.blend_func = moderngl.SRC_ALPHA, moderngl.ONE_MINUS_SRC_ALPHA
            self.ctx.depth_mask = False
        self.body_vao.render(moderngl.TRIANGLES)
        self.ctx.depth_mask = True
        self.ctx.disable(moderngl.BLEND)

    def draw(self, camera) -> None:
        if self.shadows and not self.lines_mode:
            self._draw_shadow_pass()
        self.ctx.enable(moderngl.DEPTH_TEST)
        set_camera(self.floor_program, camera)
        set_uniform(self.floor_program, "m_light", self.light.projection() @ self.light.view())
        set_uniform(self.floor_program, "albedo", FLOOR_ALBEDO)
        set_uniform(self.floor_program, "light_direction", tuple(LIGHT_DIRECTION))
        set_uniform(self.floor_program, "light_intensity", LIGHT_INTENSITY)
        set_uniform(self.floor_program, "ambient", AMBIENT)
        set_uniform(self.floor_program, "shadows", self.shadows and not self.lines_mode)
        set_uniform(self.floor_program, "texel", 1.0 / SHADOW_SIZE)
        self.shadow_map.use(0)
        set_uniform(self.floor_program, "shadow_map", 0)
        self.floor_vao.render(moderngl.TRIANGLE_STRIP)
        if self.lines_mode:
            self.edges.draw_lines(camera, np.identity(4), color=(0.2, 0.2, 0.2, 1.0))
        else:
            self.edges.draw_tubes(camera, np.identity(4), self.sim.params.tube_radius, **self._tube_uniforms())
        if self.show_body:
            self._draw_body(camera)

    def status(self) -> list[str]:
        sim, p = self.sim, self.sim.params
        return [
            f"A = {sim.count}  nodes {sim.capacity - sim.nodes_count} used / {sim.nodes_count} free  "
            f"edges {sim.edges_count}  steps {sim.steps}",
            f"clip {sim.anim_time:.2f} s {'playing' if p.animate else 'paused'}  "
            f"guard {'on' if p.repeat_guard else 'off'}  [{self.selected} = {getattr(p, self.selected):.3g}]",
        ]

    # {{{ key actions

    def toggle_tubes(self) -> None:
        self.lines_mode = not self.lines_mode

    def toggle_animation(self) -> None:
        self.sim.update(animate=not self.sim.params.animate)

    def toggle_body(self) -> None:
        self.show_body = not self.show_body

    def toggle_shadows(self) -> None:
        self.shadows = not self.shadows

    def toggle_repeat_guard(self) -> None:
        self.sim.update(repeat_guard=not self.sim.params.repeat_guard)

    select_influence, select_growth, select_kill = View.select_influence, View.select_growth, View.select_kill
    scale_up, scale_down = View.scale_up, View.scale_down

    def export(self) -> None:
        path = Path("out") / "space_colonization_skinned.obj"
        self.sim.export_mesh(path)
        print(f"ugpcl-view: wrote {path}")

    # }}}


# }}}
