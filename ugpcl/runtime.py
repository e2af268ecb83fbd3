"""OpenCL runtime: choose a device, build programs from ``clkernels/``, hand out kernels fetched once.

Device choice (first that applies):
  1. ``UGPCL_DEVICE`` (or the ``device`` argument): a case-insensitive substring of "platform | device",
     e.g. ``pocl``, ``nvidia``, ``oclgrind``;
  2. ``PYOPENCL_CTX``: PyOpenCL's own selector;
  3. the first GPU, then the first CPU (the Oclgrind simulator is only used when named).
Every chosen device must build and run a probe kernel before it is trusted: PyPI's PoCL wheel, for one,
lists a CPU it cannot compile for (DESIGN.md, "PoCL").
"""

from __future__ import annotations

import hashlib
import math
import os
from importlib import resources
from pathlib import Path
from typing import ClassVar

import numpy as np
import pyopencl as cl
import pyopencl.array as cla


def _kernel_dir() -> Path:
    if os.environ.get("UGPCL_KERNELS"):
        return Path(os.environ["UGPCL_KERNELS"])
    try:
        return Path(str(resources.files("ugpcl.clkernels")))
    except ModuleNotFoundError:  # a checkout on PYTHONPATH, not installed: the folder beside ugpcl/
        return Path(__file__).resolve().parents[1] / "clkernels"


KERNEL_DIR = _kernel_dir()
"""The ``.cl`` files: the package data of ``ugpcl.clkernels`` (the top-level ``clkernels/`` folder of a checkout,
installed or editable alike); ``UGPCL_KERNELS`` points elsewhere, e.g. at a folder of edited copies."""
INCLUDE_DIR = KERNEL_DIR / "include"

INSTALL_HINT = (
    "install an OpenCL driver: Debian/Ubuntu `apt-get install pocl-opencl-icd` (CPU), "
    "or your GPU vendor's OpenCL runtime; `make` does the former where it can"
)

_PROBE_SOURCE = "__kernel void ugpcl_probe(__global int* out) { out[get_global_id(0)] = 2 * (int)get_global_id(0); }"


class DeviceError(RuntimeError):
    """No usable OpenCL device: the message is one line saying what to do."""


class BuildError(RuntimeError):
    """A ``clkernels/*.cl`` file failed to build; the message holds the file name and the build log."""


def round_up(n: int, multiple: int) -> int:
    """Smallest multiple of ``multiple`` that is >= n (OpenCL 1.2 global sizes must be multiples of the local size)."""
    return (n + multiple - 1) // multiple * multiple


def fitted_shape(wanted: tuple[int, ...], device: cl.Device) -> tuple[int, ...]:
    """``wanted`` (a 2-D or 3-D work-group shape) halved until ``device`` runs it: an axis over the device's per-axis
    limit first, else the largest axis (the first of equals)."""
    limits = device.max_work_item_sizes[: len(wanted)]
    size = list(wanted)
    while math.prod(size) > device.max_work_group_size or any(s > m for s, m in zip(size, limits, strict=True)):
        over = [a for a in range(len(size)) if size[a] > limits[a]]
        axis = over[0] if over else size.index(max(size))
        size[axis] = max(1, size[axis] // 2)
    return tuple(size)


def _is_simulator(platform: cl.Platform) -> bool:
    return "oclgrind" in platform.name.lower()


def _label(device: cl.Device) -> str:
    return f"{device.platform.name} | {device.name}"


def _search_text(device: cl.Device) -> str:
    """What UGPCL_DEVICE is matched against: names, vendors and versions ('pocl' is only in the version)."""
    p = device.platform
    return f"{p.name} {p.vendor} {p.version} | {device.name} {device.vendor}".lower()


def all_devices() -> list[cl.Device]:
    """Every device of every platform. Enumerating loads the drivers: do it before creating a GL context, since
    Debian's PoCL aborts ("Option ... registered more than once") when Mesa's llvmpipe loaded LLVM first."""
    try:
        platforms = cl.get_platforms()
    except cl.Error:  # the ICD loader found no platform at all
        return []
    devices = []
    for platform in platforms:
        try:
            devices += platform.get_devices()
        except cl.Error:  # a platform that lists no device
            continue
    return devices


def choose_device(wanted: str | None = None) -> tuple[cl.Device, str]:
    """Return (device, why it was chosen); raise DeviceError with a one-line message otherwise."""
    devices = all_devices()
    if not devices:
        raise DeviceError(f"no OpenCL platform found: {INSTALL_HINT}")
    wanted = wanted if wanted is not None else os.environ.get("UGPCL_DEVICE") or None
    if wanted:
        for device in devices:
            if wanted.lower() in _search_text(device):
                return device, f"UGPCL_DEVICE={wanted!r}"
        names = "; ".join(_label(d) for d in devices)
        raise DeviceError(f"UGPCL_DEVICE={wanted!r} matches no OpenCL device (have: {names})")
    if os.environ.get("PYOPENCL_CTX"):
        try:
            ctx = cl.create_some_context(interactive=False)
        except (cl.Error, RuntimeError, ValueError) as err:  # PyOpenCL says only "input did not match any platform"
            names = "; ".join(_label(d) for d in devices)
            raise DeviceError(
                f"PYOPENCL_CTX={os.environ['PYOPENCL_CTX']!r} does not select a device ({err}); have: {names}"
            ) from None
        return ctx.devices[0], f"PYOPENCL_CTX={os.environ['PYOPENCL_CTX']!r}"
    real = [d for d in devices if not _is_simulator(d.platform)]
    for kind, why in ((cl.device_type.GPU, "first GPU"), (cl.device_type.CPU, "first CPU")):
        for device in real:
            if device.type & kind:
                return device, why
    if real:
        return real[0], "first device"
    raise DeviceError(f"only the Oclgrind simulator was found (set UGPCL_DEVICE=oclgrind to use it): {INSTALL_HINT}")


# {{{ the one launch path


class Kernel:
    """One kernel of a built program, launched on the runtime's queue: ``kernel(global_size, local_size, *args)``.

    Every chapter launches through this. PyOpenCL's ``cl_kernel(queue, gsize, lsize, *args)`` sets every argument
    through its generic path on every call (about 54 us of host time per launch on an H100, 50 us on PoCL, against
    9 us and 3 us for a bare ``enqueue_nd_range_kernel``; ``ugpcl bench launch`` measures all three). Here a buffer
    argument is set only when a different buffer is passed (after a ping-pong swap, a reset), numpy scalars are set
    from their bytes (0.4 us each: cheaper than comparing them with the last value), and the kernel is enqueued
    with ``enqueue_nd_range_kernel``. Arguments are numpy scalars (``np.int32``, ``np.float32``, ``cltypes``
    vectors), ``cl.Buffer``, ``pyopencl.array.Array`` (its buffer is passed), ``cl.LocalMemory`` or None.
    """

    def __init__(self, runtime: Runtime, kernel: cl.Kernel, name: str):
        self.runtime, self.cl, self.name = runtime, kernel, name
        self.num_args = kernel.num_args
        self._buffers: list = [_UNSET] * self.num_args  # the buffer (or None) each argument was last set to
        # A numpy scalar through the public set_arg costs ~9 us (PyOpenCL's generic argument path); its bytes
        # through _set_arg_buf, which PyOpenCL's own generated invokers use, ~0.4 us.
        self._set_bytes = getattr(kernel, "_set_arg_buf", kernel.set_arg)

    def __call__(self, global_size, local_size, *args) -> cl.Event:
        if len(args) != self.num_args:
            raise TypeError(f"{self.name} takes {self.num_args} arguments, got {len(args)}")
        buffers = self._buffers
        for i, arg in enumerate(args):
            if isinstance(arg, np.generic):
                self._set_bytes(i, arg)
                continue
            if isinstance(arg, cla.Array):
                arg = arg.base_data if arg.offset == 0 else arg.data
            elif isinstance(arg, int | float):  # a Python number has no OpenCL width: say which argument
                raise TypeError(f"{self.name} argument {i}: pass a numpy scalar (np.int32, np.float32), got {arg!r}")
            if arg is not buffers[i] or isinstance(arg, cl.LocalMemory):
                self.cl.set_arg(i, arg)
                buffers[i] = arg
        if isinstance(global_size, int):
            global_size = (global_size,)
        if isinstance(local_size, int):
            local_size = (local_size,)
        return cl.enqueue_nd_range_kernel(self.runtime.queue, self.cl, global_size, local_size)

    def over(self, n: int, group_size: int, *args) -> cl.Event | None:
        """``n`` work-items in 1-D groups of ``group_size``, the global size padded to whole groups (the kernel
        guards ``i >= n``); nothing is enqueued when n <= 0, as the book skips a Dispatch of zero groups."""
        if n <= 0:
            return None
        return self(round_up(n, group_size), group_size, *args)

    def work_group_size(self) -> int:
        """The largest work-group this kernel runs with on the device (registers and local memory allowing)."""
        return int(self.cl.get_work_group_info(cl.kernel_work_group_info.WORK_GROUP_SIZE, self.runtime.device))


_UNSET = object()
"""A kept argument that was never set: equal to nothing."""


# }}}


class Program:
    """One built ``.cl`` file. ``kernel(name)`` returns the same ``Kernel`` (launch wrapper) every time."""

    def __init__(self, runtime: Runtime, program: cl.Program, path: Path, options: list[str]):
        self.runtime, self.program, self.path, self.options = runtime, program, path, options
        self._kernels: dict[str, Kernel] = {}

    def kernel(self, name: str) -> Kernel:
        if name not in self._kernels:
            self._kernels[name] = Kernel(self.runtime, cl.Kernel(self.program, name), name)
        return self._kernels[name]

    def __getitem__(self, name: str) -> Kernel:
        return self.kernel(name)


def _format_define(value) -> str:
    if isinstance(value, bool):
        return "1" if value else "0"
    if isinstance(value, float):
        return f"{value!r}f"
    return str(value)


ZERO_FILL_PIECE = 1 << 30
"""Bytes per enqueue_fill_buffer in Runtime.zeros (below NVIDIA's 2 GiB fill limit)."""


class Runtime:
    """A context and an in-order queue on one device, plus the program cache."""

    _shared: ClassVar[dict] = {}

    @classmethod
    def shared(cls, device: str | None = None) -> Runtime:
        """The process's one ``Runtime`` for ``device`` (a substring of "platform | device", or None to choose as
        ``ugpcl run`` does), made on first use: every ``ugpcl.cli.main`` and ``ugpcl.create`` call of a process
        reuses its context, queue and built programs. A GPU context holds device memory until it is collected; a
        test session that made one per call ran NVIDIA's driver out of contexts."""
        key = (device, os.environ.get("UGPCL_DEVICE"), os.environ.get("PYOPENCL_CTX"))  # what choose_device reads
        if key not in cls._shared:
            cls._shared[key] = cls(device)
        return cls._shared[key]

    def __init__(self, device: str | None = None):
        self.device, self.reason = choose_device(device)
        self.context = cl.Context([self.device])
        self.queue = cl.CommandQueue(self.context)
        self._programs: dict[tuple, Program] = {}
        self._probe()

    # {{{ device facts

    @property
    def label(self) -> str:
        return _label(self.device).strip()

    @property
    def is_oclgrind(self) -> bool:
        return _is_simulator(self.device.platform)

    @property
    def is_gpu(self) -> bool:
        return bool(self.device.type & cl.device_type.GPU) and not self.is_oclgrind

    @property
    def image_support(self) -> bool:
        return bool(self.device.image_support)

    def _probe(self) -> None:
        try:
            prg = cl.Program(self.context, _PROBE_SOURCE).build()
            out = cla.zeros(self.queue, 4, np.int32)
            cl.Kernel(prg, "ugpcl_probe")(self.queue, (4,), None, out.data)
            ok = out.get().tolist() == [0, 2, 4, 6]
        except cl.Error as err:
            first = str(err).strip().splitlines()[0] if str(err).strip() else type(err).__name__
            raise DeviceError(f"{self.label}: cannot build a probe kernel ({first}); {INSTALL_HINT}") from None
        if not ok:
            raise DeviceError(f"{self.label}: the probe kernel ran but gave wrong results; {INSTALL_HINT}")

    # }}}

    # {{{ programs

    def program(self, stem: str, **defines) -> Program:
        """Build ``clkernels/<stem>.cl`` with ``-D NAME=value`` for each define (cached per stem and defines)."""
        key = (stem, tuple(sorted(defines.items())))
        if key not in self._programs:
            self._programs[key] = self._build(KERNEL_DIR / f"{stem}.cl", defines)
        return self._programs[key]

    def fitted_program(
        self, stem: str, kernels, wanted: int, define: str | None = None, dims: int = 1, **defines
    ) -> tuple[int, Program]:
        """(size, program): the largest halving of ``wanted`` whose work-group (size**dims work-items) every kernel
        named in ``kernels`` runs with on this device. ``define`` is the build define that carries the size (a
        kernel's reqd_work_group_size, the book's numthreads): each candidate is built with it."""
        size = wanted
        while True:
            program = self.program(stem, **defines, **({define: size} if define else {}))
            limit = min(program.kernel(name).work_group_size() for name in kernels)
            if size**dims <= limit or size == 1:
                return size, program
            size //= 2

    def _build(self, path: Path, defines: dict) -> Program:
        if not path.exists():
            raise BuildError(f"{path}: no such kernel file")
        # '#line' makes build logs and Oclgrind reports name the real file; the header digest makes a changed
        # header rebuild every program (the driver caches compare source text, not included files).
        headers = hashlib.sha1(b"".join(p.read_bytes() for p in sorted(INCLUDE_DIR.glob("*.h")))).hexdigest()[:12]
        source = f'// headers {headers}\n#line 1 "{path.name}"\n' + path.read_text()
        options = [f"-I{INCLUDE_DIR}"] + [f"-D{k}={_format_define(v)}" for k, v in sorted(defines.items())]
        try:
            program = cl.Program(self.context, source).build(options=options)
        except cl.RuntimeError as err:
            raise BuildError(f"{path.name}: build failed on {self.label} with {' '.join(options[1:])}\n{err}") from None
        return Program(self, program, path, options)

    # }}}

    # {{{ arrays (pyopencl.array: a device buffer that knows its shape and dtype)

    def to_device(self, array: np.ndarray) -> cla.Array:
        self._check_size(array.shape, array.dtype)
        return cla.to_device(self.queue, np.ascontiguousarray(array))

    def zeros(self, shape, dtype) -> cla.Array:
        """A zero-filled array: its first ZERO_FILL_PIECE bytes filled, then copied over the rest. pyopencl fills a
        larger array on NVIDIA with a kernel (its way round an NVIDIA fill bug) that cannot take struct dtypes such
        as marching cubes' triangles, and NVIDIA's own fill at offsets past 4 GiB broke the context on the H100
        (a 4.75 GiB triangle pool: every later call failed with -9999); device-to-device copies take any offset."""
        self._check_size(shape, dtype)
        array = cla.empty(self.queue, shape, dtype)
        buffer, first = array.base_data, min(ZERO_FILL_PIECE, array.nbytes)
        if first:
            cl.enqueue_fill_buffer(self.queue, buffer, np.int8(0), 0, first)
        for start in range(first, array.nbytes, first):
            size = min(first, array.nbytes - start)
            cl.enqueue_copy(self.queue, buffer, buffer, src_offset=0, dst_offset=start, byte_count=size)
        return array

    def empty(self, shape, dtype) -> cla.Array:
        self._check_size(shape, dtype)
        return cla.empty(self.queue, shape, dtype)

    def _check_size(self, shape, dtype) -> None:
        """A buffer larger than the device allows fails here with its size, not as INVALID_BUFFER_SIZE. Scenes
        name the parameter to blame before they allocate (``Simulation.allocations``); this is the backstop."""
        nbytes = int(np.prod(shape, dtype=np.int64)) * np.dtype(dtype).itemsize
        if nbytes > self.device.max_mem_alloc_size:
            limit = self.device.max_mem_alloc_size
            raise ValueError(f"a buffer of shape {shape} needs {nbytes} bytes; {self.label} allows {limit} per buffer")

    def finish(self) -> None:
        self.queue.finish()

    # }}}

    def describe(self) -> dict:
        d = self.device
        return {
            "device": self.label,
            "chosen because": self.reason,
            "type": cl.device_type.to_string(d.type),
            "OpenCL": d.version,
            "compute units": d.max_compute_units,
            "max work-group size": d.max_work_group_size,
            "max work-item sizes": tuple(d.max_work_item_sizes),
            "local memory": f"{d.local_mem_size // 1024} KiB",
            "global memory": f"{d.global_mem_size / 2**30:.1f} GiB",
            "constant buffer": f"{d.max_constant_buffer_size // 1024} KiB",
            "images": bool(d.image_support),
        }
