"""The device's own limits that ``ugpcl bench`` throughputs are a share of, and the benches of the device itself
(``ugpcl bench copy``, ``peak``, ``launch``).

A bench row may carry columns named ``... bytes/s`` (the least memory traffic its work needs, per second) or
``... flop/s`` (its stated flop count, per second); ``ugpcl bench`` then adds ``% copy bw`` (of the device-to-device
copy bandwidth that ``ugpcl bench copy`` measures) or ``% FP32 peak`` (of the FMA rate ``ugpcl bench peak``
measures) after each.
"""

from __future__ import annotations

import time
from dataclasses import dataclass


def bench_launch(runtime, sizes=None) -> list[dict]:
    """Host cost of one kernel launch (LaunchProbe: 3 buffers, 4 scalars, 256 work-items), each way of launching
    beside the bare PyOpenCL floor that does the same work: a launch whose arguments are all the objects of the
    last one against a bare ``enqueue_nd_range_kernel`` (nothing set), a launch with two new numpy scalars against
    the bare enqueue after setting those two from their bytes; PyOpenCL's plain call ``kernel(queue, gsize, lsize,
    *args)`` (every argument set every time) for scale. ugpcl's launch path is ``runtime.Kernel``: the declaration
    checked, unchanged objects not set again, scalars of the declared type set from their bytes.

    host us/launch: time to enqueue with the device held back (the batch waits on a user event, so the runtime's
    own threads do not share the host's cores while it is timed); us/launch: enqueued with the device running and
    finished at the end of the batch; x floor: host time against the bare way doing the same work; x bare enqueue:
    against the bare enqueue that sets nothing. Best of seven batches of 2,000, the ways taken in turn."""
    import numpy as np
    import pyopencl as cl

    n, batch = 256, 2000
    queue = runtime.queue
    a, b, out = (runtime.zeros(n, np.float32) for _ in range(3))
    wrapper = runtime.program("probes").kernel("LaunchProbe")
    plain = cl.Kernel(wrapper.cl.program, "LaunchProbe")  # a second cl.Kernel: its arguments are its own
    fixed = (a.data, b.data, out.data, np.int32(n), np.float32(2.0))
    kept = (*fixed, np.float32(0.0), np.int32(0))
    set_bytes = getattr(plain, "_set_arg_buf", plain.set_arg)

    def plain_call(i):
        plain(queue, (n,), None, *fixed, np.float32(i), np.int32(0))

    def bare_enqueue(i):
        cl.enqueue_nd_range_kernel(queue, plain, (n,), None)

    def launch_same(i):
        wrapper((n,), None, *kept)

    def bare_set_enqueue(i):
        set_bytes(5, np.float32(i))
        set_bytes(6, np.int32(0))
        cl.enqueue_nd_range_kernel(queue, plain, (n,), None)

    def launch_new(i):
        wrapper((n,), None, *fixed, np.float32(i), np.int32(0))

    ways = (  # name, launch, the bare way doing the same work
        ("bare enqueue", bare_enqueue, "bare enqueue"),
        ("launch path, same arguments", launch_same, "bare enqueue"),
        ("bare + set 2 new scalars", bare_set_enqueue, "bare + set 2 new scalars"),
        ("launch path, 2 new scalars", launch_new, "bare + set 2 new scalars"),
        ("plain call, 2 new scalars", plain_call, "bare + set 2 new scalars"),
    )

    def timed(launch, held: bool) -> tuple[float, float]:
        plain.set_args(*kept)
        queue.finish()
        gate = cl.UserEvent(runtime.context) if held else None
        if gate is not None:
            cl.enqueue_marker(queue, wait_for=[gate])
        start = time.perf_counter()
        for i in range(batch):
            launch(i)
        enqueued = time.perf_counter()
        if gate is not None:
            gate.set_status(cl.command_execution_status.COMPLETE)
        queue.finish()
        return enqueued - start, time.perf_counter() - start

    host = {name: [] for name, _, _ in ways}
    total = {name: [] for name, _, _ in ways}
    for _ in range(7):
        for name, launch, _ in ways:
            host[name].append(timed(launch, held=True)[0] / batch)
            total[name].append(timed(launch, held=False)[1] / batch)
    best = {name: min(host[name]) * 1e6 for name in host}
    return [
        {
            "launch": name,
            "host us/launch": best[name],
            "us/launch": min(total[name]) * 1e6,
            "x floor": best[name] / best[floor],
            "x bare enqueue": best[name] / best["bare enqueue"],
        }
        for name, _, floor in ways
    ]


# {{{ the device's limits


@dataclass(frozen=True)
class DeviceLimits:
    copy_bytes_per_s: float
    """Device-to-device copy of a large buffer, bytes read plus bytes written per second."""
    fp32_flops: float
    """Independent FP32 fused multiply-adds (FmaProbe), flops per second (an FMA is 2)."""
    host_bytes_per_s: float
    """Device-to-host copies into page-locked memory (``Runtime.read_back``), bytes per second: the link a view's
    upload crosses."""


_limits: dict[int, DeviceLimits] = {}


def device_limits(runtime) -> DeviceLimits:
    """The device's measured limits (measured once per device and process: about a second)."""
    key = runtime.device.int_ptr
    if key not in _limits:
        size = _copy_size(runtime)
        _limits[key] = DeviceLimits(copy_rate(runtime, size), fp32_rate(runtime), read_back_rate(runtime, size // 4))
    return _limits[key]


def _copy_size(runtime) -> int:
    """256 MiB, or less where the device holds less (an eighth of its memory, half its largest buffer)."""
    d = runtime.device
    return int(min(256 * 2**20, d.global_mem_size // 8, d.max_mem_alloc_size // 2)) // 16 * 16


def copy_rate(runtime, nbytes: int) -> float:
    """Bytes moved per second (read + write) by ``enqueue_copy`` of one buffer into another: the best of five."""
    import pyopencl as cl

    src = cl.Buffer(runtime.context, cl.mem_flags.READ_WRITE, nbytes)
    dst = cl.Buffer(runtime.context, cl.mem_flags.READ_WRITE, nbytes)
    queue = runtime.queue
    cl.enqueue_fill_buffer(queue, src, b"\x01", 0, nbytes)
    cl.enqueue_copy(queue, dst, src)  # warm-up: first touch of the pages
    queue.finish()
    copies = 4 if runtime.is_gpu else 1
    best = float("inf")
    for _ in range(5):
        start = time.perf_counter()
        for _ in range(copies):
            cl.enqueue_copy(queue, dst, src)
        queue.finish()
        best = min(best, (time.perf_counter() - start) / copies)
    src.release()
    dst.release()
    return 2 * nbytes / best


def read_back_rate(runtime, nbytes: int) -> float:
    """Bytes per second of ``Runtime.read_back`` (device to page-locked host memory) of one buffer: the best of
    five, after a first read that pins the host copy."""
    import numpy as np

    array = runtime.zeros(nbytes // 4, np.float32)
    runtime.read_back(array)
    best = float("inf")
    for _ in range(5):
        start = time.perf_counter()
        runtime.read_back(array)
        best = min(best, time.perf_counter() - start)
    return array.nbytes / best


def fp32_rate(runtime) -> float:
    """Flops per second of FmaProbe over enough work-items to fill the device: the best of five launches."""
    import numpy as np

    d = runtime.device
    n = d.max_compute_units * (2048 if runtime.is_gpu else 64)
    rounds = 256 if runtime.is_gpu else 32
    out = runtime.zeros(n, np.float32)
    probe = runtime.program("probes").kernel("FmaProbe")
    args = (out.data, np.int32(rounds), np.float32(0.999), np.float32(1e-3))
    probe((n,), None, *args)
    runtime.finish()
    best = float("inf")
    for _ in range(5):
        start = time.perf_counter()
        probe((n,), None, *args)
        runtime.finish()
        best = min(best, time.perf_counter() - start)
    return n * rounds * 16 * 64 / best


def bench_copy(runtime, sizes=None) -> list[dict]:
    """Device-to-device copy bandwidth (``enqueue_copy`` of one buffer into another; bytes read plus written, the
    best of five), per buffer size in MiB (--size); the largest is the limit memory-bound rows are a share of."""
    sizes = sizes or [16, 64, _copy_size(runtime) // 2**20]
    rows = []
    for mib in sizes:
        rate = copy_rate(runtime, mib * 2**20)
        rows.append({"buffer MiB": mib, "GB/s": rate / 1e9})
    return rows


def bench_peak(runtime, sizes=None) -> list[dict]:
    """FP32 peak as measured: FmaProbe, 8 independent float4 FMA chains per work-item and nothing else, the best of
    five launches; compute-bound rows are a share of it. sizes: ignored."""
    return [{"probe": "FmaProbe", "TFLOP/s": fp32_rate(runtime) / 1e12}]


def with_shares(rows: list[dict], limits: DeviceLimits) -> list[dict]:
    """``rows`` with ``% copy bw`` after each ``... bytes/s`` column, ``% host link`` after each ``... host bytes/s``
    (device to host, ``Runtime.read_back``) and ``% FP32 peak`` after each ``... flop/s``; a row with two such
    columns of one kind names each share after its column (``field % copy bw``)."""
    shares = (
        ("host bytes/s", "% host link", limits.host_bytes_per_s),
        ("bytes/s", "% copy bw", limits.copy_bytes_per_s),
        ("flop/s", "% FP32 peak", limits.fp32_flops),
    )

    def kind(key: str):
        return next((s for s in shares if key.endswith(s[0])), None)

    out = []
    for row in rows:
        shared = {}
        for key, value in row.items():
            shared[key] = value
            found = kind(key)
            if found and isinstance(value, float):
                unit, share, limit = found
                several = sum(kind(k) is found for k in row) > 1
                shared[f"{key[: -len(unit)].strip()} {share}" if several else share] = 100.0 * value / limit
        out.append(shared)
    return out


# }}}
