"""Runtime: device choice, program building and caching, the scene interface's parameter handling."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest

import ugpcl.runtime
from ugpcl.registry import scenes
from ugpcl.runtime import BuildError, DeviceError, Runtime, choose_device, round_up
from ugpcl.scene import Params, param


def test_device_choice_by_name(runtime):
    device, why = choose_device("pocl")
    assert "pocl" in device.platform.version.lower() and "UGPCL_DEVICE" in why


def test_unknown_device_is_a_one_line_error():
    with pytest.raises(DeviceError) as err:
        Runtime("no-such-device")
    message = str(err.value)
    assert "\n" not in message and "no-such-device" in message and "have:" in message


def test_automatic_choice_never_picks_the_simulator(monkeypatch):
    monkeypatch.delenv("UGPCL_DEVICE", raising=False)
    monkeypatch.delenv("PYOPENCL_CTX", raising=False)
    device, why = choose_device()
    assert "oclgrind" not in device.platform.name.lower() and why in ("first GPU", "first CPU", "first device")


def test_programs_and_kernels_are_built_once(runtime):
    a = runtime.program("boids", SIMULATION_BLOCK_SIZE=64)
    assert runtime.program("boids", SIMULATION_BLOCK_SIZE=64) is a
    assert a.kernel("ForceCS") is a.kernel("ForceCS")
    assert runtime.program("boids", SIMULATION_BLOCK_SIZE=128) is not a


def test_missing_define_fails_with_the_file_and_the_reason(runtime):
    with pytest.raises(BuildError, match="boids.cl: build failed") as err:
        runtime.program("boids")
    assert "SIMULATION_BLOCK_SIZE" in str(err.value)


def test_build_log_names_the_file_and_line(runtime, tmp_path, monkeypatch):
    (tmp_path / "broken.cl").write_text("__kernel void k(__global int* a) {\n  a[0] = undefined_name;\n}\n")
    monkeypatch.setattr(ugpcl.runtime, "KERNEL_DIR", tmp_path)
    with pytest.raises(BuildError) as err:
        runtime.program("broken")
    message = str(err.value)
    assert message.startswith("broken.cl: build failed") and "undefined_name" in message
    if "pocl" in runtime.device.platform.version.lower():  # NVIDIA's log names no file; PoCL's follows '#line'
        assert "broken.cl:2" in message
    with pytest.raises(BuildError, match="no such kernel file"):
        runtime.program("absent")


def test_round_up():
    assert [round_up(n, 256) for n in (1, 255, 256, 257, 1000)] == [256, 256, 256, 512, 1024]


@dataclass(frozen=True)
class Example(Params):
    count: int = param(3, 1, 10)
    """How many."""
    scale: float = param(1.0, 0.0, lo_open=True)
    size: tuple[float, float] = param((1.0, 2.0), 0.0)
    mode: str = param("a", choices=("a", "b"))
    flag: bool = False


def test_params_parse_set_values_by_type():
    assert Example.parse("count", "7") == 7
    assert Example.parse("size", "3, 4.5") == (3.0, 4.5)
    assert Example.parse("flag", "yes") is True
    for name, text, message in [
        ("count", "x", "count expects int"),
        ("size", "1", "size expects float,float"),
        ("colour", "1", "unknown parameter 'colour'; valid: count, scale"),
    ]:
        with pytest.raises(ValueError, match=message):
            Example.parse(name, text)


def test_params_validate_and_coerce():
    assert Example(scale=2).scale == 2.0 and isinstance(Example(scale=2).scale, float)
    with pytest.raises(ValueError, match="scale must be in \\(0.0, inf\\], got 0.0"):
        Example(scale=0.0)
    with pytest.raises(ValueError, match="count must be of type int"):
        Example(count=True)
    with pytest.raises(ValueError, match="mode must be one of a\\|b, got 'c'"):
        Example(mode="c")
    table = {row["name"]: row for row in Example.table()}
    assert table["count"]["range"] == "in [1, 10]" and table["count"]["meaning"] == "How many."


def test_zeros_fills_every_piece_of_struct_arrays(runtime, monkeypatch):
    """Runtime.zeros fills its first piece and copies it over the rest (NVIDIA fills neither struct dtypes nor past
    4 GiB):
    with 1 KiB pieces, a 76-byte struct array of 100 items comes back all zero over a buffer that held ones."""
    dtype = np.dtype([("position", "<f4", (3, 3)), ("normal", "<f4", (3, 3)), ("cell", "<u4")])
    dirty = runtime.to_device(np.frombuffer(np.full(100 * dtype.itemsize, 0xFF, np.uint8).tobytes(), dtype))
    del dirty  # its memory is likely reused by the next allocation: zeros must not rely on fresh memory
    monkeypatch.setattr(ugpcl.runtime, "ZERO_FILL_PIECE", 1024)
    array = runtime.zeros(100, dtype)
    assert array.get().tobytes() == bytes(100 * dtype.itemsize)


# {{{ typed launches: arguments checked against the kernel's declaration


@pytest.fixture
def probe(runtime):
    """LaunchProbe(a, b, out: __global float*, n: int, scale: float, time: float, unused: int): out[i] = a[i] *
    scale + b[i] + time for i < n; with its buffers (a = 0..n-1, b = 1)."""
    n = 40
    a = runtime.to_device(np.arange(n, dtype=np.float32))
    b = runtime.to_device(np.ones(n, np.float32))
    out = runtime.zeros(n, np.float32)
    return runtime.program("probes").kernel("LaunchProbe"), n, a, b, out


def test_scalars_are_converted_to_the_declared_type(probe):
    kernel, n, a, b, out = probe
    kernel.over(n, 16, a, b, out, n, np.int32(3), np.float64(0.1), 0)  # an int32 for float scale; a float64 time
    expected = np.arange(n, dtype=np.float32) * np.float32(3.0) + np.float32(1.0) + np.float32(0.1)
    np.testing.assert_array_equal(out.get(), expected)
    kernel.over(n, 16, a, b, out, np.int64(n // 2), 2, 0.5, np.int16(7))  # Python and other-width numbers
    got = out.get()
    np.testing.assert_array_equal(got[: n // 2], np.arange(n // 2, dtype=np.float32) * 2 + 1.5)
    np.testing.assert_array_equal(got[n // 2 :], expected[n // 2 :])  # i >= n: untouched


def _refused(kernel, *args) -> str:
    with pytest.raises(ugpcl.runtime.LaunchError) as err:
        kernel.over(40, 16, *args)
    message = str(err.value)
    assert "\n" not in message and message.startswith("LaunchProbe"), message
    return message


def test_wrong_arguments_are_refused_naming_kernel_and_argument(probe):
    kernel, n, a, b, out = probe
    message = _refused(kernel, a, b, out, a, 3.0, 0.0, 0)  # a buffer for int n
    assert "argument n (int) got an array of float32" in message, message
    message = _refused(kernel, np.float32(1.0), b, out, n, 3.0, 0.0, 0)  # a scalar for buffer a
    assert "argument a (__global float*) got float32" in message, message
    message = _refused(kernel, a, b, out, n, 3.0, 0.0)  # unused is missing
    assert "6 arguments given, missing unused (int)" in message, message
    message = _refused(kernel, a, b, out, 2**31, 3.0, 0.0, 0)  # past int32
    assert "argument n (int) got int 2147483648: outside int32" in message, message
    message = _refused(kernel, a, b, out, n, 1e39, 0.0, 0)  # past float32
    assert "argument scale (float) got float 1e+39: outside the range of float32" in message, message
    message = _refused(kernel, a, b, out, n, 3.0, np.float64(-1e39), 0)
    assert "argument time (float)" in message and "outside the range of float32" in message, message


SHAPE_PROBE = """
__kernel void ShapeProbe(__global int* out) {
    if (get_global_id(0) == 0 && get_global_id(1) == 0) {
        out[0] = get_global_size(0); out[1] = get_global_size(1);
        out[2] = get_local_size(0); out[3] = get_local_size(1);
    }
    atomic_inc(&out[4]);
}
"""


def test_over_pads_a_2d_shape_to_whole_groups_and_skips_a_zero_axis(runtime):
    kernel = runtime.program_from_source(SHAPE_PROBE, "shape_probe.cl").kernel("ShapeProbe")
    out = runtime.zeros(5, np.int32)
    assert kernel.over((10, 5), (4, 4), out) is not None
    assert out.get().tolist() == [12, 8, 4, 4, 96]  # 10 x 5 padded to 3 x 2 groups of 4 x 4
    for empty in ((0, 5), (10, 0), (-1, 5)):
        assert kernel.over(empty, (4, 4), out) is None, empty
    runtime.finish()
    assert out.get()[4] == 96, "a launch with an empty axis ran work-items"


def test_every_scene_refuses_a_bad_dt_before_stepping(runtime):
    """``Simulation.step`` checks dt first: NaN and a negative dt raise one ValueError naming dt, and no kernel of
    the step runs (``_step`` is never called; steps and time stay 0). Each scene at its CPU sizes."""
    failures = []
    for name, scene in scenes().items():
        sim = scene.create(runtime, 0, **scene.interactive)
        calls = []
        sim._step = lambda dt, calls=calls: calls.append(dt)  # noqa: B023 (bound per scene through the default)
        for dt in (float("nan"), -1):
            try:
                sim.step(dt)
            except ValueError as err:
                if not (str(err).startswith("dt must be") and "\n" not in str(err)):
                    failures.append(f"{name}: step({dt}) raised {err!r}")
            else:
                failures.append(f"{name}: step({dt}) raised nothing")
        if calls or sim.steps or sim.time:
            failures.append(f"{name}: stepped {calls} (steps {sim.steps}, time {sim.time}) on a bad dt")
        del sim
    assert not failures, "\n".join(failures)


# }}}


def test_headers_are_inlined_and_errors_name_the_file_and_line(runtime):
    """A program's headers are part of its source (no -I path in the build options, so the drivers' binary caches
    hit from any checkout), and #line keeps a build error's file and line those of the text that has it."""
    from ugpcl.runtime import BuildError

    text = '#include "pool.h"\n#include "pool.h"\n__kernel void K(__global int* a) { a[0] = not_declared; }\n'
    with pytest.raises(BuildError) as err:
        runtime.program_from_source(text, "inline_probe.cl")
    log = str(err.value)
    assert log.startswith("inline_probe.cl: build failed") and "not_declared" in log, log[:400]
    if "inline_probe.cl:" in log.split("\n", 1)[1]:  # a compiler that honours #line (PoCL; NVIDIA's says <kernel>)
        assert "inline_probe.cl:3:" in log, log[:400]
    program = runtime.program_from_source(text.replace("not_declared", "POOL_COUNT"), "inline_probe.cl")
    assert not any(option.startswith("-I") for option in program.options)


def test_read_back_mirrors_an_array_into_one_kept_host_copy(runtime):
    """``Runtime.read_back``: the array's values (of a view at an offset too), in the same host array every call
    (pinned once, then overwritten: the views hand it straight to GL), dropped when the device array is."""
    import gc

    values = np.arange(1000, dtype=np.float32)
    device = runtime.to_device(values)
    first = runtime.read_back(device)
    assert np.array_equal(first, values)
    device.fill(np.float32(7))
    again = runtime.read_back(device)
    assert again is first and np.all(again == 7)
    device.set(values)
    prefix = runtime.read_back(device, count=5)  # a live prefix only, into the same kept array
    assert np.shares_memory(prefix, first) and np.array_equal(prefix, values[:5]) and np.all(first[5:] == 7)
    part = device[10:20]
    part.set(np.arange(10, dtype=np.float32))
    assert np.array_equal(runtime.read_back(part), np.arange(10))
    kept = len(runtime._staging)
    del device, part
    gc.collect()
    assert len(runtime._staging) == kept - 2
