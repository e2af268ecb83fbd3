"""Memory a parameter set asks for, compared with what the device and the host can give, before anything is allocated.

A Simulation lists its large buffers and images, and its large host arrays at their peak, with
``allocations(params)``; each names the parameter that sizes it. Device buffers are checked against the device
(one buffer, all of them, image sizes); host arrays, and on a CPU device the device buffers too (they live in the
same memory), against the host memory available now. ``check(simulation, params, device)`` raises
``ResourceError`` with one line naming that parameter, its value and the largest value this device takes (found by
bisection over the parameter's range, the other parameters kept), rather than letting ``clCreateBuffer`` fail
half-way through a reset.
"""

from __future__ import annotations

import dataclasses
import os
from dataclasses import dataclass
from pathlib import Path

import pyopencl as cl


class ResourceError(ValueError):
    """The parameters ask for more memory, or a larger image, than the device has."""


@dataclass(frozen=True)
class Allocation:
    what: str
    """What the buffer holds, for the message (``triangle buffer``)."""
    nbytes: int
    param: str
    """The parameter that sizes it (an int field of the scene's Params)."""
    image: tuple[int, ...] | None = None
    """Width, height (and depth) when it is an image: checked against the device's image limits too."""
    count: int = 1
    """How many buffers of ``nbytes`` each (six textures per drawable)."""
    host: bool = False
    """Host memory (numpy arrays, temporaries at their peak) rather than a device buffer."""

    @property
    def total(self) -> int:
        return self.nbytes * self.count


def host_memory_available() -> int:
    """Bytes of host memory a run can take now: MemAvailable (free memory plus caches the kernel can drop), or less
    where this process's control group (a container, a systemd slice, a batch job) allows less."""
    try:
        with open("/proc/meminfo") as f:
            machine = next(int(line.split()[1]) * 1024 for line in f if line.startswith("MemAvailable:"))
    except (OSError, StopIteration):
        machine = os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    group = cgroup_memory_left()
    return machine if group is None else min(machine, group)


CGROUP_FILES = {"": ("memory.max", "memory.current"), "memory": ("memory.limit_in_bytes", "memory.usage_in_bytes")}
"""The limit and the usage of a memory control group: cgroup v2 (the unified hierarchy, controllers "") and v1."""


def cgroup_memory_left(root: Path = Path("/sys/fs/cgroup"), membership: Path = Path("/proc/self/cgroup")) -> int | None:
    """The least headroom (limit less usage) of this process's memory control group and the groups above it, in
    bytes; None where no group sets a limit (or the files cannot be read). A kill by the OOM killer comes from the
    group's limit, not from the machine's free memory."""
    try:
        lines = membership.read_text().splitlines()
    except OSError:
        return None
    left = None
    for line in lines:
        _, controllers, path = line.split(":", 2)
        if controllers not in CGROUP_FILES and "memory" not in controllers.split(","):
            continue
        limit_name, usage_name = CGROUP_FILES["" if controllers == "" else "memory"]
        base = root if controllers == "" else root / "memory"
        folder = base / path.lstrip("/")
        while True:  # this group, then each group above it up to the mount's root
            try:
                limit = (folder / limit_name).read_text().strip()
                usage = int((folder / usage_name).read_text())
                if limit != "max" and int(limit) < 1 << 60:  # v1 writes "no limit" as about 2^63
                    left = int(limit) - usage if left is None else min(left, int(limit) - usage)
            except (OSError, ValueError):
                pass
            if folder == base or base not in folder.parents:
                break
            folder = folder.parent
    return None if left is None else max(left, 0)


def gib(nbytes: int) -> str:
    return f"{nbytes / 2**30:.2f} GiB" if nbytes >= 2**30 else f"{nbytes / 2**20:.1f} MiB"


def problem(allocations: list[Allocation], device: cl.Device) -> tuple[Allocation | None, str]:
    """The first allocation the device or the host cannot hold and what it needs beyond the limit ((None, '') when
    all fit)."""
    on_device = [a for a in allocations if not a.host]
    for a in on_device:
        if a.nbytes > device.max_mem_alloc_size:
            return a, f"a {gib(a.nbytes)} {a.what}, over the {gib(device.max_mem_alloc_size)} one buffer may hold"
        if a.image is not None:
            limits = (
                (device.image2d_max_width, device.image2d_max_height)
                if len(a.image) == 2
                else (device.image3d_max_width, device.image3d_max_height, device.image3d_max_depth)
            )
            if any(s > m for s, m in zip(a.image, limits, strict=True)):
                size, most = "x".join(map(str, a.image)), "x".join(map(str, limits))
                return a, f"a {size} {a.what}, over the {most} an image may have"
    total = sum(a.total for a in on_device)
    if on_device and total > device.global_mem_size:
        biggest = max(on_device, key=lambda a: a.total)
        return biggest, f"{gib(total)} of buffers, over the {gib(device.global_mem_size)} of device memory"
    in_host = [a for a in allocations if a.host or device.type & cl.device_type.CPU]
    need, available = sum(a.total for a in in_host), host_memory_available()
    if in_host and need > available:
        biggest = max(in_host, key=lambda a: a.total)
        return biggest, f"{gib(need)} of host memory, over the {gib(available)} available now"
    return None, ""


def check(simulation, params, device: cl.Device) -> None:
    """ResourceError naming the parameter and the largest value of it that fits, if ``params`` do not fit."""
    bad, need = problem(simulation.allocations(params), device)
    if bad is None:
        return
    value = getattr(params, bad.param)
    field = next(f for f in dataclasses.fields(params) if f.name == bad.param)
    lo = field.metadata.get("lo") or 0
    sides = isinstance(value, tuple)  # a size of several sides (width, height): every side capped at v

    def sized(v: int):
        return tuple(min(side, v) for side in value) if sides else v

    def fits(v: int) -> bool:
        try:
            candidate = params.replace(**{bad.param: sized(v)})
        except ValueError:  # a cross-field limit of Params: not a value the user could take either
            return False
        return problem(simulation.allocations(candidate), device)[0] is None

    best = None
    low, high = lo, (max(value) if sides else value) - 1  # bisection: sizes grow with the parameter
    while low <= high:
        mid = (low + high) // 2
        if fits(mid):
            best, low = mid, mid + 1
        else:
            high = mid - 1
    shown = lambda v: ",".join(map(str, v)) if sides else str(v)  # noqa: E731 - as --set takes it
    largest = (
        f"the largest {bad.param} it takes is {shown(sized(best))}" if best is not None else f"no {bad.param} fits"
    )
    raise ResourceError(f"{bad.param}={shown(value)} needs {need} on {device.name.strip()}; {largest}")
