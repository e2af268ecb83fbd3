"""Stable fluids 2D view (vol.1 ch.4, RenderEffect + Sample.shader): the solver's field on a quad, black ink on
white; drag with the mouse to paint velocity and ink (the book's MouseSourceProvider). GL gets only the field the
display mode shows, as half floats (Simulation.draw_texture: 2 or 4 bytes a cell, not the solver's 16)."""

from __future__ import annotations

import moderngl
import numpy as np

from ugpcl.scenes.stable_fluids_2d import STROKES, TEXTURE_FIELDS

from ..camera import FlatCamera
from ..gl import load_program, set_camera, set_uniform
from . import Key
from . import View as BaseView

DISPLAY_MODES = ("ink", "density", "velocity", "divergence")
"""What Tab cycles through: the book's ink, density in grey, velocity as colour, |divergence| as heat."""
SHOWN_FIELD = {"ink": "density", "density": "density", "velocity": "velocity", "divergence": "divergence"}
"""The field each display mode samples (Simulation.draw_texture)."""
RADIUS_STEP = 1.25
"""+ and - scale source_radius by this factor."""
MAX_SWEEPS = 4096
"""Top of the . key (gs_iterations doubling)."""


class FluidKeyActions:
    """Key actions on the 2D fluid's parameters, shared by this view and the tessellation view (its fluid's knobs)."""

    def toggle_density_only(self) -> None:
        self.sim.update(density_only=not self.sim.params.density_only)

    def next_stroke(self) -> None:
        self.sim.update(stroke=STROKES[(STROKES.index(self.sim.params.stroke) + 1) % len(STROKES)])
        self.sim.restart_stroke()

    def more_viscous(self) -> None:
        self.sim.update(visc=self.sim.params.visc * 2.0)

    def less_viscous(self) -> None:
        self.sim.update(visc=self.sim.params.visc / 2.0)

    def more_diffusion(self) -> None:
        self.sim.update(diff=self.sim.params.diff * 2.0)

    def less_diffusion(self) -> None:
        self.sim.update(diff=self.sim.params.diff / 2.0)


class View(FluidKeyActions, BaseView):
    title = "Stable fluids 2D (vol.1 ch.4)"
    background = (1.0, 1.0, 1.0)  # the sample camera clears to solid white
    keys = (
        Key("tab", "display: ink / density / velocity / divergence", "next_display"),
        Key("6", "ink post effect on/off (the original's RenderEffect)", "toggle_effect"),
        Key("v", "variant: fixed (Stam) / book (the original's arithmetic)", "toggle_variant"),
        Key("m", "solver: vol1 (this chapter) / vol4 (no pressure sweeps, no AdvectVelocity)", "toggle_solver"),
        Key("d", "density_only on/off (advect the ink by the brush only)", "toggle_density_only"),
        Key("c", "scripted stroke: circle / line / figure8 / none (replays it)", "next_stroke"),
        Key("+", "source_radius x 1.25", "bigger_brush"),
        Key("-", "source_radius / 1.25", "smaller_brush"),
        Key("up", "viscosity visc x 2", "more_viscous"),
        Key("down", "viscosity visc / 2", "less_viscous"),
        Key("right", "diffusion diff x 2", "more_diffusion"),
        Key("left", "diffusion diff / 2", "less_diffusion"),
        Key(".", "gs_iterations x 2 (Jacobi sweeps)", "more_sweeps"),
        Key(",", "gs_iterations / 2", "fewer_sweeps"),
        Key("]", "lod + 1 (grid / 2, clears the fluid)", "coarser_grid"),
        Key("[", "lod - 1 (grid x 2, clears the fluid)", "finer_grid"),
    )

    def __init__(self, ctx: moderngl.Context, sim):
        super().__init__(ctx, sim)
        self.program = load_program(ctx, "stable_fluids_2d")
        self.vbo = ctx.buffer(reserve=4 * 4 * 4)
        self.vao = ctx.vertex_array(self.program, [(self.vbo, "2f 2f", "in_position", "in_uv")])
        self.texture = None
        self.display, self.ink_effect = "ink", True
        self.velocity_scale, self.divergence_scale = 1.0, 1.0
        self.held: tuple[float, float] | None = None  # brush position (uv) while the mouse button is down
        self.move = np.zeros(2)  # mouse move (uv) since the last step took the brush

    def _rect(self) -> tuple[float, float, float, float]:
        return (0.0, float(self.sim.w), 0.0, float(self.sim.h))

    def make_camera(self):
        return FlatCamera(rect=self._rect())

    def upload(self) -> None:
        w, h, shown = self.sim.w, self.sim.h, SHOWN_FIELD[self.display]
        field, top = self.sim.draw_texture(shown)  # page-locked half floats, straight to GL
        components = TEXTURE_FIELDS[shown]
        if self.texture is None or (self.texture.size, self.texture.components) != ((w, h), components):
            if self.texture is not None:
                self.texture.release()
            self.texture = self.ctx.texture((w, h), components, dtype="f2")  # R16F or RG16F
            self.texture.filter = (moderngl.LINEAR, moderngl.LINEAR)
            self.texture.repeat_x = self.texture.repeat_y = False
            quad = np.array([[0, 0, 0, 0], [w, 0, 1, 0], [0, h, 0, 1], [w, h, 1, 1]], "f4")
            self.vbo.write(quad.tobytes())
        self.texture.write(field)  # row 0 = the bottom, as GL expects
        if self.display == "velocity":
            self.velocity_scale = 1.0 / max(top, 1e-6)
        elif self.display == "divergence":
            self.divergence_scale = 1.0 / max(top, 1e-6)
        if self.held is not None and self.sim.pending_brush is None:
            self.sim.brush(*self.held)  # button held still: ink keeps flowing in, as in the original

    def draw(self, camera) -> None:
        p = self.sim.params
        camera.rect = self._rect()  # follows the grid after a lod change
        self.ctx.disable(moderngl.DEPTH_TEST)
        set_camera(self.program, camera)
        set_uniform(self.program, "display_mode", DISPLAY_MODES.index(self.display))
        set_uniform(self.program, "ink_effect", self.ink_effect)
        set_uniform(self.program, "ink_gain", p.ink_gain)
        set_uniform(self.program, "velocity_scale", self.velocity_scale)
        set_uniform(self.program, "divergence_scale", self.divergence_scale)
        self.texture.use(0)
        set_uniform(self.program, "field", 0)
        self.vao.render(moderngl.TRIANGLE_STRIP)

    def status(self) -> list[str]:
        p, s = self.sim.params, self.sim
        extra = {"velocity": f"  (|v| max {1 / self.velocity_scale:.3g})", "divergence": ""}.get(self.display, "")
        return [
            f"grid {s.w}x{s.h} (lod {p.lod})  variant {p.variant}  solver {p.solver}  display {self.display}{extra}",
            f"visc {p.visc:g}  diff {p.diff:g}  sweeps {p.gs_iterations}  radius {p.source_radius:.3g}  "
            f"stroke {p.stroke}{'  density only' if p.density_only else ''}",
        ]

    # {{{ mouse: drag = brush (velocity along the drag + ink), as the book's MouseSourceProvider

    def _uv(self, camera, u: float, v: float) -> np.ndarray:
        x, y = camera.to_world(u, v)
        return np.array([x / self.sim.w, y / self.sim.h])

    def on_drag(self, camera, u: float, v: float, du: float, dv: float) -> None:
        here, before = self._uv(camera, u, v), self._uv(camera, u - du, v - dv)
        if self.sim.pending_brush is None:  # the last brush was used by a step: start a new frame's move
            self.move[:] = 0.0
        self.move += here - before
        self.held = (float(here[0]), float(here[1]))
        self.sim.brush(*self.held, *self.move)

    def on_release(self, camera) -> None:
        self.held = None

    # }}}

    # {{{ key actions

    def next_display(self) -> None:
        self.display = DISPLAY_MODES[(DISPLAY_MODES.index(self.display) + 1) % len(DISPLAY_MODES)]

    def toggle_effect(self) -> None:
        self.ink_effect = not self.ink_effect

    def toggle_variant(self) -> None:
        self.sim.update(variant="book" if self.sim.params.variant == "fixed" else "fixed")

    def toggle_solver(self) -> None:
        self.sim.update(solver="vol4" if self.sim.params.solver == "vol1" else "vol1")

    def bigger_brush(self) -> None:
        self.sim.update(source_radius=min(1.0, self.sim.params.source_radius * RADIUS_STEP))

    def smaller_brush(self) -> None:
        self.sim.update(source_radius=self.sim.params.source_radius / RADIUS_STEP)

    def more_sweeps(self) -> None:
        self.sim.update(gs_iterations=min(MAX_SWEEPS, self.sim.params.gs_iterations * 2))

    def fewer_sweeps(self) -> None:
        self.sim.update(gs_iterations=max(1, self.sim.params.gs_iterations // 2))

    def coarser_grid(self) -> None:
        p = self.sim.params
        if min(p.width >> (p.lod + 1), p.height >> (p.lod + 1)) >= 3:
            self.sim.update(lod=p.lod + 1)

    def finer_grid(self) -> None:
        self.sim.update(lod=max(0, self.sim.params.lod - 1))

    # }}}
