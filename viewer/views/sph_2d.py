"""SPH fluid 2D view (vol.1 ch.5, FluidRenderer + Particle.shader): one point per particle, expanded by a geometry
shader into a soft sprite in the water colour on black; drag with the mouse to push the fluid."""

from __future__ import annotations

import math

import moderngl
import numpy as np

from ..camera import FlatCamera
from ..gl import GrowableBuffer, Lines, load_program, set_camera, set_uniform
from . import Key
from . import View as BaseView

COLOR_MODES = ("water", "speed", "density", "pressure")
"""What the Tab key cycles through: the book's water colour, or a blue-to-red ramp of one quantity."""
MIN_PARTICLES = 256
MAX_PARTICLES = {"all_pairs": 32768, "grid": 1 << 20}
"""Range of the [ and ] keys per neighbour search (the all-pairs loops cost N^2)."""
NO_GRAVITY = (0.0, 0.0)


class View(BaseView):
    title = "SPH fluid 2D (vol.1 ch.5)"
    background = (0.0, 0.0, 0.0)
    keys = (
        Key("[", "halve the particles (same fluid area: h, mass, radius scale)", "fewer_particles"),
        Key("]", "double the particles (same fluid area: h, mass, radius scale)", "more_particles"),
        Key("+", "pressure_stiffness x 1.5", "stiffer"),
        Key("-", "pressure_stiffness / 1.5", "softer"),
        Key(".", "viscosity x 2", "more_viscous"),
        Key(",", "viscosity / 2", "less_viscous"),
        Key("g", "gravity on/off (weightless fluid)", "toggle_gravity"),
        Key("k", "neighbour search: all pairs (book) / uniform grid", "next_search"),
        Key("tab", "colour: water / speed / density / pressure", "next_color_mode"),
        Key("b", "box outline on/off", "toggle_box"),
    )

    def __init__(self, ctx: moderngl.Context, sim):
        super().__init__(ctx, sim)
        self.program = load_program(ctx, "sph_2d")
        self.particles = GrowableBuffer(ctx)  # FluidParticle records: the book's _ParticlesBuffer
        self.values = GrowableBuffer(ctx)  # the density or pressure per particle, when a colour mode shows it
        self.layout = None  # the particle buffer's vertex format: positions only (water) or whole records
        self.box = Lines(ctx, color=(0.45, 0.45, 0.45, 1.0))
        self.show_box, self.color_mode = True, "water"
        self.color_scale = 1.0
        self.saved_gravity = sim.params.gravity if sim.params.gravity != NO_GRAVITY else (0.0, -10.0)
        self.mean_density = 0.0
        self.picture_rect: tuple[float, float, float, float] | None = None
        """A fixed rect around the fluid for pictures (``png_camera``); None: the box's."""

    def _rect(self) -> tuple[float, float, float, float]:
        """The box plus a margin of range.y / 9 (the book scene's camera: half-height 5.5 around (8, 4.5);
        docs/chapters/05-sph-2d.md, "What differs from the book")."""
        w, h = self.sim.params.range
        margin = h / 9.0
        return (-margin, w + margin, -margin, h + margin)

    def make_camera(self):
        return FlatCamera(rect=self._rect())

    def png_camera(self):
        """Pictures zoom onto the fluid where that fits in three quarters of the box's width and height (the code
        defaults' disc of radius 0.1 in a 1 x 1 box covers 3 % of it): the particles' bounds down to the floor,
        plus a margin of a fifth of the fluid's own size (a disc still in the air keeps the floor under it without
        a margin as tall as its fall). The rect stays fixed for the camera's life (a video does not jump)."""
        x0, x1, y0, y1 = self._rect()
        position = self.sim.particles_array()["position"]
        (fx0, fy0), (fx1, fy1) = position.min(axis=0), position.max(axis=0)
        margin = 0.2 * max(fx1 - fx0, fy1 - fy0)
        fy0 = 0.0  # the floor the fluid lands on stays in view
        fluid = (max(fx0 - margin, x0), min(fx1 + margin, x1), max(fy0 - margin, y0), min(fy1 + margin, y1))
        small = fluid[1] - fluid[0] < 0.75 * (x1 - x0) and fluid[3] - fluid[2] < 0.75 * (y1 - y0)
        self.picture_rect = tuple(map(float, fluid)) if small else None
        return FlatCamera(rect=self.picture_rect or self._rect())

    def upload(self) -> None:
        # straight from page-locked copies to GL, only what the colour mode shows (a million particles: 8 MB a
        # frame of positions for the water, 16 MB of records for the speed, 4 more for a density or pressure; GL
        # takes them at about 4 GB/s on the lent H200)
        sim, read = self.sim, self.sim.runtime.read_back
        water = self.color_mode == "water"
        data = read(sim.packed_positions() if water else sim.particles.read)
        field = {"density": sim.density, "pressure": sim.pressure}.get(self.color_mode)
        values = read(field) if field is not None else None
        grown = self.particles.write(data)
        if values is not None or self.values.buffer is None or self.values.buffer.size < 4 * sim.n:
            grown |= self.values.write(values if values is not None else np.zeros(sim.n, np.float32))
        layout = ("2f", "in_position") if water else ("2f 2f", "in_position", "in_velocity")
        if grown or layout != self.layout:
            self.layout = layout
            self.vao = self.ctx.vertex_array(
                self.program, [(self.particles.buffer, *layout), (self.values.buffer, "1f", "in_value")]
            )
        density = values if self.color_mode == "density" else read(sim.density)  # the bus is fast; GL is not
        self.mean_density = float(density.mean())
        if self.color_mode == "speed":  # computed only when shown: a norm per particle
            values = np.linalg.norm(data["velocity"], axis=1)
        if values is not None:  # top of the ramp: the 99th percentile, so one fast particle does not wash it out
            self.color_scale = max(float(np.percentile(values, 99)), 1e-6)
        w, h = self.sim.params.range
        self.box.set([[0, 0, 0], [w, 0, 0], [w, 0, 0], [w, h, 0], [w, h, 0], [0, h, 0], [0, h, 0], [0, 0, 0]])

    def draw(self, camera) -> None:
        p = self.sim.params
        camera.rect = self.picture_rect or self._rect()  # follows a new box size after a reset
        self.ctx.disable(moderngl.DEPTH_TEST)  # book: ZWrite Off; particles only blend
        if self.show_box:
            self.box.draw(camera)
        set_camera(self.program, camera)
        set_uniform(self.program, "particle_radius", p.particle_radius)
        set_uniform(self.program, "water_color", p.water_color)
        set_uniform(self.program, "color_mode", COLOR_MODES.index(self.color_mode))
        set_uniform(self.program, "color_scale", self.color_scale)
        self.ctx.enable(moderngl.BLEND)
        self.ctx.blend_func = moderngl.SRC_ALPHA, moderngl.ONE_MINUS_SRC_ALPHA
        self.vao.render(moderngl.POINTS, vertices=self.sim.n)
        self.ctx.disable(moderngl.BLEND)

    def status(self) -> list[str]:
        p = self.sim.params
        gravity = "off" if p.gravity == NO_GRAVITY else f"{p.gravity[1]:g}"
        scale = f" (top {self.color_scale:.3g})" if self.color_mode != "water" else ""
        return [
            f"N = {self.sim.n}  search: {p.search}  colour: {self.color_mode}{scale}",
            f"mean density {self.mean_density:.2f} (rest {p.rest_density:g})  B = {p.pressure_stiffness:.3g}  "
            f"mu = {p.viscosity:.3g}  h = {p.smoothlen:.3g}  gravity {gravity}",
        ]

    # {{{ mouse: hold and drag to push the fluid away (book: Fluid2D, _MouseDown / _MousePos)

    def on_drag(self, camera, u: float, v: float, du: float, dv: float) -> None:
        self.sim.push(*camera.to_world(u, v))

    def on_release(self, camera) -> None:
        self.sim.release()

    # }}}

    # {{{ key actions

    def _resize(self, n: int) -> None:
        """N particles over the same fluid area: h and the drawn radius scale with 1/sqrt(N), the mass with 1/N, so
        the number of neighbours and the densities stay the scene's."""
        p = self.sim.params
        n = int(min(MAX_PARTICLES[p.search], max(MIN_PARTICLES, n)))
        factor = n / self.sim.n
        if factor == 1:
            return
        self.sim.update(
            particle_num=n,
            smoothlen=p.smoothlen / math.sqrt(factor),
            particle_mass=p.particle_mass / factor,
            particle_radius=p.particle_radius / math.sqrt(factor),
        )

    def fewer_particles(self) -> None:
        self._resize(self.sim.n // 2)

    def more_particles(self) -> None:
        self._resize(self.sim.n * 2)

    def stiffer(self) -> None:
        self.sim.update(pressure_stiffness=self.sim.params.pressure_stiffness * 1.5)

    def softer(self) -> None:
        self.sim.update(pressure_stiffness=self.sim.params.pressure_stiffness / 1.5)

    def more_viscous(self) -> None:
        self.sim.update(viscosity=max(self.sim.params.viscosity * 2.0, 0.05))

    def less_viscous(self) -> None:
        self.sim.update(viscosity=self.sim.params.viscosity / 2.0)

    def toggle_gravity(self) -> None:
        if self.sim.params.gravity == NO_GRAVITY:
            self.sim.update(gravity=self.saved_gravity)
        else:
            self.saved_gravity = self.sim.params.gravity
            self.sim.update(gravity=NO_GRAVITY)

    def next_search(self) -> None:
        self.sim.update(search="grid" if self.sim.params.search == "all_pairs" else "all_pairs")

    def next_color_mode(self) -> None:
        self.color_mode = COLOR_MODES[(COLOR_MODES.index(self.color_mode) + 1) % len(COLOR_MODES)]

    def toggle_box(self) -> None:
        self.show_box = not self.show_box

    # }}}
