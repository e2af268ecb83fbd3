"""Marching cubes view (vol.1 ch.7, GPUMarchingCubesRenderStandardMesh.shader).

Two ways to draw the same surface: the OpenCL path's triangles (the Simulation's Pool, made by every step) drawn as
a plain mesh, the default, and the book's, where a geometry shader runs once per grid cell (an attribute-less draw
of N^3 points) and emits the cell's triangles. Tab switches between them; the status line shows the triangle count
of the path on screen (a GL primitives-generated query for the geometry shader, the pool's counter for the kernels).

The mesh is the default because the step has already made it: the geometry shader polygonises the field again,
twice a frame (lit and shadow pass), evaluating it 8 times per cell, in graphics shaders (an H100 or H200 runs those
on 2 of its TPCs; OpenCL has all of them). The mesh's upload moves only the frame's triangles, 72 bytes each
(Simulation.draw_vertices).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import moderngl
import numpy as np

from ugpcl.geometry.marching_cubes_tables import CUBE_EDGE_FLAGS, TRIANGLE_CONNECTION_TABLE
from ugpcl.scenes.marching_cubes import NORMALS, SHAPES, field_constants

from ..camera import OrbitCamera, look_at, orthographic
from ..gl import GrowableBuffer, load_program, set_camera, set_uniform
from . import Key
from . import View as BaseView

TEXTURE_UNITS = {"field": 0, "triangle_table": 1, "edge_flags": 2, "shadow_map": 3}
"""Texture unit of each sampler of marching_cubes.geom and marching_cubes.frag."""
MODEL = np.diag([-1.0, 1.0, -1.0, 1.0])
"""The object's transform in Sample.unity: rotation 180 degrees about Y (the kaiware's beak faces the camera)."""
SEGMENT_NUMS = (16, 32, 64, 128, 256)
"""Grid sizes of the + and - keys."""
THRESHOLD_STEP = 0.02
FLOOR_Y = -0.5
"""Unity Plane (10 x 10) under the object, light grey."""
FLOOR_COLOR = (0.8, 0.8, 0.8)
SHADOW_MAP_SIZE = 2048
"""Texels per side of the shadow map (covers LightCamera's 2.4 x 2.4 box: ~1/14 of a cell at N = 64)."""


@dataclass
class LightCamera:
    """Orthographic view along the sun (lighting.glsl's LIGHT_DIRECTION), covering the object and its shadow."""

    direction: tuple[float, float, float] = (-0.321, -0.766, 0.557)
    half_size: float = 1.2
    distance: float = 2.5

    def view(self) -> np.ndarray:
        d = np.asarray(self.direction) / np.linalg.norm(self.direction)
        return look_at(-d * self.distance, (0.0, 0.0, 0.0))

    def projection(self) -> np.ndarray:
        h = self.half_size
        return orthographic(-h, h, -h, h, 0.1, 2 * self.distance)


LIGHT = LightCamera()


class View(BaseView):
    title = "Marching cubes (vol.1 ch.7)"
    keys = (
        Key("]", f"threshold + {THRESHOLD_STEP}", "threshold_up"),
        Key("[", f"threshold - {THRESHOLD_STEP}", "threshold_down"),
        Key("+", "double N (cells per axis)", "more_cells"),
        Key("-", "halve N", "fewer_cells"),
        Key("a", "animation on/off (field time)", "toggle_animation"),
        Key("f", "wireframe on/off", "toggle_wireframe"),
        Key("tab", "draw path: geometry shader (book) / OpenCL kernel mesh", "toggle_path"),
        Key("g", "geometry shader field: analytic Sample (book) / 3D texture from SampleField", "toggle_field_source"),
        Key("m", "normals: analytic resampling / grid differences", "toggle_normals"),
        Key("p", "OpenCL path: atomic append / classify + scan + generate", "toggle_kernel_path"),
        Key("1", "shape: three spheres, book radii", "shape_book"),
        Key("2", "shape: three spheres, repository radii", "shape_repo"),
        Key("3", "shape: kaiware sprout", "shape_kaiware"),
        Key("b", "floor on/off", "toggle_floor"),
        Key("l", "shadows on/off (the book's shadow-caster pass)", "toggle_shadows"),
    )

    def __init__(self, ctx: moderngl.Context, sim):
        super().__init__(ctx, sim)
        # lit pass and shadow-caster pass of each path, as the book's two passes (geom_light / geom_shadow)
        self.programs = {
            ("gs", "lit"): load_program(ctx, "marching_cubes"),
            ("gs", "shadow"): load_program(ctx, "marching_cubes", fragment="marching_cubes_shadow"),
            ("mesh", "lit"): load_program(ctx, "marching_cubes_mesh", fragment="marching_cubes"),
            ("mesh", "shadow"): load_program(ctx, "marching_cubes_mesh", fragment="marching_cubes_shadow"),
        }
        # attribute-less point draws: the cell comes from gl_VertexID
        self.points = {kind: ctx.vertex_array(self.programs[("gs", kind)], []) for kind in ("lit", "shadow")}
        table = np.ascontiguousarray(TRIANGLE_CONNECTION_TABLE, np.int32)
        flags = np.ascontiguousarray(CUBE_EDGE_FLAGS, np.int32)
        self.textures = {
            "triangle_table": ctx.texture((16, 256), 1, table.tobytes(), dtype="i4"),
            "edge_flags": ctx.texture((256, 1), 1, flags.tobytes(), dtype="i4"),
            "shadow_map": ctx.depth_texture((SHADOW_MAP_SIZE, SHADOW_MAP_SIZE)),
        }
        for texture in self.textures.values():
            texture.filter = (moderngl.NEAREST, moderngl.NEAREST)  # integer textures are incomplete otherwise
        self.textures["shadow_map"].compare_func = "<="  # sampler2DShadow: 1 where the fragment is not behind
        self.textures["shadow_map"].repeat_x = self.textures["shadow_map"].repeat_y = False
        self.shadow_fbo = ctx.framebuffer(depth_attachment=self.textures["shadow_map"])
        self.field_texture = None
        self.mesh_vbo, self.mesh_vaos, self.mesh_vertices = GrowableBuffer(ctx, headroom=1.25, min_bytes=24), {}, 0
        floor = np.array(
            [[x, FLOOR_Y, z, 0.0, 1.0, 0.0] for x, z in ((-5, -5), (5, -5), (5, 5), (-5, -5), (5, 5), (-5, 5))], "f4"
        )
        self.floor_vbo = ctx.buffer(floor.tobytes())
        self.floor_vao = ctx.vertex_array(
            self.programs[("mesh", "lit")], [(self.floor_vbo, "3f 3f", "in_position", "in_normal")]
        )
        self.query = ctx.query(primitives=True)
        self.use_gs, self.field_source, self.wireframe, self.show_floor, self.shadows = False, 0, False, True, True
        self.gs_triangles = 0
        # Unity culls back faces (Cull Back); its left-handed world behind the viewer's z-mirror turns the outward
        # faces clockwise on screen. The tests flip these two to prove that the mesh's winding is outward.
        self.cull, self.front_face = True, "cw"
        self.frame_ms, self._last_draw = 0.0, None

    def make_camera(self):
        return OrbitCamera(target=(0.0, 0.0, 0.0), distance=1.0, near=0.3)  # book: camera at (0, 0, -1), FOV 60

    def png_camera(self):
        # a little farther and above the book's camera, so the floor and the object's shadow show
        return OrbitCamera(target=(0.0, -0.1, 0.0), distance=1.3, yaw=-25.0, pitch=18.0, near=0.1)

    # {{{ upload and draw

    def upload(self) -> None:
        n = self.sim.n
        if self.use_gs and (self.field_source == 1 or self.sim.params.normals == "grid"):
            data = self.sim.field_array()
            if self.field_texture is None or self.field_texture.size != (n + 1,) * 3:
                if self.field_texture is not None:
                    self.field_texture.release()
                self.field_texture = self.ctx.texture3d((n + 1,) * 3, 1, dtype="f4")
                self.field_texture.filter = (moderngl.NEAREST, moderngl.NEAREST)
            self.field_texture.write(data)  # float32, C-contiguous: written as it is, no host copy
        if not self.use_gs:
            vertices = self.sim.draw_vertices()  # (3 T, 6) float32: position, normal; the frame's triangles only
            if self.mesh_vbo.write(vertices):
                vbo = self.mesh_vbo.buffer
                self.mesh_vaos = {  # the shadow pass reads positions only (its program has no in_normal)
                    "lit": self.ctx.vertex_array(
                        self.programs[("mesh", "lit")], [(vbo, "3f 3f", "in_position", "in_normal")]
                    ),
                    "shadow": self.ctx.vertex_array(
                        self.programs[("mesh", "shadow")], [(vbo, "3f 12x", "in_position")]
                    ),
                }
            self.mesh_vertices = len(vertices)

    def _material(self, program, color=None) -> None:
        p = self.sim.params
        set_uniform(program, "diffuse_color", tuple(color or p.diffuse_color))
        set_uniform(program, "metallic", 0.0 if color else p.metallic)
        set_uniform(program, "glossiness", 0.1 if color else p.glossiness)
        emission = (0.0, 0.0, 0.0) if color else tuple(c * p.emission_intensity for c in p.emission_color)
        set_uniform(program, "emission", emission)
        set_uniform(program, "shadows", self.shadows)
        set_uniform(program, "m_light", LIGHT.projection() @ LIGHT.view())
        set_uniform(program, "shadow_map", TEXTURE_UNITS["shadow_map"])

    def draw(self, camera) -> None:
        now = time.perf_counter()
        if self._last_draw is not None:
            self.frame_ms = 1e3 * (now - self._last_draw)
        self._last_draw = now
        ctx = self.ctx
        for name, texture in self.textures.items():
            if name != "shadow_map":
                texture.use(TEXTURE_UNITS[name])
        if self.field_texture is not None:
            self.field_texture.use(TEXTURE_UNITS["field"])
        if self.shadows:
            self._shadow_pass()
        self.textures["shadow_map"].use(TEXTURE_UNITS["shadow_map"])
        ctx.enable(moderngl.DEPTH_TEST)
        if self.show_floor:
            program = self.programs[("mesh", "lit")]
            set_camera(program, camera)
            set_uniform(program, "m_model", np.identity(4))
            self._material(program, FLOOR_COLOR)
            self.floor_vao.render(moderngl.TRIANGLES)
        if self.cull:
            ctx.enable(moderngl.CULL_FACE)
        ctx.front_face = self.front_face
        ctx.wireframe = self.wireframe
        with self.query:
            self._draw_surface("lit", camera)
        self.gs_triangles = self.query.primitives if self.use_gs else 0
        ctx.wireframe = False
        ctx.front_face = "ccw"
        ctx.disable(moderngl.CULL_FACE)

    def _shadow_pass(self) -> None:
        """The book's shadow-caster pass: the same surface again, seen from the light, into the depth texture."""
        ctx, previous = self.ctx, self.ctx.fbo
        self.shadow_fbo.use()
        self.shadow_fbo.clear(depth=1.0)
        ctx.enable(moderngl.DEPTH_TEST)
        self._draw_surface("shadow", LIGHT)
        previous.use()

    def _draw_surface(self, kind: str, camera) -> None:
        """One pass (``lit`` or ``shadow``) of the surface, by the geometry shader or from the kernels' mesh."""
        p = self.sim.params
        program = self.programs[("gs" if self.use_gs else "mesh", kind)]
        set_camera(program, camera)
        set_uniform(program, "m_model", MODEL)
        if kind == "lit":
            self._material(program)
        if not self.use_gs:
            if self.mesh_vertices:
                self.mesh_vaos[kind].render(moderngl.TRIANGLES, vertices=self.mesh_vertices)
            return
        radii, twist = field_constants(p.shape, self.sim.field_time)
        for name, value in (
            ("segment_num", self.sim.n),
            ("threshold", p.threshold),
            ("field_source", self.field_source),
            ("normals", NORMALS[p.normals]),
            ("shape", SHAPES[p.shape]),
            ("radius", radii),
            ("twist", twist),
            *((name, unit) for name, unit in TEXTURE_UNITS.items() if name != "shadow_map"),
        ):
            set_uniform(program, name, value)
        self.points[kind].render(moderngl.POINTS, vertices=self.sim.cells)

    def status(self) -> list[str]:
        p = self.sim.params
        if self.use_gs:
            source = "analytic" if self.field_source == 0 else "texture"
            drawn = f"geometry shader ({source} field): {self.gs_triangles} triangles"
        else:
            drawn = f"OpenCL {p.path}: {self.sim.frame_counts[-1]} triangles"  # recorded by polygonize: no read
        return [
            f"N = {self.sim.n}  t = {self.sim.field_time:.2f} s{'' if p.animate else ' (still)'}  "
            f"threshold = {p.threshold:.2f}  {p.shape}  normals: {p.normals}",
            f"{drawn}  {self.frame_ms:.1f} ms/frame",
        ]

    # }}}

    # {{{ key actions

    def _update(self, **changes) -> None:
        self.sim.update(**changes)
        self.sim.remesh()  # show the change at once, also while paused

    def threshold_up(self) -> None:
        self._update(threshold=min(1.0, round(self.sim.params.threshold + THRESHOLD_STEP, 4)))

    def threshold_down(self) -> None:
        self._update(threshold=max(0.0, round(self.sim.params.threshold - THRESHOLD_STEP, 4)))

    def more_cells(self) -> None:
        larger = [n for n in SEGMENT_NUMS if n > self.sim.n]
        if larger:
            self.sim.update(segment_num=larger[0], time=self.sim.field_time)

    def fewer_cells(self) -> None:
        smaller = [n for n in SEGMENT_NUMS if n < self.sim.n]
        if smaller:
            self.sim.update(segment_num=smaller[-1], time=self.sim.field_time)

    def toggle_animation(self) -> None:
        self.sim.update(animate=not self.sim.params.animate)

    def toggle_wireframe(self) -> None:
        self.wireframe = not self.wireframe

    def toggle_path(self) -> None:
        self.use_gs = not self.use_gs

    def toggle_field_source(self) -> None:
        self.field_source = 1 - self.field_source

    def toggle_normals(self) -> None:
        self._update(normals="grid" if self.sim.params.normals == "analytic" else "analytic")

    def toggle_kernel_path(self) -> None:
        self._update(path="scan" if self.sim.params.path == "append" else "append")

    def shape_book(self) -> None:
        self._update(shape="spheres-book")

    def shape_repo(self) -> None:
        self._update(shape="spheres-repo")

    def shape_kaiware(self) -> None:
        self._update(shape="kaiware")

    def toggle_floor(self) -> None:
        self.show_floor = not self.show_floor

    def toggle_shadows(self) -> None:
        self.shadows = not self.shadows

    # }}}
