"""The skinned figure (vol.4 ch.1 section 1.4, the SkinnedAnimation scene): lit capsules on the skinned node
positions, glowing where they grow, over a floor that takes their shadow; ``b`` shows the figure's mesh, skinned in
the vertex shader with the same matrices. Edges are drawn by the sphere view's ``EdgeRenderer`` with the skinned
vertex and fragment stages (space_colonization_skinned.vert/.frag) on the 48-byte SkinnedNode."""

from __future__ import annotations

from pathlib import Path

import moderngl
import numpy as np

from ..camera import OrbitCamera, look_at, orthographic
from ..gl import load_program, set_camera, set_uniform
from . import Key
from . import View as BaseView
from .space_colonization import EdgeRenderer, TunableDistances

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


class View(TunableDistances, BaseView):
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

    def make_camera(self):
        # the book: FOV 23, pitched 10.23 degrees down, the whole character in view
        return OrbitCamera(target=(0.0, 0.95, 0.0), distance=6.0, pitch=10.23, fov=23.0)

    def upload(self) -> None:
        self.edges.set(*self.sim.live_records())  # the live node prefix and edges, page-locked, straight to GL

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
            f"A = {sim.attraction_count}  nodes {sim.live_nodes} live / {sim.free_slots} free slots  "
            f"edges {sim.live_edges}  steps {sim.steps}",
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

    def export(self) -> None:
        path = Path("out") / "space_colonization_skinned.obj"
        self.sim.export_mesh(path)
        print(f"ugpcl-view: wrote {path}")

    # }}}
