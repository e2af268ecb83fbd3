"""``ugpcl bench cloth``: ms per frame and us per CSSimulation substep of the main scene at each size (vol.4 ch.3;
docs/chapters/14-cloth.md)."""

from __future__ import annotations

from ..scenes.cloth import MAIN_SCENE, Params, Simulation
from .timing import seconds_per_call, seconds_per_step

SUBSTEP_BATCH = 20
"""CSSimulation launches the bench runs back to back before it finishes the queue, as a frame's substeps run."""


SUBSTEP_BYTES_PER_PARTICLE = 64
"""A substep's least memory traffic per particle: read pos and prev, write both (float4 each); the neighbours'
positions come from cache. The bench's ``% copy bw`` is this traffic's share of the device's copy bandwidth."""


def bench(runtime, sizes=None) -> list[dict]:
    """For W = H = each size (main scene: 4 substeps, sphere on): ms per frame (the queue finished after each frame)
    with particle-updates/s (particles x substeps per second) and frames/s; one substep (a CSSimulation launch and
    the ping-pong swap) in us, timed over 20 substeps back to back (5 frames' worth, each frame's last writing the
    normal) and one finish, and as the least traffic a substep needs (SUBSTEP_BYTES_PER_PARTICLE) per second.
    ``kernel`` names the substep's kernel (CSSimulation_cpu on CPU devices)."""
    sizes = sizes or ([64, 128, 256, 512, 1024] if runtime.is_gpu else [64, 128, 256])
    rows = []
    for n in sizes:
        sim = Simulation(runtime, Params(**{**MAIN_SCENE, "res": (n, n)}), seed=0)
        seconds = seconds_per_step(sim, max_steps=100)
        frames = SUBSTEP_BATCH // sim.params.substeps  # a frame's substeps, the normal written by the last
        substep = seconds_per_call(sim.cs_substeps, runtime.queue, max_calls=100 * frames, batch=frames)
        substep /= sim.params.substeps
        updates = n * n * sim.params.substeps
        rows.append(
            {
                "res": f"{n}x{n}",
                "particles": n * n,
                "substeps": sim.params.substeps,
                "kernel": sim.simulation_kernel,
                "ms/frame": seconds * 1e3,
                "us/substep": substep * 1e6,
                "particle-updates/s": updates / seconds,
                "frames/s": 1.0 / seconds,
                "substep bytes/s": SUBSTEP_BYTES_PER_PARTICLE * n * n / substep,
            }
        )
    return rows
