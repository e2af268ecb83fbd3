"""MCMC view (vol.1 ch.8, DemoMetropolis3d / DemoRejection3d): every emitted state as an instanced cube coloured by
its chain, chains revealed at ``chains_per_second``; the target density on a translucent slice (key v)."""

from __future__ import annotations

import moderngl
import numpy as np

from ugpcl.scenes.mcmc import DENSITY_MODES, PALETTE

from ..camera import OrbitCamera
from ..gl import GrowableBuffer, Lines, load_program, set_camera
from ..meshes import box_edges, cube
from . import Key
from . import View as BaseView

CUBE_SIZE = 0.3
"""The sample's cube prefabs are Unity cubes scaled 0.3."""
SLICE_TEXELS = 4
"""Density samples per lattice unit on the slice."""
MODES = ("metropolis", "rejection", "pi")
PI_POINTS_SHOWN = 4096


class View(BaseView):
    title = "MCMC sampling (vol.1 ch.8)"
    keys = (
        Key("tab", "sampler: metropolis / rejection / pi", "next_mode"),
        Key("d", "density: exact / legacy / grid / gaussian", "next_density"),
        Key("[", "proposal sigma x 0.8", "narrower"),
        Key("]", "proposal sigma x 1.25", "wider"),
        Key("t", "threshold up (from off to 0, then + 0.05)", "threshold_up"),
        Key("g", "threshold down (below 0: off)", "threshold_down"),
        Key(",", "burn-in / 2", "shorter_burn_in"),
        Key(".", "burn-in x 2", "longer_burn_in"),
        Key("+", "reveal faster (x 2)", "faster"),
        Key("-", "reveal slower (/ 2)", "slower"),
        Key("c", "clear: reveal again from the first chain", "clear"),
        Key("v", "density slice on/off", "toggle_slice"),
        Key("up", "slice up (z + 1)", "slice_up"),
        Key("down", "slice down (z - 1)", "slice_down"),
        Key("b", "lattice box on/off", "toggle_box"),
    )

    def __init__(self, ctx: moderngl.Context, sim):
        super().__init__(ctx, sim)
        self.program = load_program(ctx, "mcmc")
        vertices, indices = cube()
        self.mesh_vbo = ctx.buffer(vertices.tobytes())
        self.mesh_ibo = ctx.buffer(indices.tobytes())
        self.instances = GrowableBuffer(ctx, min_bytes=24)
        self.count = 0
        self.box = Lines(ctx, color=(0.6, 0.7, 0.8, 1.0))
        self.slice_program = load_program(ctx, "mcmc_slice")
        self.quad = ctx.buffer(np.array([0, 0, 1, 0, 0, 1, 1, 1], "f4").tobytes())
        self.slice_vao = ctx.vertex_array(self.slice_program, [(self.quad, "2f", "in_corner")])
        self.slice_texture = None
        self.show_slice, self.show_box = False, True
        self.slice_z = sim.params.L / 2
        self._uploaded = None  # what the instance buffer holds: (lattice buffer, revealed count)
        self._slice_key = None

    def make_camera(self):
        L = self.sim.params.L
        # the book's camera sits at (0, 1, -50) looking +z with the cloud up-right; this one orbits the lattice,
        # far enough that the box's near bottom corner stays inside a 16:9 frame
        return OrbitCamera(target=(L / 2, L / 2, L / 2), distance=1.9 * L, yaw=-30.0, pitch=20.0)

    # {{{ instances

    def instance_data(self) -> np.ndarray:
        """(n, 6) float32: position and colour of every cube shown now."""
        sim, p = self.sim, self.sim.params
        if p.mode == "metropolis":
            shown = sim.revealed()
            state = sim.state()
            positions = state["samples"][:shown].reshape(-1, 3)
            colors = np.repeat(np.asarray(PALETTE, "f4")[state["palette"][:shown]], p.samples, axis=0)
        elif p.mode == "rejection":
            points, ids = sim.rejection_points()
            positions = points[ids < sim.revealed() * p.limit]
            colors = np.broadcast_to(np.asarray(PALETTE[0], "f4"), positions.shape)
        else:
            u, hit = sim.pi_points(PI_POINTS_SHOWN)
            positions = np.column_stack([u * p.L, np.zeros(len(u))])
            colors = np.where(hit[:, None], np.asarray(PALETTE[1], "f4"), np.asarray(PALETTE[0], "f4"))
        return np.column_stack([positions, colors]).astype("f4")

    def upload(self) -> None:
        key = (id(self.sim.W), self.sim.revealed())
        if key != self._uploaded:
            data = self.instance_data()
            if self.instances.write(data):
                self.vao = self.ctx.vertex_array(
                    self.program,
                    [
                        (self.mesh_vbo, "3f 3f", "in_position", "in_normal"),
                        (self.instances.buffer, "3f 3f/i", "in_offset", "in_color"),
                    ],
                    index_buffer=self.mesh_ibo,
                )
            self.count, self._uploaded = len(data), key
        L = self.sim.params.L
        self.box.set(box_edges((L / 2 - 0.5,) * 3, (L,) * 3))  # lattice points 0..L-1, half a cell around
        if self.show_slice:
            self._upload_slice()

    def _upload_slice(self) -> None:
        p = self.sim.params
        key = (id(self.sim.W), p.density, self.slice_z)
        if key == self._slice_key:
            return
        n = p.L * SLICE_TEXELS
        coords = -0.5 + (np.arange(n) + 0.5) / SLICE_TEXELS
        x, y = np.meshgrid(coords, coords)
        points = np.column_stack([x.ravel(), y.ravel(), np.full(x.size, self.slice_z)])
        density = self.sim.density_at(points).reshape(n, n).astype("f4")  # row 0 = lowest y = GL's bottom row
        if self.slice_texture is None or self.slice_texture.size != (n, n):
            if self.slice_texture is not None:
                self.slice_texture.release()
            self.slice_texture = self.ctx.texture((n, n), 1, dtype="f4")
            self.slice_texture.repeat_x = self.slice_texture.repeat_y = False
        self.slice_texture.write(density.tobytes())
        self.slice_max = float(np.abs(density).max()) or 1.0
        self._slice_key = key

    # }}}

    def draw(self, camera) -> None:
        L = self.sim.params.L
        self.ctx.enable(moderngl.DEPTH_TEST)
        if self.count:
            set_camera(self.program, camera)
            self.program["cube_size"].value = CUBE_SIZE
            self.vao.render(moderngl.TRIANGLES, instances=self.count)
        if self.show_box:
            self.box.draw(camera)
        if self.show_slice and self.slice_texture is not None:
            set_camera(self.slice_program, camera)
            self.slice_program["rect"].value = (-0.5, -0.5, float(L), float(L))
            self.slice_program["slice_z"].value = float(self.slice_z)
            self.slice_program["inverse_max"].value = 1.0 / self.slice_max
            self.slice_texture.use(0)
            self.ctx.enable(moderngl.BLEND)
            self.ctx.blend_func = moderngl.SRC_ALPHA, moderngl.ONE_MINUS_SRC_ALPHA
            self.ctx.depth_mask = False  # translucent: cubes behind it stay visible
            self.slice_vao.render(moderngl.TRIANGLE_STRIP)
            self.ctx.depth_mask = True
            self.ctx.disable(moderngl.BLEND)

    def status(self) -> list[str]:
        s, p = self.sim.stats(), self.sim.params
        if p.mode == "metropolis":
            threshold = "off" if p.threshold < 0 else f"{p.threshold:g}"
            return [
                f"Metropolis  density: {p.density}  sigma {p.sigma:g}  threshold {threshold}  burn-in {p.burn_in}",
                f"chains {s['chains shown']}/{p.chains}  cubes {s['chains shown'] * p.samples}  "
                f"acceptance {s['acceptance rate']:.3f}  failed resets {s['failed resets']}",
            ]
        if p.mode == "rejection":
            return [
                f"Rejection  noise > {p.rejection_threshold:g}  scale {p.noise_scale:g}",
                f"batches {s['batches shown']}/{p.batches}  kept {s['accepted']}/{s['candidates']}"
                f" ({s['acceptance rate']:.3%})",
            ]
        return [f"pi ~ {s['pi estimate']:.6f} from {p.n} points ({s['hits']} hits); first {PI_POINTS_SHOWN} shown"]

    # {{{ key actions

    def next_mode(self) -> None:
        self.sim.update(mode=MODES[(MODES.index(self.sim.params.mode) + 1) % len(MODES)])

    def next_density(self) -> None:
        d = self.sim.params.density
        self.sim.update(density=DENSITY_MODES[(DENSITY_MODES.index(d) + 1) % len(DENSITY_MODES)])

    def narrower(self) -> None:
        self.sim.update(sigma=max(0.01, self.sim.params.sigma * 0.8))

    def wider(self) -> None:
        self.sim.update(sigma=min(100.0, self.sim.params.sigma * 1.25))

    def threshold_up(self) -> None:
        t = self.sim.params.threshold
        self.sim.update(threshold=0.0 if t < 0 else round(t + 0.05, 6))

    def threshold_down(self) -> None:
        t = self.sim.params.threshold - 0.05
        self.sim.update(threshold=-100.0 if t < 0 else round(t, 6))

    def shorter_burn_in(self) -> None:
        self.sim.update(burn_in=self.sim.params.burn_in // 2)

    def longer_burn_in(self) -> None:
        self.sim.update(burn_in=min(100000, max(1, self.sim.params.burn_in * 2)))

    def faster(self) -> None:
        p = self.sim.params
        self.sim.update(chains_per_second=min(1e6, p.chains_per_second * 2))
        self.sim.update(batches_per_second=min(1e6, p.batches_per_second * 2))

    def slower(self) -> None:
        p = self.sim.params
        self.sim.update(chains_per_second=max(0.1, p.chains_per_second / 2))
        self.sim.update(batches_per_second=max(0.1, p.batches_per_second / 2))

    def clear(self) -> None:
        self.sim.time = 0.0  # the samples stay; the reveal starts over

    def toggle_slice(self) -> None:
        self.show_slice = not self.show_slice

    def slice_up(self) -> None:
        self.slice_z = min(self.sim.params.L - 1, self.slice_z + 1)

    def slice_down(self) -> None:
        self.slice_z = max(0, self.slice_z - 1)

    def toggle_box(self) -> None:
        self.show_box = not self.show_box

    # }}}
