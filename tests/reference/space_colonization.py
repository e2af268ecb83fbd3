"""The book's GPU step of space colonization (SpaceColonization.compute: Search, Attract, Connect, Remove, Grow) in
numpy float64 on the same records, with the node pool as a LIFO list: the reference of test_space_colonization's
whole-run test (vol.4 ch.1; docs/chapters/12-space-colonization.md)."""

from __future__ import annotations

import numpy as np

from ugpcl.geometry.space_colonization import MIN_DIRECTION, REPEAT_TOLERANCE


def nrand(u, v) -> np.ndarray:
    """HLSL nrand(float2(u, v)) in float64 (the device's float32 sin differs: compare masses statistically)."""
    x = np.sin(np.asarray(u, float) * 12.9898 + np.asarray(v, float) * 78.233) * 43758.5453
    return x - np.floor(x)


class ColonizationRef:
    """SpaceColonization.compute step by step on numpy records; node slots come from a LIFO pool as on the GPU.

    Node indices follow the reference's own (sequential) append order, which differs from a GPU run's atomic
    order: compare nodes as sets of positions. Nearest-node ties keep the lowest index, as the kernels do.
    """

    def __init__(
        self,
        attractions,
        seeds,
        *,
        influence: float,
        growth: float,
        kill: float,
        growth_speed: float,
        mass_min: float = 1.0,
        mass_max: float = 1.0,
        capacity: int | None = None,
        repeat_guard: bool = False,
    ):
        self.attraction_position = np.asarray(attractions, float).copy()
        a = len(self.attraction_position)
        self.capacity = a if capacity is None else capacity
        m = self.capacity
        self.influence, self.growth, self.kill, self.growth_speed = influence, growth, kill, growth_speed
        self.mass_min, self.mass_max, self.repeat_guard = mass_min, mass_max, repeat_guard
        self.attraction_active = np.ones(a, bool)
        self.attraction_found = np.zeros(a, bool)
        self.attraction_nearest = np.full(a, -1)
        self.position = np.zeros((m, 3))
        self.t, self.offset, self.mass = np.zeros(m), np.zeros(m), np.zeros(m)
        self.from_ = np.full(m, -1)
        self.active = np.zeros(m, bool)
        self.last_candidate = np.zeros((m, 4))
        self.edges: list[tuple[int, int]] = []
        self.pool = list(range(m))  # Setup appends 0..m-1; Consume takes from the top
        for i, seed in enumerate(np.asarray(seeds, float)):  # Seed
            j = self.pool.pop()
            self.position[j], self.t[j], self.offset[j], self.from_[j], self.active[j] = seed, 1.0, 0.0, -1, True
            self.mass[j] = mass_min + (mass_max - mass_min) * nrand(i, 0)
        self.colonize()  # the host's Step(0) after Seed

    def colonize(self) -> int:
        """Search, Attract, Connect, Remove while the pool has slots; returns the number of new nodes."""
        if not self.pool:
            return 0
        self.search()
        candidates = self.attract()
        made = self.connect(candidates)
        self.remove()
        return made

    def step(self, dt: float) -> int:
        made = self.colonize()
        self.grow(dt)
        return made

    def search(self) -> None:
        live = np.flatnonzero(self.active)
        act = np.flatnonzero(self.attraction_active)
        self.attraction_found[act] = False
        if not len(live) or not len(act):
            return
        d = np.linalg.norm(self.attraction_position[act, None, :] - self.position[None, live, :], axis=2)
        best = d.argmin(axis=1)  # first minimum = lowest node index
        found = d[np.arange(len(act)), best] < self.influence
        self.attraction_found[act] = found
        self.attraction_nearest[act[found]] = live[best[found]]

    def attract(self) -> list[tuple[np.ndarray, int]]:
        pulled = np.flatnonzero(self.attraction_active & self.attraction_found)
        nearest = self.attraction_nearest[pulled]
        to = self.attraction_position[pulled] - self.position[nearest]
        length = np.linalg.norm(to, axis=1)
        ok = length >= MIN_DIRECTION
        count = np.bincount(nearest[ok], minlength=self.capacity)
        total = np.zeros((self.capacity, 3))
        np.add.at(total, nearest[ok], to[ok] / length[ok, None])
        candidates = []
        for i in np.flatnonzero(self.active & (self.t >= 1.0) & (count > 0)):
            c = self.position[i] + total[i] / count[i] * self.growth
            if self.repeat_guard:
                last, tolerance = self.last_candidate[i], REPEAT_TOLERANCE * self.growth
                on_last = last[3] != 0 and np.linalg.norm(c - last[:3]) < tolerance
                if on_last or np.linalg.norm(c - self.position[i]) < tolerance:
                    continue
                self.last_candidate[i] = (*c, 1.0)
            candidates.append((c, int(i)))
        return candidates

    def connect(self, candidates: list) -> int:
        count = min(len(self.pool), len(candidates))
        for _ in range(count):  # the last appended candidates are consumed first
            c, parent = candidates.pop()
            j = self.pool.pop()
            self.position[j], self.t[j], self.from_[j], self.active[j] = c, 0.0, parent, True
            self.offset[j] = self.offset[parent] + 1.0
            self.mass[j] = self.mass_min + (self.mass_max - self.mass_min) * nrand(parent, j)
            self.edges.append((parent, j))
        return count

    def remove(self) -> None:
        live = np.flatnonzero(self.active)
        act = np.flatnonzero(self.attraction_active)
        if not len(live) or not len(act):
            return
        d = np.linalg.norm(self.attraction_position[act, None, :] - self.position[None, live, :], axis=2)
        self.attraction_active[act[(d < self.kill).any(axis=1)]] = False

    def grow(self, dt: float) -> None:
        live = self.active
        self.t[live] = np.clip(self.t[live] + dt * self.growth_speed * self.mass[live], 0.0, 1.0)
