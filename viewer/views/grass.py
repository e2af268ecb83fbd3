"""Geometry-shader views (vol.1 ch.6): the grass field and the pyramid quad, drawn through their GLSL geometry
shaders (viewer/shaders/grass.*, grass_pyramid.* with grass.frag). Tab switches to drawing what the OpenCL kernels
emitted instead (GrassExpand / PyramidExpand, copied through the host), which should look the same."""

from __future__ import annotations

import moderngl
import numpy as np

from ugpcl.geometry.grass import BLADE_VERTICES, strip_triangles
from ugpcl.scenes.grass import PARAM_FIELDS

from ..camera import OrbitCamera, OrthoCamera
from ..gl import GrowableBuffer, load_program, set_camera, set_uniform
from . import Key
from . import View as BaseView

TEXTURE_UNITS = {"height_map": 0, "rotation_map": 1, "wind_map": 2}
"""Sampler uniform -> texture unit (book: _HeightMap, _RotationMap, _WindMap)."""
MAP_OF_SAMPLER = {"height_map": "height", "rotation_map": "rot", "wind_map": "wind"}
GS_VARYINGS = ("g_world", "g_color")
"""Geometry-shader outputs that transform feedback can capture (the tests compare them with the kernels)."""
PATHS = ("geometry shader", "OpenCL")
FAST_WIND_TIME_SCALE = 1.0
"""The `,` key's alternative to the faithful 1/20: the sway then has a 6.3 s period instead of 126 s."""
PLAIN_QUAD_COLOR = (0.5, 0.5, 0.5, 1.0)
"""Fig. 6.2's quad before the geometry shader: flat grey."""


def book_grass_camera() -> OrbitCamera:
    """Grass.unity's camera: at (0, 30, -85) pitched 12 degrees down, FOV 60, near 0.3, far 1000; it orbits about
    the point of its view ray above the field's middle (z = -5)."""
    pitch = 12.0
    distance = 80.0 / np.cos(np.radians(pitch))
    target_y = 30.0 - distance * np.sin(np.radians(pitch))
    return OrbitCamera(target=(0.0, float(target_y), -5.0), distance=float(distance), pitch=pitch)


class _GeometryShaderView(BaseView):
    """What both views share: Unity's unlit look on black, Cull Off, wireframe, and the draw-path switch."""

    background = (0.0, 0.0, 0.0)

    def __init__(self, ctx: moderngl.Context, sim):
        super().__init__(ctx, sim)
        self.cull, self.wireframe, self.path = False, False, PATHS[0]
        self.strip_program = load_program(ctx, "grass_strip", fragment="grass")
        self.strip_vbo, self.strip_ibo, self.strip_vertices = GrowableBuffer(ctx), None, 0

    def _begin(self) -> None:
        self.ctx.enable(moderngl.DEPTH_TEST)
        if self.cull:  # the book says Cull Off: with culling, every blade or pyramid face seen from behind vanishes
            self.ctx.enable(moderngl.CULL_FACE)
            self.ctx.front_face = "cw"  # Unity's front faces are clockwise; the view matrix mirrors z
        self.ctx.wireframe = self.wireframe

    def _end(self) -> None:
        self.ctx.disable(moderngl.CULL_FACE)
        self.ctx.front_face = "ccw"
        self.ctx.wireframe = False

    def _upload_strips(self, positions: np.ndarray, colors: np.ndarray, triangles) -> None:
        """The kernel's world-space vertices and colours, interleaved; ``triangles()`` gives their triangle list,
        called only when the vertex count changes (the list depends on nothing else)."""
        data = np.concatenate([positions.reshape(-1, 3), colors.reshape(-1, 4)], axis=1).astype("f4")
        grown = self.strip_vbo.write(data)
        if grown or len(data) != self.strip_vertices:
            if self.strip_ibo is not None:
                self.strip_ibo.release()
            self.strip_ibo = self.ctx.buffer(np.ascontiguousarray(triangles(), "u4").tobytes())
            self.strip_vertices = len(data)
            self.strip_vao = self.ctx.vertex_array(
                self.strip_program,
                [(self.strip_vbo.buffer, "3f 4f", "in_position", "in_color")],
                index_buffer=self.strip_ibo,
                index_element_size=4,
            )

    def _draw_strips(self, camera) -> None:
        set_camera(self.strip_program, camera)
        self.strip_vao.render(moderngl.TRIANGLES)

    # {{{ shared key actions

    def toggle_cull(self) -> None:
        self.cull = not self.cull

    def toggle_wireframe(self) -> None:
        self.wireframe = not self.wireframe

    def next_path(self) -> None:
        self.path = PATHS[(PATHS.index(self.path) + 1) % len(PATHS)]

    # }}}


class GrassView(_GeometryShaderView):
    title = "Grass shader (vol.1 ch.6)"
    keys = (
        Key("up", "height x 1.1", "taller"),
        Key("down", "height / 1.1", "shorter"),
        Key("right", "width x 1.1", "wider"),
        Key("left", "width / 1.1", "narrower"),
        Key("]", "wind_power + 0.25", "more_wind"),
        Key("[", "wind_power - 0.25", "less_wind"),
        Key("w", "wind on/off", "toggle_wind"),
        Key(",", "wind_time_scale: 1/20 (book) / 1 (visible sway)", "toggle_time_scale"),
        Key("+", "density: plane_resolution x 2", "denser"),
        Key("-", "density: plane_resolution / 2", "sparser"),
        Key("2", "more planes (+1 per side)", "more_planes"),
        Key("1", "fewer planes (-1 per side)", "fewer_planes"),
        Key("c", "back-face culling on/off (the book: Cull Off)", "toggle_cull"),
        Key("f", "wireframe on/off", "toggle_wireframe"),
        Key("tab", "draw with the geometry shader / the OpenCL blades", "next_path"),
    )

    def __init__(self, ctx: moderngl.Context, sim):
        super().__init__(ctx, sim)
        self.program = load_program(ctx, "grass", varyings=GS_VARYINGS)
        self.saved_wind_power = sim.params.wind_power or sim.Params().wind_power
        self.ground = self.maps = self.models_bytes = None
        self.textures: dict[str, moderngl.Texture] = {}
        self.vao = None

    def make_camera(self):
        return book_grass_camera()

    # {{{ GL objects

    def upload(self) -> None:
        sim = self.sim
        if self.maps is not sim.maps:
            self._upload_maps(sim.maps)
        if self.ground is not sim.ground or self.models_bytes != sim.models.tobytes():
            self._upload_mesh(sim.ground, sim.models)
        if self.path == "OpenCL":
            blades = sim.blades_state()
            self._upload_strips(blades["blade_pos"], blades["blade_col"], lambda: strip_triangles(sim.blades))

    def _upload_maps(self, maps: dict[str, np.ndarray]) -> None:
        for texture in self.textures.values():
            texture.release()
        self.textures = {}
        for sampler, name in MAP_OF_SAMPLER.items():
            image = np.ascontiguousarray(maps[name], "f4")  # row 0 = v = 0, as GL textures start
            texture = self.ctx.texture(image.shape[::-1], 1, image.tobytes(), dtype="f4")
            texture.filter = (moderngl.LINEAR, moderngl.LINEAR)  # bilinear, no mipmaps (Unity import settings)
            texture.repeat_x = texture.repeat_y = True
            self.textures[sampler] = texture
        self.maps = maps

    def _upload_mesh(self, mesh: dict[str, np.ndarray], models: np.ndarray) -> None:
        if self.vao is not None:
            for obj in (self.vao, self.vbo, self.ibo, self.instances):
                obj.release()
        vertices = np.concatenate([mesh["pos"], mesh["nrm"], mesh["uv"]], axis=1).astype("f4")
        self.vbo = self.ctx.buffer(vertices.tobytes())
        self.ibo = self.ctx.buffer(np.ascontiguousarray(mesh["tri"], "u4").tobytes())
        # GLSL reads a mat4 attribute column by column: upload each row-major model transposed
        self.instances = self.ctx.buffer(np.ascontiguousarray(models.transpose(0, 2, 1), "f4").tobytes())
        self.vao = self.ctx.vertex_array(
            self.program,
            [
                (self.vbo, "3f 3f 2f", "in_position", "in_normal", "in_uv"),
                (self.instances, "16f/i", "in_model"),
            ],
            index_buffer=self.ibo,
            index_element_size=4,
        )
        self.ground, self.models_bytes, self.instance_count = mesh, models.tobytes(), len(models)

    def set_uniforms(self, camera) -> None:
        """Camera, the Params the geometry shader reads, the shader time and the three maps."""
        p = self.sim.params
        set_camera(self.program, camera)
        for name in PARAM_FIELDS:
            set_uniform(self.program, name, getattr(p, name))
        set_uniform(self.program, "time", float(self.sim.shader_time))
        for sampler, unit in TEXTURE_UNITS.items():
            self.textures[sampler].use(unit)
            set_uniform(self.program, sampler, unit)

    # }}}

    def draw(self, camera) -> None:
        self._begin()
        if self.path == "OpenCL":
            self._draw_strips(camera)
        else:
            self.set_uniforms(camera)
            self.vao.render(moderngl.TRIANGLES, instances=self.instance_count)  # one instance per plane
        self._end()

    def status(self) -> list[str]:
        p = self.sim.params
        return [
            f"{self.sim.blades} blades ({len(self.sim.models)} planes x {len(self.sim.ground['tri'])} triangles), "
            f"{self.sim.blades * BLADE_VERTICES} vertices emitted  [{self.path}]",
            f"height {p.height:.3g}  width {p.width:.3g}  wind_power {p.wind_power:g}  "
            f"wind_time_scale {p.wind_time_scale:g}  t = {self.sim.shader_time:.1f} s"
            + ("  cull on" if self.cull else ""),
        ]

    # {{{ key actions

    def taller(self) -> None:
        self.sim.update(height=self.sim.params.height * 1.1)

    def shorter(self) -> None:
        self.sim.update(height=self.sim.params.height / 1.1)

    def wider(self) -> None:
        self.sim.update(width=self.sim.params.width * 1.1)

    def narrower(self) -> None:
        self.sim.update(width=self.sim.params.width / 1.1)

    def more_wind(self) -> None:
        self.sim.update(wind_power=self.sim.params.wind_power + 0.25)

    def less_wind(self) -> None:
        self.sim.update(wind_power=self.sim.params.wind_power - 0.25)

    def toggle_wind(self) -> None:
        power = self.sim.params.wind_power
        if power:
            self.saved_wind_power = power
        self.sim.update(wind_power=0.0 if power else self.saved_wind_power)

    def toggle_time_scale(self) -> None:
        faithful = type(self.sim.params)().wind_time_scale
        fast = self.sim.params.wind_time_scale == faithful
        self.sim.update(wind_time_scale=FAST_WIND_TIME_SCALE if fast else faithful)

    def _resize(self, planes: tuple[int, int], resolution: int) -> None:
        try:
            self.sim.update(planes=planes, plane_resolution=resolution)
        except ValueError:  # Params.check: more than MAX_BLADES blades; keep the current field
            pass

    def denser(self) -> None:
        self._resize(self.sim.params.planes, min(1000, self.sim.params.plane_resolution * 2))

    def sparser(self) -> None:
        self._resize(self.sim.params.planes, max(1, self.sim.params.plane_resolution // 2))

    def more_planes(self) -> None:
        w, h = self.sim.params.planes
        self._resize((min(50, w + 1), min(50, h + 1)), self.sim.params.plane_resolution)

    def fewer_planes(self) -> None:
        w, h = self.sim.params.planes
        self._resize((max(1, w - 1), max(1, h - 1)), self.sim.params.plane_resolution)

    # }}}


class PyramidView(_GeometryShaderView):
    title = "Simple geometry shader (vol.1 ch.6)"
    keys = (
        Key("up", "height x 1.1", "taller"),
        Key("down", "height / 1.1", "shorter"),
        Key("c", "back-face culling on/off (the book: Cull Off)", "toggle_cull"),
        Key("f", "wireframe on/off", "toggle_wireframe"),
        Key("tab", "draw with the geometry shader / the OpenCL pyramids", "next_path"),
    )

    def __init__(self, ctx: moderngl.Context, sim):
        super().__init__(ctx, sim)
        self.program = load_program(ctx, "grass_pyramid", fragment="grass", varyings=GS_VARYINGS)
        self.flat_program = load_program(ctx, "grass_flat", fragment="grass")
        self.ground = None

    def make_camera(self):
        # book: orthographic size 5 at (0, 7.6, -10) pitched 25 degrees down; orbit about where that ray meets y = 0
        pitch = 25.0
        distance = 7.6 / np.sin(np.radians(pitch))
        target_z = -10.0 + distance * np.cos(np.radians(pitch))
        # both quads reach x = +-8 (4.5 + 2.5 (cos 35 + sin 35)): keep them in narrower windows than the book's 16:9
        return OrthoCamera(
            target=(0.0, 0.0, float(target_z)),
            distance=float(distance),
            pitch=pitch,
            half_height=5.0,
            min_half_width=8.5,
        )

    def upload(self) -> None:
        sim = self.sim
        if self.ground is not sim.ground:
            if self.ground is not None:
                for obj in (self.vao, self.flat_vao, self.vbo, self.ibo):
                    obj.release()
            self.vbo = self.ctx.buffer(np.ascontiguousarray(sim.ground["pos"], "f4").tobytes())
            self.ibo = self.ctx.buffer(np.ascontiguousarray(sim.ground["tri"], "u4").tobytes())
            content = [(self.vbo, "3f", "in_position")]
            self.vao = self.ctx.vertex_array(self.program, content, index_buffer=self.ibo, index_element_size=4)
            self.flat_vao = self.ctx.vertex_array(
                self.flat_program, content, index_buffer=self.ibo, index_element_size=4
            )
            self.ground = sim.ground
        if self.path == "OpenCL":
            state = sim.state()
            vertices = state["pyr_pos"].shape[0] * state["pyr_pos"].shape[1]  # separate triangles, in order
            self._upload_strips(state["pyr_pos"], state["pyr_col"], lambda: np.arange(vertices).reshape(-1, 3))

    def set_uniforms(self, camera) -> None:
        p = self.sim.params
        set_camera(self.program, camera)
        set_uniform(self.program, "m_model", self.sim.model.astype(np.float64))
        for name in ("height", "top_color", "bottom_color"):
            set_uniform(self.program, name, getattr(p, name))

    def draw(self, camera) -> None:
        self._begin()
        set_camera(self.flat_program, camera)  # fig. 6.2: the quad as it is
        set_uniform(self.flat_program, "m_model", self.sim.models[0].astype(np.float64))
        set_uniform(self.flat_program, "color", PLAIN_QUAD_COLOR)
        self.flat_vao.render(moderngl.TRIANGLES)
        if self.path == "OpenCL":
            self._draw_strips(camera)
        else:  # fig. 6.3: the same quad through the geometry shader
            self.set_uniforms(camera)
            self.vao.render(moderngl.TRIANGLES)
        self._end()

    def status(self) -> list[str]:
        p = self.sim.params
        return [
            f"{self.sim.triangles} triangles in, {4 * self.sim.triangles} out  height {p.height:.3g}  [{self.path}]"
            + ("  cull on" if self.cull else "")
        ]

    def taller(self) -> None:
        self.sim.update(height=self.sim.params.height * 1.1)

    def shorter(self) -> None:
        self.sim.update(height=self.sim.params.height / 1.1)
