"""Stable fluids 3D view (vol.1 ch.4): the solver volume ray-marched as smoke, or one slice, in a wire box.

The book's Solver3D has no renderer. Ray-marching was chosen over stacked slices because smoke is a volume: a
ray per pixel through the linear-filtered field shows the plume's whole depth from any orbit angle without
sorting or slicing artefacts, and one shadow ray per sample gives it shape. The slice mode shows the inside
(density or speed) where the smoke is too thick to see through.

The smoke is ray-marched by an OpenCL kernel (RayMarchSmoke, ``Simulation.ray_march``) into a picture the size of
the viewport, which is uploaded and laid over the box: 3.7 MB at 1280x720 instead of the half-float volume (32 MB at
256^3), and the march runs on the whole device, where a compute GPU (H100, H200) runs graphics shaders on a few of
its multiprocessors and takes GL uploads from the host at a few GB/s. The fragment shader's ray march
(stable_fluids_3d.frag, the same steps) stays for the slice display and as ``gl_smoke``: the smoke on CPU devices,
and what the tests compare the kernel's picture with.
"""

from __future__ import annotations

import moderngl
import numpy as np

from ..camera import OrbitCamera
from ..gl import Lines, load_program, set_uniform
from ..meshes import box_edges
from . import Key
from . import View as BaseView

DISPLAYS = ("smoke", "slice")
FIELDS = ("density", "speed")
AXES = "xyz"
LIGHT_DIR = np.array([0.4, 1.0, -0.3]) / np.linalg.norm([0.4, 1.0, -0.3])
"""Towards the light, scene coordinates: above, a little to the right and in front (Unity's -z side)."""
EMITTER_STEP = 0.05
"""Arrow keys move the emitter this far in uvw units."""
SLICE_STEP = 1.0 / 32.0
SPEED_ABSORPTION = 6.0
"""Extinction per box length of the fastest cell in the ray-marched speed display."""


def start_camera() -> OrbitCamera:
    """Window and PNG camera: the whole box (largest edge 1, centred on the origin) from the front-left, above."""
    return OrbitCamera(target=(0.0, 0.0, 0.0), distance=1.9, yaw=-30.0, pitch=20.0, near=0.05, far=50.0)


class View(BaseView):
    title = "Stable fluids 3D (vol.1 ch.4)"
    background = (0.12, 0.12, 0.13)
    keys = (
        Key("tab", "display: ray-marched smoke / slice", "next_display"),
        Key("f", "field: density / speed (length of the velocity)", "next_field"),
        Key("x", "slice axis x / y / z", "next_axis"),
        Key("[", "move the slice back", "slice_back"),
        Key("]", "move the slice forward", "slice_forward"),
        Key("1", "smoke absorption / 1.5", "thinner"),
        Key("2", "smoke absorption x 1.5", "thicker"),
        Key("+", "source_radius + 0.01", "larger_source"),
        Key("-", "source_radius - 0.01", "smaller_source"),
        Key(".", "gs_iterations x 2", "more_iterations"),
        Key(",", "gs_iterations / 2", "fewer_iterations"),
        Key("v", "variant fixed / book", "toggle_variant"),
        Key("d", "density_only on/off", "toggle_density_only"),
        Key("e", "emitter on/off", "toggle_emitter"),
        Key("left", "emitter -x", "emitter_left"),
        Key("right", "emitter +x", "emitter_right"),
        Key("up", "emitter +z (away)", "emitter_away"),
        Key("down", "emitter -z (nearer)", "emitter_nearer"),
        Key("b", "box outline on/off", "toggle_box"),
    )

    def __init__(self, ctx: moderngl.Context, sim):
        super().__init__(ctx, sim)
        self.program = load_program(ctx, "stable_fluids_3d")
        self.vao = ctx.vertex_array(self.program, [])
        self.texture = None
        self.volume_current = False  # the texture holds this frame's volume (upload() leaves it for the slice)
        self.copy = load_program(ctx, "postfx_copy", vertex="fullscreen")  # the picture, texel for pixel
        self.copy_vao = ctx.vertex_array(self.copy, [])
        self.smoke_texture = None
        # the smoke by the fragment shader from the uploaded volume, instead of by RayMarchSmoke into a picture: on a
        # CPU device, where GL (llvmpipe) runs on the same cores, a little faster there (ugpcl bench frames, 48^3 at
        # 1280x720 on 2 cores: 148-161 against 166-187 ms a frame) and no bus to spare; the tests set it to compare
        self.gl_smoke = not sim.runtime.is_gpu
        self.box = Lines(ctx, color=(0.55, 0.55, 0.6, 1.0))
        self.display, self.field, self.slice_axis, self.slice_position = "smoke", "density", 2, 0.5
        self.show_box = True
        self.max_density = self.max_speed = 0.0

    def make_camera(self):
        return start_camera()

    @property
    def box_size(self) -> np.ndarray:
        """World size of the grid: cells are cubes, the largest edge is 1."""
        p = self.sim.params
        dims = np.array([p.width, p.height, p.depth], float)
        return dims / dims.max()

    def upload(self) -> None:
        self.box.set(box_edges((0.0, 0.0, 0.0), self.box_size))
        self.volume_current = False
        if self.display == "slice" or self.gl_smoke:  # the device's smoke is made in draw(), for the camera
            self.upload_volume()

    def upload_volume(self) -> None:
        # only the shown field, as half floats, and the two maxima reduced on the device: 2 bytes a cell
        volume, self.max_density, self.max_speed = self.sim.draw_volume(self.field)  # (D, H, W): x fastest, as GL's
        d, h, w = volume.shape
        if self.texture is None or self.texture.size != (w, h, d):
            if self.texture is not None:
                self.texture.release()
            self.texture = self.ctx.texture3d((w, h, d), 1, dtype="f2")  # R16F
            self.texture.filter = (moderngl.LINEAR, moderngl.LINEAR)
            self.texture.repeat_x = self.texture.repeat_y = self.texture.repeat_z = False
        self.texture.write(volume)
        self.volume_current = True

    def draw(self, camera) -> None:
        if self.show_box:
            self.ctx.enable(moderngl.DEPTH_TEST)
            self.box.draw(camera)
        if self.display == "smoke" and not self.gl_smoke:
            self.draw_smoke(camera)
        else:
            self.draw_gl(camera)

    def draw_smoke(self, camera) -> None:
        """The smoke ray-marched on the device for this camera and viewport, laid over the box."""
        size = tuple(self.ctx.viewport[2:])
        speed = self.field == "speed"
        image, self.max_density, self.max_speed = self.sim.ray_march(
            np.linalg.inv(camera.projection() @ camera.view()),
            camera.eye(),
            size,
            self.field,
            SPEED_ABSORPTION if speed else self.sim.params.absorption,
            LIGHT_DIR,
        )
        if self.smoke_texture is None or self.smoke_texture.size != size:
            if self.smoke_texture is not None:
                self.smoke_texture.release()
            self.smoke_texture = self.ctx.texture(size, 4)  # RGBA8, row 0 at the bottom as the picture's
        self.smoke_texture.write(image)
        self.smoke_texture.use(0)
        self._blend_over(self.copy_vao)

    def _blend_over(self, vao) -> None:
        """One full-screen triangle of premultiplied colour over what is drawn (the box)."""
        self.ctx.disable(moderngl.DEPTH_TEST)
        self.ctx.enable(moderngl.BLEND)
        self.ctx.blend_func = moderngl.ONE, moderngl.ONE_MINUS_SRC_ALPHA
        vao.render(moderngl.TRIANGLES, vertices=3)
        self.ctx.disable(moderngl.BLEND)

    def draw_gl(self, camera) -> None:
        """The fragment shader's display of the uploaded volume: the slice, or the smoke where ``gl_smoke``."""
        if not self.volume_current:  # the display changed since upload()
            self.upload_volume()
        p = self.sim.params
        speed = self.field == "speed"
        dims = np.array([p.width, p.height, p.depth], float)
        uniforms = {
            "m_inv_view_proj": np.linalg.inv(camera.projection() @ camera.view()),
            "eye": tuple(float(v) for v in camera.eye()),
            "box_size": tuple(float(v) for v in self.box_size),
            "step_size": float(0.5 / dims.max()),  # half a cell
            "display": DISPLAYS.index(self.display),
            "field": FIELDS.index(self.field),
            "absorption": float(SPEED_ABSORPTION if speed else p.absorption),
            "value_scale": 1.0 / self.max_speed if speed and self.max_speed > 0 else 1.0,
            "slice_scale": 1.0 / max(1.0 if speed else self.max_density, 1e-12),
            "slice_axis": self.slice_axis,
            "slice_position": float(self.slice_position),
            "light_dir": tuple(float(v) for v in LIGHT_DIR),
            "volume": 0,
        }
        for name, value in uniforms.items():
            set_uniform(self.program, name, value)
        self.texture.use(0)
        self._blend_over(self.vao)  # premultiplied colour from the shader (the slice: opaque)

    def status(self) -> list[str]:
        p = self.sim.params
        view = self.display if self.display == "smoke" else f"slice {AXES[self.slice_axis]} = {self.slice_position:.2f}"
        center = ", ".join(f"{c:.2f}" for c in p.emitter_center)
        emitter = f"emitter {'on' if self.sim.source_active() else 'off'} at ({center})"
        return [
            f"{p.width}x{p.height}x{p.depth}  {p.variant}  {emitter}  gs {p.gs_iterations}"
            + ("  density only" if p.density_only else ""),
            f"{view}: {self.field}  max density {self.max_density:.3g}  max speed {self.max_speed:.3g}",
        ]

    # {{{ key actions

    def next_display(self) -> None:
        self.display = DISPLAYS[(DISPLAYS.index(self.display) + 1) % len(DISPLAYS)]

    def next_field(self) -> None:
        self.field = FIELDS[(FIELDS.index(self.field) + 1) % len(FIELDS)]

    def next_axis(self) -> None:
        self.slice_axis = (self.slice_axis + 1) % 3

    def slice_back(self) -> None:
        self.slice_position = max(0.0, self.slice_position - SLICE_STEP)

    def slice_forward(self) -> None:
        self.slice_position = min(1.0, self.slice_position + SLICE_STEP)

    def thinner(self) -> None:
        self.sim.update(absorption=self.sim.params.absorption / 1.5)

    def thicker(self) -> None:
        self.sim.update(absorption=self.sim.params.absorption * 1.5)

    def larger_source(self) -> None:
        self.sim.update(source_radius=min(1.0, round(self.sim.params.source_radius + 0.01, 4)))

    def smaller_source(self) -> None:
        self.sim.update(source_radius=max(0.01, round(self.sim.params.source_radius - 0.01, 4)))

    def more_iterations(self) -> None:
        self.sim.update(gs_iterations=min(4096, self.sim.params.gs_iterations * 2))

    def fewer_iterations(self) -> None:
        self.sim.update(gs_iterations=max(1, self.sim.params.gs_iterations // 2))

    def toggle_variant(self) -> None:
        self.sim.update(variant="book" if self.sim.params.variant == "fixed" else "fixed")

    def toggle_density_only(self) -> None:
        self.sim.update(density_only=not self.sim.params.density_only)

    def toggle_emitter(self) -> None:
        self.sim.update(emitter=not self.sim.params.emitter)

    def _move_emitter(self, axis: int, delta: float) -> None:
        center = list(self.sim.params.emitter_center)
        center[axis] = float(np.clip(round(center[axis] + delta, 4), 0.0, 1.0))
        self.sim.update(emitter_center=tuple(center))

    def emitter_left(self) -> None:
        self._move_emitter(0, -EMITTER_STEP)

    def emitter_right(self) -> None:
        self._move_emitter(0, EMITTER_STEP)

    def emitter_away(self) -> None:
        self._move_emitter(2, EMITTER_STEP)

    def emitter_nearer(self) -> None:
        self._move_emitter(2, -EMITTER_STEP)

    def toggle_box(self) -> None:
        self.show_box = not self.show_box

    # }}}
