"""Cloth views (vol.4 ch.3): the lit two-sided cloth surface with the red collider (GPUClothRenderer +
ClothSurface.shader), and the debug render (GPUClothDebugRenderer + DebugRenderShader.shader): mass points as
sprites and the structural, shear and bend springs as additive lines on black. D switches between the two.

Positions and normals go from the OpenCL buffers into one RGBA32UI texture each frame, packed on the device into
16 bytes a particle (Simulation.pack_surface: the position's float bits, the normal in 10 bits a component; half of the
float buffers' 32); the surface's and the points' vertex shaders fetch them by vertex id (texelFetch), as the book's
shaders sample its RenderTextures. The G key's thumbnails show the float buffers themselves. Unity's left-handed
coordinates are kept: OrbitCamera mirrors z, so winding is mirrored too, which is why the cloth is drawn without
culling and lit on whichever side faces the eye.
"""

from __future__ import annotations

import moderngl
import numpy as np

from ugpcl.geometry.cloth import grid_triangles, spring_pairs
from ugpcl.scenes.cloth import DEBUG_SCENE, MAIN_SCENE

from ..camera import OrbitCamera
from ..gl import Lines, load_program, set_camera, set_uniform
from ..meshes import uv_sphere
from . import Key
from . import View as BaseView

CLOTH_COLOR = (0.0, 0.2727, 1.0)
"""Albedo of the cloth material (sample scene)."""
SPHERE_COLOR = (1.0, 0.0, 0.038)
"""Albedo of the collider's material (sample scene)."""
SMOOTHNESS = 0.5
"""Both materials: Standard, metallic 0, smoothness 0.5."""
DEBUG_COLORS = {
    "points": (0.0, 1.0, 1.0, 0.5),
    "structural": (0.0, 0.204, 1.0, 0.5),
    "shear": (0.0, 1.0, 0.0, 0.5),
    "bend": (1.0, 0.0, 0.0, 0.5),
}
"""Colours of the debug render (book: GPUClothDebugRenderer's inspector values), blended additively."""
PARTICLE_SIZE = 0.005
"""Half-size of a mass-point sprite, world units (book: _ParticleSize)."""
STIFFNESS_FACTOR = 1.25
"""The + and - keys multiply or divide the stiffness by this."""
TIMESTEP_STEP = 0.005
"""The t and y keys add or remove this much of TimeStep, seconds."""
BUFFERS = ("pos", "pos_write", "prev", "prev_write", "normal")
"""The thumbnails of the G key, left to right (book: _posBuff[0], [1], _posPrevBuff[0], [1], _normBuff)."""


class View(BaseView):
    title = "GPU cloth (vol.4 ch.3)"
    keys = (
        Key("c", "sphere collision on/off", "toggle_sphere"),
        Key("m", "sphere motion on/off", "toggle_motion"),
        Key("]", "substeps + 1 (VerletIterationNum, 1-16)", "more_substeps"),
        Key("[", "substeps - 1", "fewer_substeps"),
        Key("+", f"stiffness x {STIFFNESS_FACTOR}", "stiffer"),
        Key("-", f"stiffness / {STIFFNESS_FACTOR}", "softer"),
        Key("t", f"timestep + {TIMESTEP_STEP}", "longer_timestep"),
        Key("y", f"timestep - {TIMESTEP_STEP}", "shorter_timestep"),
        Key("d", "debug render (mass points + springs) / surface", "toggle_debug"),
        Key("w", "wireframe surface on/off", "toggle_wireframe"),
        Key("g", "buffer thumbnails bottom-left on/off (pos 0/1, prev 0/1, normal)", "toggle_buffers"),
        Key("1", "main scene parameters (resets)", "main_preset"),
        Key("2", "debug scene parameters (resets)", "debug_preset"),
    )
    start_debug = False

    def __init__(self, ctx: moderngl.Context, sim):
        super().__init__(ctx, sim)
        self.surface = load_program(ctx, "cloth")
        self.sphere_program = load_program(ctx, "cloth", vertex="cloth_sphere")
        self.points = load_program(ctx, "cloth_points")
        self.thumbnail = load_program(ctx, "cloth_buffer", vertex="overlay")  # overlay.vert: a quad placed by rect
        vertices, indices = uv_sphere()
        self.sphere_vbo = ctx.buffer(vertices.tobytes())
        self.sphere_ibo = ctx.buffer(indices.tobytes())
        self.sphere_vao = ctx.vertex_array(
            self.sphere_program, [(self.sphere_vbo, "3f 3f", "in_position", "in_normal")], index_buffer=self.sphere_ibo
        )
        corners = np.array([0, 0, 1, 0, 0, 1, 1, 1], "f4")
        self.quad = ctx.buffer(corners.tobytes())
        self.thumbnail_vao = ctx.vertex_array(self.thumbnail, [(self.quad, "2f", "in_corner")])
        self.points_vao = ctx.vertex_array(self.points, [])
        self.springs = {family: Lines(ctx, color=DEBUG_COLORS[family]) for family in ("structural", "shear", "bend")}
        self.textures: dict[str, moderngl.Texture] = {}  # the G key's thumbnails: the float buffers
        self.surface_texture = None  # pack_surface's words
        self.size = None  # (W, H) the GL objects were made for
        self.finite = True
        self.debug, self.wireframe, self.show_buffers = self.start_debug, False, False
        self._set_background()

    # {{{ GL objects

    def _resize(self, width: int, height: int) -> None:
        """Textures, the cloth's index buffer and the spring pairs for a W x H cloth."""
        for texture in self.textures.values():
            texture.release()
        self.textures = {}
        for name in BUFFERS:
            texture = self.ctx.texture((width, height), 4, dtype="f4")
            texture.filter = (moderngl.NEAREST, moderngl.NEAREST)  # book: FilterMode.Point
            texture.repeat_x = texture.repeat_y = False  # book: TextureWrapMode.Clamp
            self.textures[name] = texture
        if self.size is not None:
            self.surface_texture.release()
            self.cloth_ibo.release()
            self.cloth_vao.release()
        self.surface_texture = self.ctx.texture((width, height), 4, dtype="u4")  # RGBA32UI: fetched, never filtered
        self.surface_texture.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self.triangles = grid_triangles(width, height)
        self.cloth_ibo = self.ctx.buffer(self.triangles.tobytes())
        self.cloth_vao = self.ctx.vertex_array(self.surface, [], index_buffer=self.cloth_ibo, index_element_size=4)
        self.pairs = spring_pairs(width, height)
        self.size = (width, height)

    def upload(self) -> None:
        sim = self.sim
        if self.size != (sim.width, sim.height):
            self._resize(sim.width, sim.height)
        surface = sim.runtime.read_back(sim.pack_surface())  # page-locked, straight to GL
        self.surface_texture.write(surface)
        # all four words as floats, contiguous (a strided xyz view checks 6x slower): the packed normal never sets
        # bit 30, so it reads as a finite float, and only the positions can be NaN or inf
        self.finite = bool(np.isfinite(surface.view(np.float32)).all())
        pos = surface[..., :3].view(np.float32)  # the positions' bits, exact
        if self.show_buffers:
            for name in BUFFERS:
                self.textures[name].write(sim.runtime.read_back(sim.buffer(name)))
        if self.debug:
            pos = pos.reshape(-1, 3)
            for family, lines in self.springs.items():
                lines.set(pos[self.pairs[family]])

    # }}}

    def make_camera(self):
        return OrbitCamera(target=(0.0, 0.0, 0.0), distance=10.0)  # book: camera at (0, 0, -10), FOV 60

    def png_camera(self):
        # from the side, where the sphere under the drape shows (from the front the sheet hides it)
        return OrbitCamera(target=(0.35, 0.0, -0.8), distance=5.6, yaw=-65.0, pitch=6.0)

    def draw(self, camera) -> None:
        self.ctx.enable(moderngl.DEPTH_TEST)
        self.ctx.disable(moderngl.CULL_FACE)  # book: Cull Off
        if self.debug:
            self._draw_debug(camera)
        else:
            self._draw_surface(camera)
        if self.show_buffers:
            self._draw_buffers(camera.aspect)

    def _draw_surface(self, camera) -> None:
        set_camera(self.surface, camera)
        self.surface["albedo"].value = CLOTH_COLOR
        self.surface["smoothness"].value = SMOOTHNESS
        self.surface["surface"].value = 0
        self.surface_texture.use(0)
        self.ctx.wireframe = self.wireframe
        self.cloth_vao.render(moderngl.TRIANGLES)
        self.ctx.wireframe = False
        if self.sim.params.sphere:
            set_camera(self.sphere_program, camera)
            sphere = self.sim.sphere_params
            self.sphere_program["center"].value = tuple(float(v) for v in sphere[:3])
            self.sphere_program["radius"].value = self.sim.params.sphere_scale * 0.5  # drawn 0.01 smaller (book)
            self.sphere_program["albedo"].value = SPHERE_COLOR
            self.sphere_program["smoothness"].value = SMOOTHNESS
            self.sphere_vao.render(moderngl.TRIANGLES)

    def _draw_debug(self, camera) -> None:
        self.ctx.disable(moderngl.DEPTH_TEST)  # additive: order does not matter
        self.ctx.enable(moderngl.BLEND)
        self.ctx.blend_func = moderngl.SRC_ALPHA, moderngl.ONE  # book: Blend SrcAlpha One
        for lines in self.springs.values():
            lines.draw(camera)
        set_camera(self.points, camera)
        set_uniform(self.points, "particle_size", PARTICLE_SIZE)
        set_uniform(self.points, "color", DEBUG_COLORS["points"])
        self.points["surface"].value = 0
        self.surface_texture.use(0)
        self.points_vao.render(moderngl.POINTS, vertices=self.sim.width * self.sim.height)
        self.ctx.disable(moderngl.BLEND)
        self.ctx.enable(moderngl.DEPTH_TEST)

    def _draw_buffers(self, aspect: float) -> None:
        """Thumbnails in a row, up to a fifth of the window height each (book: DrawSimulationBufferOnGUI, top-left;
        bottom-left here, where they do not hide the status and help text)."""
        self.ctx.disable(moderngl.DEPTH_TEST)
        texel_aspect = self.size[0] / self.size[1] / aspect  # NDC width per NDC height of one thumbnail
        height = min(0.2 * 2.0, (2.0 - 0.01 * (len(BUFFERS) + 1)) / len(BUFFERS) / texel_aspect)
        width = height * texel_aspect
        self.thumbnail["buffer_texture"].value = 0
        for i, name in enumerate(BUFFERS):
            x = -1.0 + 0.01 + i * (width + 0.01)
            self.thumbnail["rect"].value = (x, -1.0 + 0.02, width, height)
            self.textures[name].use(0)
            self.thumbnail_vao.render(moderngl.TRIANGLE_STRIP)
        self.ctx.enable(moderngl.DEPTH_TEST)

    def status(self) -> list[str]:
        p, sim = self.sim.params, self.sim
        sphere = f"sphere z = {sim.sphere_params[2]:+.2f}" + ("" if p.sphere_motion else " (still)")
        return [
            f"{sim.width} x {sim.height} particles  substeps {p.substeps} (dt {p.substep_dt * 1e3:.2f} ms)  "
            f"timestep {p.timestep:g}  k = {p.stiffness:g}",
            (sphere if p.sphere else "sphere off") + ("  [debug]" if self.debug else ""),
        ] + ([] if self.finite else [f"DIVERGED (dt*sqrt(12k/m) = {p.stability:.2f}): R resets"])

    # {{{ key actions

    def _set_background(self) -> None:
        self.background = (0.0, 0.0, 0.0) if self.debug else BaseView.background  # debug scene: black

    def toggle_sphere(self) -> None:
        self.sim.update(sphere=not self.sim.params.sphere)

    def toggle_motion(self) -> None:
        self.sim.update(sphere_motion=not self.sim.params.sphere_motion)

    def more_substeps(self) -> None:
        self.sim.update(substeps=min(16, self.sim.params.substeps + 1))

    def fewer_substeps(self) -> None:
        self.sim.update(substeps=max(1, self.sim.params.substeps - 1))

    def stiffer(self) -> None:
        self.sim.update(stiffness=self.sim.params.stiffness * STIFFNESS_FACTOR)

    def softer(self) -> None:
        self.sim.update(stiffness=self.sim.params.stiffness / STIFFNESS_FACTOR)

    def longer_timestep(self) -> None:
        self.sim.update(timestep=min(0.1, round(self.sim.params.timestep + TIMESTEP_STEP, 6)))

    def shorter_timestep(self) -> None:
        self.sim.update(timestep=max(TIMESTEP_STEP, round(self.sim.params.timestep - TIMESTEP_STEP, 6)))

    def toggle_debug(self) -> None:
        self.debug = not self.debug
        self._set_background()

    def toggle_wireframe(self) -> None:
        self.wireframe = not self.wireframe

    def toggle_buffers(self) -> None:
        self.show_buffers = not self.show_buffers

    def main_preset(self) -> None:
        self.sim.update(**MAIN_SCENE)
        self.sim.reset()

    def debug_preset(self) -> None:
        self.sim.update(**DEBUG_SCENE)
        self.sim.reset()

    # }}}


class DebugView(View):
    """The sample's Debug/GPUClothSimulationDebugRender scene: starts in the debug render."""

    title = "GPU cloth, debug render (vol.4 ch.3)"
    start_debug = True
