"""Stable fluids 3D view (vol.1 ch.4): the solver volume ray-marched as smoke, or one slice, in a wire box.

The book's Solver3D has no renderer. Ray-marching was chosen over stacked slices because smoke is a volume: a
ray per pixel through a linear-filtered 3D texture shows the plume's whole depth from any orbit angle without
sorting or slicing artefacts, and one shadow ray per sample gives it shape. The slice mode shows the inside
(density or speed) where the smoke is too thick to see through.
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
        self.box.set(box_edges((0.0, 0.0, 0.0), self.box_size))

    def draw(self, camera) -> None:
        p = self.sim.params
        if self.show_box:
            self.ctx.enable(moderngl.DEPTH_TEST)
            self.box.draw(camera)
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
        self.ctx.disable(moderngl.DEPTH_TEST)
        self.ctx.enable(moderngl.BLEND)
        self.ctx.blend_func = moderngl.ONE, moderngl.ONE_MINUS_SRC_ALPHA  # premultiplied colour from the shader
        self.vao.render(moderngl.TRIANGLES, vertices=3)
        self.ctx.disable(moderngl.BLEND)

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
