"""OpenCL runtime: choose a device, build programs from ``clkernels/``, hand out kernels fetched once.

Device choice (first that applies):
  1. ``UGPCL_DEVICE`` (or the ``device`` argument): a case-insensitive substring of "platform | device",
     e.g. ``pocl``, ``nvidia``, ``oclgrind``;
  2. ``PYOPENCL_CTX``: PyOpenCL's own selector;
  3. the first GPU, then the first CPU (the Oclgrind simulator is only used when named).
Every chosen device must build and run a probe kernel before it is trusted: PyPI's PoCL wheel, for one,
lists a CPU it cannot compile for (docs/architecture.md, "Devices").
"""

from __future__ import annotations

import math
import os
import re
import sys
import warnings
import weakref
from contextlib import contextmanager
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import ClassVar

import numpy as np
import pyopencl as cl
import pyopencl.array as cla
import pyopencl.cltypes as cltypes


def _kernel_dir() -> Path:
    try:
        return Path(str(resources.files("ugpcl.clkernels")))
    except ModuleNotFoundError:  # a checkout on PYTHONPATH, not installed: the folder beside ugpcl/
        return Path(__file__).resolve().parents[1] / "clkernels"


KERNEL_DIR = _kernel_dir()
"""The package's ``.cl`` files: the package data of ``ugpcl.clkernels`` (the top-level ``clkernels/`` folder of a
checkout, installed or editable alike)."""
INCLUDE_DIR = KERNEL_DIR / "include"
"""The shared headers (``pool.h``, ``grid.h``, ``random.h`` ...): ``inline_headers`` puts them into each program."""


INSTALL_HINT = (
    "install an OpenCL driver: Debian/Ubuntu `apt-get install pocl-opencl-icd` (CPU), "
    "or your GPU vendor's OpenCL runtime; `make` does the former where it can"
)

_PROBE_SOURCE = "__kernel void ugpcl_probe(__global int* out) { out[get_global_id(0)] = 2 * (int)get_global_id(0); }"


class DeviceError(RuntimeError):
    """No usable OpenCL device: the message is one line saying what to do."""


class BuildError(RuntimeError):
    """A ``clkernels/*.cl`` file failed to build; the message holds the file name and the build log."""


def kernel_dirs() -> list[Path]:
    """Where ``Runtime.program(stem)`` looks for ``<stem>.cl``, in order: the folders ``UGPCL_KERNELS`` names
    (os.pathsep-separated: a chapter of your own, edited copies of ours), then ``KERNEL_DIR``. Read at each build,
    so a test may set it; the include folder stays the package's."""
    extra = [Path(p) for p in os.environ.get("UGPCL_KERNELS", "").split(os.pathsep) if p]
    return [*extra, KERNEL_DIR]


def kernel_file(stem: str) -> Path:
    """The first ``<stem>.cl`` of ``kernel_dirs()``; BuildError naming every folder searched when none has it."""
    folders = kernel_dirs()
    for folder in folders:
        if (folder / f"{stem}.cl").is_file():
            return folder / f"{stem}.cl"
    raise BuildError(f"{stem}.cl: no such kernel file in {', '.join(str(f) for f in folders)}")


def round_up(n: int, multiple: int) -> int:
    """Smallest multiple of ``multiple`` that is >= n (OpenCL 1.2 global sizes must be multiples of the local size)."""
    return (n + multiple - 1) // multiple * multiple


def fitted_shape(wanted: tuple[int, ...], device: cl.Device, limit: int | None = None) -> tuple[int, ...]:
    """``wanted`` (a 1-D to 3-D work-group shape) halved until ``device`` runs it (and it holds at most ``limit``
    work-items, a kernel's own limit): an axis over the device's per-axis limit first, else the largest axis (the
    first of equals)."""
    limits = device.max_work_item_sizes[: len(wanted)]
    most = min(device.max_work_group_size, limit or device.max_work_group_size)
    size = list(wanted)
    while math.prod(size) > most or any(s > m for s, m in zip(size, limits, strict=True)):
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


class LaunchError(TypeError):
    """A kernel launched with arguments that do not fit its declaration: one line naming kernel and argument."""


_SCALARS = {
    "char": np.int8, "uchar": np.uint8, "short": np.int16, "ushort": np.uint16, "int": np.int32,
    "uint": np.uint32, "long": np.int64, "ulong": np.uint64, "half": np.float16, "float": np.float32,
    "double": np.float64,
}  # fmt: skip
"""OpenCL C scalar type names and their numpy types (the widths OpenCL fixes for every device)."""


@dataclass(frozen=True)
class KernelArg:
    """One argument as the kernel declares it (read through ``-cl-kernel-arg-info``): ``kind`` is ``scalar``
    (``dtype`` a numpy scalar or ``cltypes`` vector type), ``buffer`` (a __global or __constant pointer), ``local``
    (a __local pointer: cl.LocalMemory), ``image``, ``sampler`` or ``bytes`` (a struct passed by value: a numpy
    scalar of its layout)."""

    name: str
    declared: str
    kind: str
    dtype: np.dtype | None = None

    def describe(self) -> str:
        return f"{self.name} ({self.declared})"


def _read_arg(kernel: cl.Kernel, i: int) -> KernelArg:
    info = cl.kernel_arg_info
    name = kernel.get_arg_info(i, info.NAME)
    type_name = kernel.get_arg_info(i, info.TYPE_NAME).strip()
    space = kernel.get_arg_info(i, info.ADDRESS_QUALIFIER)
    qualifier = cl.kernel_arg_address_qualifier
    base = type_name.rstrip("*").strip()
    if type_name.endswith("*"):
        if space == qualifier.LOCAL:
            return KernelArg(name, f"__local {type_name}", "local")
        space_name = "__constant" if space == qualifier.CONSTANT else "__global"
        return KernelArg(name, f"{space_name} {type_name}", "buffer")
    if base.startswith("image"):
        return KernelArg(name, type_name, "image")
    if base == "sampler_t":
        return KernelArg(name, type_name, "sampler")
    if base in _SCALARS:
        return KernelArg(name, type_name, "scalar", np.dtype(_SCALARS[base]))
    vector = re.fullmatch(r"([a-z]+)(2|3|4|8|16)", base)
    if vector and vector[1] in _SCALARS:
        return KernelArg(name, type_name, "scalar", np.dtype(getattr(cltypes, base)))
    return KernelArg(name, type_name, "bytes")


def _what(value) -> str:
    """How a refused argument is named in a message: its type, and its value where that is short."""
    if isinstance(value, np.generic | int | float | bool):
        return f"{type(value).__name__} {value!r}"
    if isinstance(value, cla.Array):
        return f"an array of {value.dtype} {value.shape}"
    return f"a {type(value).__name__}"


def _number(value, dtype: np.dtype, refuse):
    """``value`` (a Python or numpy number) as ``dtype`` where no information is lost: an integer of the type's
    range, an integer a float type holds exactly, any float narrowed to a float type without overflowing it (float
    arguments compute in their declared width anyway). ``refuse(why)`` raises the error."""
    if isinstance(value, bool | np.bool_) or not isinstance(value, int | float | np.integer | np.floating):
        refuse("")
    if dtype.kind in "iu":
        if not isinstance(value, int | np.integer):
            refuse(": a float for an integer argument")
        limits = np.iinfo(dtype)
        if not limits.min <= int(value) <= limits.max:
            refuse(f": outside {dtype} [{limits.min}, {limits.max}]")
        return dtype.type(int(value))
    with np.errstate(over="ignore"):
        converted = dtype.type(value)
    if isinstance(value, int | np.integer) and int(converted) != int(value):
        refuse(f": {dtype} cannot hold this integer exactly")
    if math.isfinite(float(value)) and not math.isfinite(float(converted)):
        refuse(f": outside the range of {dtype}")
    return converted


class Kernel:
    """One kernel of a built program, launched on the runtime's queue: ``kernel(global_size, local_size, *args)``
    or ``kernel.over(shape, group, *args)``.

    Every chapter launches through this, and it keeps the kernel's declaration: on first use it reads each
    argument's name, address space and type (programs are built with ``-cl-kernel-arg-info``). A numpy scalar of
    the declared type is set from its bytes (0.4 us; PyOpenCL's generic ``set_arg`` costs ~9 us); any other number
    is converted where that is lossless (``_number``) or refused with a ``LaunchError`` naming kernel, argument,
    declared type and what was given, as are a buffer for a scalar, a scalar for a buffer and a wrong argument
    count. An argument given the very object it was last set from (a kept buffer, a reused scalar) is not set
    again. Buffers are ``cl.Buffer``, ``pyopencl.array.Array`` or None (NULL). ``ugpcl bench launch`` times this
    path against a bare enqueue.
    """

    def __init__(self, runtime: Runtime, kernel: cl.Kernel, name: str):
        self.runtime, self.cl, self.name = runtime, kernel, name
        self._queue = runtime.queue
        self.num_args = kernel.num_args
        self._given: list = [_UNSET] * self.num_args  # the object each argument was last set from
        self._set_bytes = getattr(kernel, "_set_arg_buf", kernel.set_arg)  # PyOpenCL's own invokers use it
        self.args = tuple(_read_arg(kernel, i) for i in range(self.num_args))  # the declaration, read once
        # per argument: the numpy type whose scalars are set from their bytes unchecked (None: always check)
        self._exact = tuple(a.dtype.type if a.kind == "scalar" and a.dtype.names is None else None for a in self.args)
        self._groups: dict = {}  # work-group asked for -> work-group fitted (over)

    def __call__(self, global_size, local_size, *args) -> cl.Event:
        if len(args) != self.num_args:
            raise self._count_error(args)
        given, exact = self._given, self._exact
        i = 0
        for arg in args:
            if arg is not given[i]:  # the same object as last time (a kept buffer, a reused scalar) is already set
                if type(arg) is exact[i]:  # a numpy scalar of exactly the declared type: its bytes, unchecked
                    self._set_bytes(i, arg)
                    given[i] = arg
                else:
                    self._set(i, arg)
            i += 1
        if type(global_size) is int:
            global_size = (global_size,)
        if type(local_size) is int:
            local_size = (local_size,)
        return _enqueue(self._queue, self.cl, global_size, local_size)

    def over(self, shape, group, *args) -> cl.Event | None:
        """``shape`` work-items (an int, or a 2- or 3-tuple) in work-groups of ``group`` (of the same rank, halved
        by ``fitted_shape`` where the kernel cannot run it; a kernel with a required work-group size gets exactly
        that), the global size padded to whole groups: the kernel guards its own range. Nothing is enqueued when
        any axis is <= 0, as the book skips a Dispatch of zero groups."""
        shape = (shape,) if isinstance(shape, int | np.integer) else tuple(shape)
        if min(shape) <= 0:
            return None
        local = self._groups.get(group)
        if local is None:
            local = self._groups[group] = self._fit(group, len(shape))
        return self(tuple(round_up(int(n), g) for n, g in zip(shape, local, strict=True)), local, *args)

    def work_group_size(self) -> int:
        """The largest work-group this kernel runs with on the device (registers and local memory allowing)."""
        return int(self.cl.get_work_group_info(cl.kernel_work_group_info.WORK_GROUP_SIZE, self.runtime.device))

    # {{{ the checked paths

    def _fit(self, group, rank: int) -> tuple[int, ...]:
        wanted = (int(group),) if isinstance(group, int | np.integer) else tuple(int(g) for g in group)
        if len(wanted) != rank:
            raise LaunchError(f"{self.name}: a work-group of rank {len(wanted)} for a launch of rank {rank}")
        info = cl.kernel_work_group_info.COMPILE_WORK_GROUP_SIZE
        required = tuple(int(v) for v in self.cl.get_work_group_info(info, self.runtime.device))[:rank]
        if any(required):
            if required != wanted:
                raise LaunchError(f"{self.name}: requires work-groups of {required}, got {wanted}")
            return required
        return fitted_shape(wanted, self.runtime.device, self.work_group_size())

    def _set(self, i: int, arg) -> None:
        a = self.args[i]
        if a.kind == "scalar" or a.kind == "bytes":
            self._set_bytes(i, self._scalar(a, arg))
        else:
            self.cl.set_arg(i, self._object(a, arg))
        self._given[i] = arg

    def _count_error(self, args) -> LaunchError:
        names = ", ".join(a.name for a in self.args)
        if len(args) < self.num_args:
            missing = ", ".join(a.describe() for a in self.args[len(args) :])
            return LaunchError(f"{self.name}({names}): {len(args)} arguments given, missing {missing}")
        return LaunchError(f"{self.name}({names}) takes {self.num_args} arguments, got {len(args)}")

    def _refuse(self, a: KernelArg, value, why: str = ""):
        raise LaunchError(f"{self.name}: argument {a.describe()} got {_what(value)}{why}")

    def _scalar(self, a: KernelArg, value):
        if a.kind == "bytes":  # a struct by value: its bytes, as a numpy scalar of its layout
            if not isinstance(value, np.generic):
                self._refuse(a, value, ": pass a numpy scalar of the struct's layout")
            return value
        dtype = a.dtype
        if isinstance(value, np.ndarray) and value.ndim == 0:  # cltypes.make_float4 and friends: a 0-d array
            value = value[()]
        if dtype.names is None:
            return _number(value, dtype, lambda why: self._refuse(a, value, why))
        if isinstance(value, np.void) and value.dtype == dtype:
            return value
        parts = tuple(value) if isinstance(value, list | tuple | np.ndarray) else None
        if parts is None or len(parts) != len(dtype.names):
            self._refuse(a, value, f": pass {len(dtype.names)} numbers")
        base = dtype.fields[dtype.names[0]][0]
        return np.array(tuple(_number(v, base, lambda why: self._refuse(a, value, why)) for v in parts), dtype)[()]

    def _object(self, a: KernelArg, value):
        if a.kind == "buffer":
            if isinstance(value, cla.Array):
                return value.base_data if value.offset == 0 else value.data
            if value is None or isinstance(value, cl.Buffer):
                return value
        elif a.kind == "local":
            if isinstance(value, cl.LocalMemory):
                return value
        elif a.kind == "image":
            if isinstance(value, cl.Image):
                return value
        elif a.kind == "sampler" and isinstance(value, cl.Sampler):
            return value
        self._refuse(a, value)

    # }}}


_UNSET = object()
"""A kept argument that was never set: equal to nothing."""

_enqueue = cl.enqueue_nd_range_kernel  # looked up once: Kernel.__call__ is the hot path of every step


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


def _format_define(value) -> str:
    if isinstance(value, bool):
        return "1" if value else "0"
    if isinstance(value, float):
        return f"{value!r}f"
    return str(value)


_INCLUDE = re.compile(r'[ \t]*#[ \t]*include[ \t]+"([^"]+)".*')


def inline_headers(text: str, name: str, seen: set | None = None) -> str:
    """``text`` with every ``#include "x.h"`` replaced by clkernels/include/x.h's own text (each header once, as its
    include guard would), framed by ``#line`` so build logs and Oclgrind reports name the real file and line (where
    the compiler honours it: PoCL and Oclgrind do, NVIDIA's log says ``<kernel>:N``). The source the driver sees is
    the whole program, so a changed header always misses the binary caches, and no path of ours enters the build
    options (PyOpenCL still adds its own include folder, so another virtualenv still builds afresh)."""
    seen = set() if seen is None else seen
    out = [f'#line 1 "{name}"']
    for number, source_line in enumerate(text.split("\n"), start=1):
        match = _INCLUDE.fullmatch(source_line)
        if not match:
            out.append(source_line)
            continue
        header = match[1]
        if header not in seen:
            seen.add(header)
            path = INCLUDE_DIR / header
            if not path.is_file():
                raise BuildError(f'{name}:{number}: #include "{header}": no such header in {INCLUDE_DIR}')
            out.append(inline_headers(path.read_text(), header, seen))
        out.append(f'#line {number + 1} "{name}"')
    return "\n".join(out)


ARG_INFO = "-cl-kernel-arg-info"
"""Build option that keeps each kernel argument's name and type for ``Kernel`` to check launches against."""

ZERO_FILL_PIECE = 1 << 30
"""Bytes per enqueue_fill_buffer in Runtime.zeros (below NVIDIA's 2 GiB fill limit)."""


@contextmanager
def _compiler_quiet():
    """A build's remarks kept off stderr: PyOpenCL's CompilerWarning for any compiler output and what PoCL's clang
    prints itself ("1 warning generated."), so that a run's stderr holds its own lines. A failed build still says
    why (its log is in the error); PYOPENCL_COMPILER_OUTPUT=1 shows everything."""
    if os.environ.get("PYOPENCL_COMPILER_OUTPUT"):
        yield
        return
    sys.stderr.flush()
    saved = os.dup(2)
    try:
        with open(os.devnull, "w") as null, warnings.catch_warnings():
            warnings.simplefilter("ignore", cl.CompilerWarning)
            os.dup2(null.fileno(), 2)
            yield
    finally:
        os.dup2(saved, 2)
        os.close(saved)


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
        self._staging: dict[int, tuple] = {}  # read_back's pinned host copies, by id of the array they mirror
        self.read_back_bytes = 0
        """Bytes ``read_back`` has copied to the host (``ugpcl bench frames`` counts a view's upload with it)."""
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
        """Build ``<stem>.cl`` (the first of ``kernel_dirs()``: ``clkernels/`` unless ``UGPCL_KERNELS`` names a folder
        that has one) with ``-D NAME=value`` for each define (cached per stem and defines)."""
        key = (stem, tuple(sorted(defines.items())))
        if key not in self._programs:
            self._programs[key] = self._build(kernel_file(stem), defines)
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
        program = self.program_from_source(path.read_text(), path.name, **defines)
        program.path = path
        return program

    def program_from_source(self, text: str, name: str = "<source>", **defines) -> Program:
        """Build OpenCL C ``text`` as a ``clkernels/`` file is built (its headers inlined, argument info kept, ``-D``
        defines): tests' own kernels launch through the same ``Kernel`` checks. Not cached here."""
        source = inline_headers(text, name)
        options = [ARG_INFO] + [f"-D{k}={_format_define(v)}" for k, v in sorted(defines.items())]
        try:
            with _compiler_quiet():
                program = cl.Program(self.context, source).build(options=options)
        except cl.RuntimeError as err:
            raise BuildError(f"{name}: build failed on {self.label} with {' '.join(options[1:])}\n{err}") from None
        return Program(self, program, KERNEL_DIR / name, options)

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

    def read_back(self, array: cla.Array, count: int | None = None) -> np.ndarray:
        """``array``'s contents in page-locked host memory kept for that array (a mapped ALLOC_HOST_PTR buffer): the
        copy runs at the bus's full speed and touches no fresh pages, where ``get()`` copies into a new pageable
        array each time (a million boids, 32 MB: 15-25 ms here, most of it page faults). For the views' uploads,
        which hand the result straight to GL: the next ``read_back`` of the same array overwrites it. ``count``:
        only the first ``count`` elements (a live prefix) are copied, and that prefix of the kept array returned."""
        if count is not None and not 0 <= count <= len(array):
            raise ValueError(f"read_back: count must be in [0, {len(array)}], got {count}")
        key = id(array)
        staged = self._staging.get(key)
        if staged is None or staged[1].shape != array.shape or staged[1].dtype != array.dtype:
            flags = cl.mem_flags.READ_WRITE | cl.mem_flags.ALLOC_HOST_PTR
            pinned = cl.Buffer(self.context, flags, max(array.nbytes, 1))
            host, _ = cl.enqueue_map_buffer(self.queue, pinned, cl.map_flags.READ, 0, array.shape, array.dtype)
            if staged is None:
                weakref.finalize(array, self._staging.pop, key, None)
            self._staging[key] = staged = (pinned, host)
        host = staged[1] if count is None else staged[1][:count]
        if host.nbytes:
            cl.enqueue_copy(self.queue, host, array.base_data, src_offset=array.offset)
            self.read_back_bytes += host.nbytes
        return host

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
