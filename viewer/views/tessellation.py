"""Tessellation + displacement view (vol.4 ch.6, FuidTessellation): Unity's Plane drawn as 3-vertex PATCHES through
the tessellation shaders, displaced by the fluid's density; drag on the plane to paint the fluid."""

from __future__ import annotations

import moderngl
import numpy as np

from ugpcl.geometry.tessellation import (
    CAMERA_POSITION,
    LIGHT_INTENSITY,
    PLANE_QUADS,
    light_direction,
    plane_mesh,
    plane_model,
)

from ..camera import FlatCamera, OrbitCamera, look_at, orthographic
from ..gl import load_program, set_camera, set_uniform
from . import Key
from . import View as BaseView
from .stable_fluids_2d import FluidKeyActions

TEXTURE_UNITS = {"displacement_map": 0, "normal_map": 1, "shadow_map": 2, "solver": 3}
"""Texture units by sampler name (the density inset uses the 2D fluid view's shader and its `solver`)."""
DISPLACEMENT_STEP = 0.05
"""+ and - change displacement by this much (the book's sample has no keys for it)."""
INSET_FRACTION = 0.3
"""The density inset's side as a fraction of the window height."""
LIGHTING = ("auto", "height", "mesh")
SHADOW_MAP_SIZE = 1024
"""Texels per side of the light's depth map (it spans the plane: about 1.5 cm of the 10 m plane per texel)."""
SHADOW_BIAS = 0.05
"""Depth offset against self-shadowing, world units along the light."""
PLANE_ATTRIBUTES = (("in_position", "3f"), ("in_normal", "3f"), ("in_tangent", "4f"), ("in_uv", "2f"))
"""The plane's vertex layout (plane_mesh: 12 floats per vertex)."""
PATCHES_PER_DRAW = 10
"""Patches per draw call. Mesa's llvmpipe silently drops the end of a tessellated draw past roughly 10^5 triangles
(200 patches at level 40 lost the far half of the plane; 20 patches at level 64 = 119 060 triangles were whole);
10 patches make at most 59 530 triangles per call. The primitive query spans all the calls."""


class View(FluidKeyActions, BaseView):
    title = "Tessellation + displacement (vol.4 ch.6)"
    background = (1.0, 1.0, 1.0)  # the scene camera clears to solid white
    keys = (
        Key("w", "wireframe on/off (shows the tessellation)", "toggle_wireframe"),
        Key("+", "displacement + 0.05", "more_displacement"),
        Key("-", "displacement - 0.05", "less_displacement"),
        Key("]", "edge_length + 1 (coarser tessellation)", "longer_edges"),
        Key("[", "edge_length - 1 (finer tessellation)", "shorter_edges"),
        Key("v", "variant: fixed / book (vol.4's solver, Point sampling, Unity's normals)", "toggle_variant"),
        Key("l", "lighting: auto / height-field normals / the plane's normals (Unity)", "next_lighting"),
        Key("i", "negative displacement on/off (Tessellation.shader subtracts)", "toggle_negative"),
        Key("o", "density_only on/off (advect the ink by the brush only)", "toggle_density_only"),
        Key("up", "viscosity visc x 2", "more_viscous"),
        Key("down", "viscosity visc / 2", "less_viscous"),
        Key("right", "diffusion diff x 2", "more_diffusion"),
        Key("left", "diffusion diff / 2", "less_diffusion"),
        Key("c", "scripted stroke: circle / line / figure8 / none", "next_stroke"),
        Key("d", "density texture inset on/off", "toggle_density"),
        Key("p", "colour by tessellation level on/off", "toggle_levels"),
        Key("f", "freeze the tessellation factors at the current camera (debug)", "toggle_freeze"),
        Key("k", "the light's shadows on/off", "toggle_shadows"),
    )

    def __init__(self, ctx: moderngl.Context, sim):
        super().__init__(ctx, sim)
        self.program = load_program(ctx, "tessellation")
        vertices, triangles = plane_mesh()
        self.vbo = ctx.buffer(vertices.tobytes())
        self.ibo = ctx.buffer(triangles.astype("u4").tobytes())
        self.vao = self.plane_vao(self.program)
        self.patches = len(triangles)
        # the shadow caster pass: the same tessellation, depth only, from the light
        self.shadow_program = load_program(ctx, "tessellation", fragment="tessellation_shadow")
        self.shadow_vao = self.plane_vao(self.shadow_program)
        self.shadow_map = ctx.depth_texture((SHADOW_MAP_SIZE, SHADOW_MAP_SIZE))
        self.shadow_map.compare_func = ""  # sampled as plain depth; tessellation.frag compares
        self.shadow_map.repeat_x = self.shadow_map.repeat_y = False
        self.shadow_fbo = ctx.framebuffer(depth_attachment=self.shadow_map)
        self.inset_program = load_program(ctx, "stable_fluids_2d")
        self.inset_vbo = ctx.buffer(np.array([[0, 0, 0, 0], [1, 0, 1, 0], [0, 1, 0, 1], [1, 1, 1, 1]], "f4").tobytes())
        self.inset_vao = ctx.vertex_array(self.inset_program, [(self.inset_vbo, "2f 2f", "in_position", "in_uv")])
        self.texture = self.solver_texture = None
        # _NormalMap: normal.tga is not in the repository; Unity's "bump" default is this flat normal (0, 0, 1)
        self.normal_map = ctx.texture((1, 1), 4, bytes([128, 128, 255, 255]))
        self.query = ctx.query(primitives=True)
        self.primitives = 0
        self.wireframe = self.show_density = self.show_levels = False
        self.frozen: tuple[np.ndarray, np.ndarray] | None = None  # (view_proj, eye) the factors stay computed for
        self.current: tuple[np.ndarray, np.ndarray] | None = None  # the same of the last frame drawn
        self.forced_level = -1.0  # tests: >= 0 forces every tessellation level
        self.last_hit: np.ndarray | None = None  # plane uv under the mouse at the previous drag event
        self.move = np.zeros(2)
        model = plane_model()
        self.model = model
        self.plane_du = model[:3, :3] @ np.array([-float(PLANE_QUADS), 0.0, 0.0])  # u runs along -x over 10 units
        self.plane_dv = model[:3, :3] @ np.array([0.0, 0.0, -float(PLANE_QUADS)])  # v along -z

    def plane_vao(self, program: moderngl.Program) -> moderngl.VertexArray:
        """The plane's vertices as ``program`` takes them (attributes a stage does not use are skipped bytes)."""
        parts = [(name, kind if name in program else f"{kind[0]}x4") for name, kind in PLANE_ATTRIBUTES]
        used = [name for name, _ in PLANE_ATTRIBUTES if name in program]
        return self.ctx.vertex_array(program, [(self.vbo, " ".join(k for _, k in parts), *used)], index_buffer=self.ibo)

    def make_camera(self):
        # the sample's camera: (0, 0, -10) looking along +z, FOV 60 (fixed in the original; the wheel zooms here)
        return OrbitCamera(target=(0.0, 0.0, 0.0), distance=-CAMERA_POSITION[2])

    # {{{ frame

    def upload(self) -> None:
        density = self.sim.density()
        h, w = density.shape
        if self.texture is None or self.texture.size != (w, h):
            for texture in (self.texture, self.solver_texture):
                if texture is not None:
                    texture.release()
            self.texture = self.ctx.texture((w, h), 1, dtype="f4")  # R32F
            self.solver_texture = self.ctx.texture((w, h), 4, dtype="f4")
            self.texture.repeat_x = self.texture.repeat_y = False  # CLAMP, as the original's
            self.solver_texture.filter = (moderngl.LINEAR, moderngl.LINEAR)
        linear = self.sim.params.linear_filter
        self.texture.filter = (moderngl.LINEAR, moderngl.LINEAR) if linear else (moderngl.NEAREST, moderngl.NEAREST)
        self.texture.write(density.tobytes())  # row 0 = v near 0, as GL expects
        if self.show_density:
            self.solver_texture.write(self.sim.fluid.solver_field().tobytes())
        if self.last_hit is not None and self.sim.fluid.pending_brush is None:
            self.sim.brush(*self.last_hit)  # button held still: the brush keeps painting

    def draw(self, camera) -> None:
        p = self.sim.params
        ctx = self.ctx
        ctx.enable(moderngl.DEPTH_TEST)
        ctx.disable(moderngl.CULL_FACE)  # the plane is seen from its front; both faces keep the winding moot
        ctx.patch_vertices = 3
        program = self.program
        set_camera(program, camera)
        self.current = (camera.projection() @ camera.view(), camera.eye())
        view_proj, eye = self.frozen or self.current
        viewport_height = ctx.viewport[3]
        uniforms = {
            "m_model": self.model,
            "tess_view_proj": view_proj,
            "tess_eye": tuple(float(v) for v in eye),
            "screen_height": float(viewport_height),
            "edge_length": p.edge_length,
            "displacement": p.displacement,
            "forced_level": self.forced_level,
            "negative": p.negative,
            "light_direction": tuple(float(v) for v in light_direction()),
            "light_color": (LIGHT_INTENSITY,) * 3,
            "albedo": p.color,
            "spec_color": p.spec_color,
            "specular": p.specular,
            "gloss": p.gloss,
            "height_normals": p.height_normals,
            "plane_du": tuple(float(v) for v in self.plane_du),
            "plane_dv": tuple(float(v) for v in self.plane_dv),
            "show_levels": self.show_levels,
            "displacement_map": TEXTURE_UNITS["displacement_map"],
            "normal_map": TEXTURE_UNITS["normal_map"],
        }
        self.texture.use(TEXTURE_UNITS["displacement_map"])
        self.normal_map.use(TEXTURE_UNITS["normal_map"])
        light_view_proj, depth_range = self.light_camera()
        if p.shadows:
            self._draw_shadow_map(uniforms, light_view_proj)
        uniforms.update(
            {
                "shadows": p.shadows,
                "shadow_map": TEXTURE_UNITS["shadow_map"],
                "light_view_proj": light_view_proj,
                "shadow_bias": SHADOW_BIAS / depth_range,
            }
        )
        for name, value in uniforms.items():
            set_uniform(program, name, value)
        self.shadow_map.use(TEXTURE_UNITS["shadow_map"])
        ctx.wireframe = self.wireframe
        with self.query:
            self._render_patches(program, self.vao)
        ctx.wireframe = False
        self.primitives = self.query.primitives
        if self.show_density:
            self._draw_inset()

    def _render_patches(self, program, vao) -> None:
        for first in range(0, self.patches, PATCHES_PER_DRAW):
            count = min(PATCHES_PER_DRAW, self.patches - first)
            set_uniform(program, "first_patch", first)  # only the capture build (tests) has it
            vao.render(moderngl.PATCHES, vertices=3 * count, first=3 * first)

    def light_camera(self) -> tuple[np.ndarray, float]:
        """World -> clip matrix of an orthographic camera looking along the light over the whole plane (with room
        for the displacement), and the depth its [0, 1] range spans in world units."""
        p = self.sim.params
        direction = light_direction()
        center = self.model[:3, 3]
        view = look_at(center - 50.0 * direction, center, up=(0.0, 0.0, 1.0))
        corners = np.array([[x, y, z, 1.0] for x in (-5, 5) for y in (-1, 1) for z in (-5, 5)])
        corners[:, 1] *= p.displacement * 2.0 + 0.1  # the density rarely passes 2
        eye_space = (view @ self.model @ corners.T).T[:, :3]
        low, high = eye_space.min(axis=0) - 0.5, eye_space.max(axis=0) + 0.5
        near, far = -high[2], -low[2]
        return orthographic(low[0], high[0], low[1], high[1], near, far) @ view, far - near

    def _draw_shadow_map(self, uniforms: dict, light_view_proj: np.ndarray) -> None:
        """The shadow caster pass: depth of the plane, tessellated for the drawing camera, seen from the light."""
        ctx = self.ctx
        saved_fbo, saved_viewport = ctx.fbo, ctx.viewport
        self.shadow_fbo.use()
        ctx.viewport = (0, 0, SHADOW_MAP_SIZE, SHADOW_MAP_SIZE)
        self.shadow_fbo.clear(depth=1.0)
        program = self.shadow_program
        for name, value in uniforms.items():
            set_uniform(program, name, value)
        set_uniform(program, "m_proj", light_view_proj)
        set_uniform(program, "m_view", np.identity(4))
        self._render_patches(program, self.shadow_vao)
        saved_fbo.use()
        ctx.viewport = saved_viewport

    def _draw_inset(self) -> None:
        """The fluid as the 2D chapter shows it (ink on white), in the bottom-left corner."""
        ctx = self.ctx
        saved = ctx.viewport
        side = int(saved[3] * INSET_FRACTION)
        ctx.viewport = (saved[0] + 8, saved[1] + 8, side, side)
        ctx.disable(moderngl.DEPTH_TEST)
        program = self.inset_program
        set_camera(program, FlatCamera(rect=(0.0, 1.0, 0.0, 1.0)))
        for name, value in (("display_mode", 0), ("ink_effect", True), ("ink_gain", 5.0)):
            set_uniform(program, name, value)
        set_uniform(program, "solver", TEXTURE_UNITS["solver"])
        self.solver_texture.use(TEXTURE_UNITS["solver"])
        self.inset_vao.render(moderngl.TRIANGLE_STRIP)
        ctx.viewport = saved
        ctx.enable(moderngl.DEPTH_TEST)

    def status(self) -> list[str]:
        p = self.sim.params
        lighting = "height" if p.height_normals else "mesh"
        frozen = "  factors FROZEN" if self.frozen else ""
        return [
            f"triangles {self.primitives} from {self.patches} patches  edge_length {p.edge_length:g} px  "
            f"displacement {'-' if p.negative else ''}{p.displacement:.2f}{frozen}",
            f"variant {p.variant} (fluid {self.sim.fluid.params.solver})  lighting {lighting}  grid {p.grid}  "
            f"visc {p.visc:g}  diff {p.diff:g}  stroke {p.stroke}",
        ]

    # }}}

    # {{{ mouse: drag on the plane paints the fluid at the plane's uv under the cursor

    def plane_uv(self, camera, u: float, v: float) -> np.ndarray | None:
        """Texture uv of the undisplaced plane under window point (u, v), or None off the plane."""
        inverse = np.linalg.inv(camera.projection() @ camera.view())
        ends = [inverse @ np.array([2 * u - 1, 2 * v - 1, z, 1.0]) for z in (-1.0, 1.0)]
        near, far = (e[:3] / e[3] for e in ends)
        normal = self.model[:3, :3] @ np.array([0.0, 1.0, 0.0])
        direction = far - near
        denominator = normal @ direction
        if abs(denominator) < 1e-12:
            return None
        t = normal @ (self.model[:3, 3] - near) / denominator
        if t < 0:
            return None
        local = self.model[:3, :3].T @ (near + t * direction - self.model[:3, 3])
        uv = np.array([(5.0 - local[0]) / 10.0, (5.0 - local[2]) / 10.0])
        return uv if np.all((uv >= 0) & (uv <= 1)) else None

    def on_drag(self, camera, u: float, v: float, du: float, dv: float) -> None:
        here = self.plane_uv(camera, u, v)
        if here is None:
            self.last_hit = None
            return
        if self.sim.fluid.pending_brush is None:  # the last brush went into a step: a new frame's move starts
            self.move[:] = 0.0
        if self.last_hit is not None:
            self.move += here - self.last_hit
        self.last_hit = here
        self.sim.brush(float(here[0]), float(here[1]), *self.move)

    def on_release(self, camera) -> None:
        self.last_hit = None

    # }}}

    # {{{ key actions

    def toggle_wireframe(self) -> None:
        self.wireframe = not self.wireframe

    def more_displacement(self) -> None:
        self.sim.update(displacement=min(30.0, self.sim.params.displacement + DISPLACEMENT_STEP))

    def less_displacement(self) -> None:
        self.sim.update(displacement=max(0.0, self.sim.params.displacement - DISPLACEMENT_STEP))

    def longer_edges(self) -> None:
        self.sim.update(edge_length=min(50.0, self.sim.params.edge_length + 1.0))

    def shorter_edges(self) -> None:
        self.sim.update(edge_length=max(2.0, self.sim.params.edge_length - 1.0))

    def toggle_variant(self) -> None:
        self.sim.update(variant="book" if self.sim.params.variant == "fixed" else "fixed")

    def next_lighting(self) -> None:
        self.sim.update(lighting=LIGHTING[(LIGHTING.index(self.sim.params.lighting) + 1) % len(LIGHTING)])

    def toggle_negative(self) -> None:
        self.sim.update(negative=not self.sim.params.negative)

    def toggle_density(self) -> None:
        self.show_density = not self.show_density

    def toggle_levels(self) -> None:
        self.show_levels = not self.show_levels

    def toggle_shadows(self) -> None:
        self.sim.update(shadows=not self.sim.params.shadows)

    def toggle_freeze(self) -> None:
        self.frozen = None if self.frozen else self.current

    # }}}
