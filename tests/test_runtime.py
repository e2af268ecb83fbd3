"""Runtime: device choice, program building and caching, the scene interface's parameter handling."""

from __future__ import annotations

from dataclasses import dataclass

import pytest

import ugpcl.runtime
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
    import numpy as np

    import ugpcl.runtime

    dtype = np.dtype([("position", "<f4", (3, 3)), ("normal", "<f4", (3, 3)), ("cell", "<u4")])
    dirty = runtime.to_device(np.frombuffer(np.full(100 * dtype.itemsize, 0xFF, np.uint8).tobytes(), dtype))
    del dirty  # its memory is likely reused by the next allocation: zeros must not rely on fresh memory
    monkeypatch.setattr(ugpcl.runtime, "ZERO_FILL_PIECE", 1024)
    array = runtime.zeros(100, dtype)
    assert array.get().tobytes() == bytes(100 * dtype.itemsize)
