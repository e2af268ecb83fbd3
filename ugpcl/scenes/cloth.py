"""GPU cloth: a mass-spring grid hanging from its top row, pushed by a moving sphere (vol.4 ch.3;
docs/chapters/14-cloth.md).

One step is one frame of the book's ``GPUClothSimulation.Update``: the collider's centre is set from the frame
time (``ColliderTranslate``: z = TranslateCenterZ + cos(0.125 t) * TranslateLengthZ), then ``CSSimulation`` runs
``substeps`` times with dt = timestep / substeps, the position and previous-position buffers swapped (ping-pong)
after each launch. ``reset()`` runs ``CSInit`` and copies both pairs, as the book's ``ResetBuffer`` Blits.
``step(dt)``'s dt is the frame's duration (1/fps): it drives the sphere only; the cloth always advances
``timestep`` per frame, as the book's fixed TimeStep. ``pack_surface()`` (``PackSurface``, not in the book) packs
position and normal into the 16 bytes a particle the views upload to GL.

On a CPU device (PoCL) the substep runs ``CSSimulation_cpu`` instead of the book's ``CSSimulation``: 16 particles of a
row per work-item in the lanes of float16 vectors, the same arithmetic (PoCL's work-group vectorizer gives up on
CSSimulation's per-neighbour branches); ``stats()["CSSimulation kernel"]`` and the bench say which ran.

Differences from the book: sizes need not be multiples of the work-group edge; the pinned row copies itself to
the write buffers; ``variant=fixed`` (default) guards the book's two ``normalize(0)`` cases (coincident particles;
a crumpled ring whose consecutive directions are all >= 90 degrees apart keeps its previous normal), ``variant=book``
keeps them (NaN). ``physical_gravity`` (off by default) makes gravity an acceleration instead of the book's force.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pyopencl as cl
import pyopencl.cltypes as cltypes

from ..buffers import PingPong
from ..geometry.cloth import grid_triangles
from ..geometry.mesh import Mesh
from ..geometry.mesh_io import write_mesh
from ..scene import Animation, AtScale, Scene, param
from ..scene import Params as BaseParams
from ..scene import Simulation as BaseSimulation

TRANSLATE_SPEED = 0.125
"""Angular speed of the collider's back-and-forth motion, rad/s (book: ColliderTranslate, cos(Time.time * 0.125))."""
COLLIDER_MARGIN = 0.01
"""The collision radius exceeds the drawn sphere's by this, world units (book: localScale.x * 0.5f + 0.01f)."""
DIVERGED = "yes: positions are NaN/inf; lower timestep or stiffness, or raise substeps (dt*sqrt(12k/m) < 2)"
"""What stats() and the view say once the explicit integration has blown up."""
MAX_PARTICLES = 1 << 22
"""Cap on W*H (4M particles: 320 MB of float4 buffers)."""
CPU_LANES = 16
"""Particles of a row per work-item of CSSimulation_cpu (CPU_LANES in clkernels/cloth.cl)."""
SIMULATION_KERNELS = ("CSSimulation", "CSSimulation_cpu")
"""The substep's two kernels: the book's one work-item per particle, and the CPU's vector lanes."""


@dataclass(frozen=True)
class Params(BaseParams):
    timestep: float = param(0.01, 0.0, 0.1, lo_open=True, live=True)
    """Simulated seconds per frame, split into `substeps` Verlet steps (book: TimeStep)."""
    substeps: int = param(4, 1, 16, live=True)
    """CSSimulation launches per frame (book: VerletIterationNum, inspector range 1-16)."""
    res: tuple[int, int] = param((128, 128), 2, 4096)
    """Particles (W, H) (book: ClothResolution); the top row y = H-1 is pinned."""
    rest_length: float = param(0.02, 1e-4, 10.0, live=True)
    """Structural spring rest length = grid spacing, metres (book: RestLength); cloth size = res * rest_length.
    1e-4 to 10: the cloth (up to 4096 x 10 m) keeps float32 positions to 4 mm and springs above their rounding."""
    stiffness: float = param(10000.0, 0.0, 1e20, live=True)
    """Spring constant k (book: Stiffness); explicit Verlet needs dt * sqrt(12 k / mass) < 2.
    Up to 1e20: one spring's force stays finite in float32; past stability 2 it diverges and the run says so."""
    damp: float = param(0.996, 0.0, 1e6, live=True)
    """Velocity damping b, applied once per neighbour: force -= b * v (book: Damp).
    Up to 1e6: b * v stays finite in float32."""
    mass: float = param(1.0, 1e-6, 1e6, live=True)
    """Mass of every particle, kg; the kernel gets 1/mass (book: Mass).
    1e-6 to 1e6: 1/mass and mass * gravity stay finite in float32."""
    gravity: tuple[float, float, float] = param((0.0, -9.81, 0.0), -1e4, 1e4, live=True)
    """Added to each particle's force, then divided by the mass (book: Gravity).
    Within 1e4: force / mass stays finite in float32."""
    physical_gravity: bool = param(False, live=True)
    """Treat gravity as an acceleration (force = mass * gravity) instead of the book's force (vol.4 §3.4,
    Kernels.compute: force = _Gravity, acc = force * invMass)."""
    sphere: bool = param(True, live=True)
    """Collide with the sphere (book: _EnableCollideSphere, true when CollisionSphereTransform is set)."""
    sphere_scale: float = param(2.0, 0.0, 1e4, lo_open=True, live=True, ignored_when={"sphere": False})
    """Diameter of the drawn sphere (its localScale.x); collision radius = scale / 2 + 0.01.
    Up to 1e4 m: float32 positions keep 1 mm."""
    translate_center_z: float = param(0.0, -1e4, 1e4, live=True, ignored_when={"sphere": False})
    """Centre of the sphere's motion along z, metres (book: ColliderTranslate.TranslateCenterZ).
    Within 1e4 m: float32 positions keep 1 mm."""
    translate_length_z: float = param(4.0, -1e4, 1e4, live=True, ignored_when={"sphere": False})
    """Amplitude of the sphere's motion along z, metres (book: ColliderTranslate.TranslateLengthZ).
    Within 1e4 m: float32 positions keep 1 mm."""
    sphere_motion: bool = param(True, live=True, ignored_when={"sphere": False})
    """Move the sphere with the frame time; off freezes it where it is."""
    num_threads_xy: int = param(16, choices=(1, 2, 4, 8, 16, 32))
    """Work-group edge (book: NUM_THREADS_XY = 32); halved until the device runs it."""
    variant: str = param("fixed", choices=("book", "fixed"))
    """fixed: guard normalize(0) in springs and normals; book: leave it (NaN for coincident particles)."""

    limits = (f"res[0]*res[1] <= {MAX_PARTICLES}",)

    def check(self) -> None:
        w, h = self.res
        if w * h > MAX_PARTICLES:
            raise self.broken(self.limits[0], f"{w * h} particles")

    @property
    def substep_dt(self) -> float:
        """dt of one CSSimulation launch (book: TimeStep / VerletIterationNum)."""
        return self.timestep / self.substeps

    @property
    def stability(self) -> float:
        """dt * sqrt(12 k / m): explicit Verlet on the 12 springs diverges roughly where this passes 2
        (docs/chapters/14-cloth.md)."""
        return self.substep_dt * math.sqrt(12.0 * self.stiffness / self.mass)

    @property
    def collide_radius(self) -> float:
        """Radius the particles are pushed out to (book: localScale.x * 0.5 + 0.01)."""
        return self.sphere_scale * 0.5 + COLLIDER_MARGIN

    @property
    def total_len(self) -> tuple[float, float]:
        """Cloth size (W, H) * rest_length, metres (book: _TotalClothLength)."""
        return (self.res[0] * self.rest_length, self.res[1] * self.rest_length)


MAIN_SCENE = {"timestep": 0.02, "res": (64, 64), "rest_length": 0.05, "translate_length_z": 3.0}
"""The book's sample scene GPUClothSimulation: a 3.2 m cloth, the sphere sweeping 3 m either side."""
DEBUG_SCENE = {"timestep": 0.01, "res": (64, 64), "rest_length": 0.05, "translate_length_z": 4.0}
"""The book's sample scene Debug/GPUClothSimulationDebugRender."""


class Simulation(BaseSimulation):
    """W x H particles: CSInit on reset, then `substeps` CSSimulation launches per frame."""

    Params = Params
    history = ("pos", "normal", "sphere", "frame")

    def _reset(self) -> None:
        p, rt = self.params, self.runtime
        self.width, self.height = p.res
        fix_nan = p.variant == "fixed"
        # largest edge <= num_threads_xy whose square the device runs CSSimulation with (the book's 32 x 32 may not run)
        self.block, self.program = rt.fitted_program(
            "cloth", ("CSSimulation",), p.num_threads_xy, define="NUM_THREADS_XY", dims=2, FIX_NAN=fix_nan
        )
        shape = (self.height, self.width, 4)
        self.pos = PingPong.zeros(rt, shape, np.float32)  # book: _posBuff[0] (.read), _posBuff[1] (.write)
        self.prev = PingPong.zeros(rt, shape, np.float32)  # book: _posPrevBuff
        self.normal = rt.zeros(shape, np.float32)  # book: _normBuff
        self.surface = rt.zeros(shape, np.uint32)  # pack_surface: what the views upload (position, packed normal)
        # the substep's kernel (tests may set the other): PoCL does not vectorize the book's kernel across
        # work-items, so CPU devices get the vector-lane one; Oclgrind keeps the book's kernel to check it
        cpu = bool(rt.device.type & cl.device_type.CPU) and not rt.is_oclgrind
        self.simulation_kernel = "CSSimulation_cpu" if cpu else "CSSimulation"
        self._constants_for = None  # the Params object _constants were made from (live fields change it)
        self.sphere_time = 0.0  # the collider's clock: stops while sphere_motion is off
        self.sphere_params = self.collider(self.sphere_time)
        self.cs_init()

    def collider(self, t: float) -> np.ndarray:
        """(x, y, z, radius) of the collision sphere at collider time t (book: ColliderTranslate)."""
        p = self.params
        z = p.translate_center_z + math.cos(TRANSLATE_SPEED * t) * p.translate_length_z
        return np.array([0.0, 0.0, z, p.collide_radius], np.float32)

    @property
    def simulation_kernel(self) -> str:
        """Name of the kernel cs_simulation() launches: CSSimulation or CSSimulation_cpu (settable)."""
        return self._simulation_name

    @simulation_kernel.setter
    def simulation_kernel(self, name: str) -> None:
        if name not in SIMULATION_KERNELS:
            raise ValueError(f"simulation_kernel must be one of {'|'.join(SIMULATION_KERNELS)}, got {name!r}")
        self._simulation_name, self._simulation = name, self.program.kernel(name)

    # {{{ kernels, in the book's order

    def cs_init(self) -> None:
        """CSInit into pos.read, prev.read and normal, then copy both pairs (book: ResetBuffer's Graphics.Blit)."""
        p, rt = self.params, self.runtime
        self.program.kernel("CSInit").over(
            (self.width, self.height),
            (self.block, self.block),
            self.pos.read,
            self.prev.read,
            self.normal,
            cltypes.make_int2(self.width, self.height),
            cltypes.make_float2(*p.total_len),
            np.float32(p.rest_length),
        )
        cl.enqueue_copy(rt.queue, self.pos.write.data, self.pos.read.data)
        cl.enqueue_copy(rt.queue, self.prev.write.data, self.prev.read.data)

    def _scalars(self) -> tuple:
        """CSSimulation's arguments after the buffers: res, rest, gravity, stiffness, damp, 1/mass, dt, collide,
        sphere. Made once per Params object and collider position, so the launches of a frame pass the same
        objects and the launch path sets none of them again."""
        p, sphere = self.params, self.sphere_params
        if self._constants_for is not p:
            gravity = np.asarray(p.gravity) * (p.mass if p.physical_gravity else 1.0)
            self._constants = (
                cltypes.make_int2(self.width, self.height),
                np.float32(p.rest_length),
                cltypes.make_float4(*gravity, 0.0),
                np.float32(p.stiffness),
                np.float32(p.damp),
                np.float32(1.0 / p.mass),
                np.float32(p.substep_dt),
                np.int32(p.sphere),
            )
            self._constants_for, self._sphere_for = p, None
        if self._sphere_for is not sphere:  # step() sets a new array per frame (replace it, never edit it in place)
            self._sphere = cltypes.make_float4(*sphere)
            self._sphere_for = sphere
        return (*self._constants, self._sphere)

    def cs_simulation(self, write_normal: bool = True) -> None:
        """One CSSimulation launch (CSSimulation_cpu on CPU devices: ``simulation_kernel``), a substep of
        timestep / substeps against the current collider, then swap both ping-pong pairs. ``write_normal`` False
        leaves the normal as it was (step() writes it on a frame's last substep only)."""
        pos, prev = self.pos, self.prev
        args = (pos.read, prev.read, pos.write, prev.write, self.normal, *self._scalars(), WRITE_NORMAL[write_normal])
        if self._simulation_name == "CSSimulation_cpu":  # one work-item per CPU_LANES particles of a row, any group
            self._simulation((-(-self.width // CPU_LANES), self.height), None, *args)
        else:
            self._simulation.over((self.width, self.height), (self.block, self.block), *args)
        # swap buffers: the positions just written are read by the next substep
        pos.swap()
        prev.swap()

    # }}}

    def pack_surface(self):
        """PackSurface (not in the book; the views'): the (H, W, 4) uint32 device array of position (xyz, the
        float32 bits) and normal (w: round(n * 511) + 511 in 10 bits a component, x in bits 0-9, y 10-19, z 20-29), 16
        bytes a particle instead of pos and normal's 32."""
        n = self.width * self.height
        self.program.kernel("PackSurface").over(n, 256, self.pos.read, self.normal, self.surface, np.int32(n))
        return self.surface

    def cs_substeps(self) -> None:
        """A frame's ``substeps`` CSSimulation launches, the normal written by the last: only that one is drawn, and
        the others' 16 bytes a particle would be a fifth of their traffic (on an H100 at 1024^2, 33 against 41 us)."""
        for k in range(self.params.substeps):
            self.cs_simulation(write_normal=k == self.params.substeps - 1)

    def _step(self, dt: float) -> None:
        """One frame: place the collider at the frame's time, then `substeps` CSSimulation launches."""
        self.sphere_params = self.collider(self.sphere_time)
        self.cs_substeps()
        if self.params.sphere_motion:
            self.sphere_time += dt

    # {{{ state

    def buffer(self, name: str):
        """The (H, W, 4) float32 device array of one buffer: pos, prev (the current read halves), normal, pos_write,
        prev_write."""
        buffers = {
            "pos": self.pos.read,
            "prev": self.prev.read,
            "normal": self.normal,
            "pos_write": self.pos.write,
            "prev_write": self.prev.write,
        }
        return buffers[name]

    def read(self, name: str) -> np.ndarray:
        """A host copy of ``buffer(name)``."""
        return self.buffer(name).get()

    def set_positions(self, pos, prev=None) -> None:
        """Place particles by hand (tests, experiments): (H, W, 3) positions and previous positions (default pos);
        both halves of each pair get the values."""
        pos = np.asarray(pos, np.float32).reshape(self.height, self.width, 3)
        prev = pos if prev is None else np.asarray(prev, np.float32).reshape(pos.shape)
        for pair, values in ((self.pos, pos), (self.prev, prev)):
            data = np.concatenate([values, np.ones((*values.shape[:2], 1), np.float32)], axis=-1)
            pair.read.set(data)
            pair.write.set(data)

    def state(self) -> dict[str, np.ndarray]:
        return {
            "pos": np.ascontiguousarray(self.read("pos")[..., :3]),
            "normal": np.ascontiguousarray(self.read("normal")[..., :3]),
            "prev_last": np.ascontiguousarray(self.read("prev")[..., :3]),
            "sphere": self.sphere_params.copy(),
            "frame": np.int32(self.steps),
        }

    def stats(self) -> dict:
        pos, prev = self.read("pos")[..., :3], self.read("prev")[..., :3]
        structural = np.concatenate(
            [
                np.linalg.norm(np.diff(pos, axis=0), axis=-1).ravel(),
                np.linalg.norm(np.diff(pos, axis=1), axis=-1).ravel(),
            ]
        )
        speed = np.linalg.norm(pos - prev, axis=-1) / self.params.substep_dt
        return {
            **super().stats(),
            "particles": f"{self.width} x {self.height}",
            "CSSimulation kernel": self.simulation_kernel,
            "work-group": f"{self.block} x {self.block}"
            if self.simulation_kernel == "CSSimulation"
            else f"{CPU_LANES} particles per work-item",
            "substep dt": self.params.substep_dt,
            "sphere": tuple(round(float(v), 4) for v in self.sphere_params),
            "max speed": float(speed.max()),
            "bottom row mean y": float(pos[0, :, 1].mean()),
            "structural length min/max": (float(structural.min()), float(structural.max())),
            "dt*sqrt(12k/m)": self.params.stability,
            "diverged": DIVERGED if not np.isfinite(pos).all() else False,
        }

    def mesh(self) -> Mesh:
        """The cloth surface: W*H vertices y * W + x, 2 triangles per cell, the simulated normals and
        uv = (x, y) / (res - 1), where the book's shader samples the buffers. Open, so not watertight."""
        state = self.state()
        y, x = np.mgrid[0 : self.height, 0 : self.width]
        uvs = np.stack([x / (self.width - 1), y / (self.height - 1)], axis=-1)
        # The ring normal starts at (0, 0, -1) (CSInit) and grid_triangles wind towards +z: reverse them so the
        # triangles face the way the simulated normals point (drawn with Cull Off, the view needs no such care).
        return Mesh(state["pos"], grid_triangles(self.width, self.height)[:, ::-1], state["normal"], uvs)

    def export_mesh(self, path) -> None:
        """--mesh: ``mesh()`` as .obj, .ply or .glb."""
        write_mesh(path, self.mesh())

    # }}}


WRITE_NORMAL = {False: np.int32(0), True: np.int32(1)}
"""CSSimulation's write_normal argument (the same objects every launch: the launch path sets a changed one only)."""

SCENES = [
    Scene(
        "cloth",
        Simulation,
        "GPU cloth: a mass-spring sheet draped over a moving sphere (vol.4 ch.3)",
        defaults=MAIN_SCENE,
        preview={"steps": 1000},
        animation=Animation("the sphere pushes into the hanging cloth, which drapes over it", every=12, start=560),
        # a million particles at the book's spacing: a 51 m sheet (the book's 3.2 m sheet at 3 mm spacing diverges:
        # explicit springs would need a far smaller step), stable at the book's stiffness, mass and step
        at_scale=AtScale(gpu={"res": (1024, 1024)}, cpu={"res": (128, 128)}),
    ),
    Scene(
        "cloth_debug",
        Simulation,
        "GPU cloth, debug render: mass points and the three spring families as lines (vol.4 ch.3)",
        defaults=DEBUG_SCENE,
        view="DebugView",
        preview={"steps": 1000},
    ),
]
