"""Memory counted before allocation (ugpcl.resources): every scene declares the device buffers it makes, and a
parameter set over the device's or the host's memory is refused in one line naming the largest value that fits."""

from __future__ import annotations

import numpy as np
import pyopencl as cl
import pyopencl.array as cla
import pytest

from ugpcl import resources
from ugpcl.cli import main
from ugpcl.registry import scenes
from ugpcl.runtime import Runtime


def device_bytes(sim) -> int:
    """Bytes of every OpenCL buffer and image reachable from the simulation's attributes (each counted once)."""
    found: dict[int, int] = {}
    seen: set[int] = set()

    def walk(obj, depth: int = 0) -> None:
        if id(obj) in seen or depth > 8 or isinstance(obj, Runtime):  # the runtime's kernels hold others' buffers
            return
        seen.add(id(obj))
        if isinstance(obj, cla.Array):
            found[obj.base_data.int_ptr] = obj.base_data.size
        elif isinstance(obj, cl.MemoryObjectHolder):
            found[obj.int_ptr] = obj.size
        elif isinstance(obj, dict):
            for value in obj.values():
                walk(value, depth + 1)
        elif isinstance(obj, list | tuple | set):
            for value in obj:
                walk(value, depth + 1)
        elif hasattr(obj, "__dict__") and type(obj).__module__.startswith("ugpcl"):
            for value in vars(obj).values():
                walk(value, depth + 1)

    walk(sim)
    return sum(found.values())


@pytest.mark.parametrize("name", list(scenes()))
def test_declared_buffers_cover_what_the_scene_allocates(runtime, name):
    scene = scenes()[name]
    params = scene.params()
    sim = scene.simulation(runtime, params, 0)
    declared = sum(a.total for a in sim.allocations(params) if not a.host)
    real = device_bytes(sim)
    assert real <= 1.1 * declared + (16 << 20), (
        f"{name}: {real / 2**20:.1f} MiB on the device, {declared / 2**20:.1f} declared"
    )


def test_projection_spray_counts_six_textures_per_drawable_and_names_the_largest_tex(
    runtime, monkeypatch, capsys, tmp_path
):
    # 16 GiB of host memory: tex=8192 (12 GiB of textures on the device, 32 GiB on the host) is over it on any device
    monkeypatch.setattr(resources, "host_memory_available", lambda: 16 << 30)
    code = main(["run", "projection_spray", "--set", "tex=8192", "--steps", "1", "--out", str(tmp_path / "x.npz")])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1, err
    largest = int(err.rsplit("the largest tex it takes is ", 1)[1])
    # at most the tex whose 12 float4 textures (two drawables) alone fill the device or the host memory
    limit = min(runtime.device.global_mem_size, resources.host_memory_available())
    assert 0 < largest < 8192 and 12 * 16 * largest**2 <= limit, (largest, limit)
    assert not (tmp_path / "x.npz").exists()


def test_a_request_over_the_host_memory_is_refused_with_the_largest_value(runtime, monkeypatch, capsys, tmp_path):
    monkeypatch.setattr(resources, "host_memory_available", lambda: 256 << 20)
    code = main(
        ["run", "procedural_modeling_forest", "--set", "trees=1024", "--steps", "1", "--out", str(tmp_path / "x.npz")]
    )
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "of host memory, over the 256.0 MiB available now" in err, err
    largest = int(err.rsplit("the largest trees it takes is ", 1)[1])
    scene = scenes()["procedural_modeling_forest"]
    cpu = bool(runtime.device.type & cl.device_type.CPU)  # a CPU device's buffers are host memory too

    def host_bytes(trees: int) -> int:
        return sum(a.total for a in scene.simulation.allocations(scene.params(trees=trees)) if a.host or cpu)

    need, more = host_bytes(largest), host_bytes(largest + 1)
    assert need <= 256 << 20 < more, (largest, need, more)


def test_the_spray_shape_is_computed_in_blocks_with_the_same_texels(monkeypatch):
    from ugpcl.geometry import projection_spray as ps

    whole = ps.spray_shape(300, 0.1, 10.0, 0.02)
    monkeypatch.setattr(ps, "SHAPE_BLOCK_TEXELS", 7 * 300)  # blocks of 7 rows, the last one shorter
    assert np.array_equal(ps.spray_shape(300, 0.1, 10.0, 0.02), whole)


def test_a_size_of_two_sides_is_capped_side_by_side(runtime, monkeypatch, capsys, tmp_path):
    """face_resolution is (width, height): the largest that fits caps every side, as --set takes it."""
    monkeypatch.setattr(resources, "host_memory_available", lambda: 64 << 20)
    argv = ["run", "multiplane_projection", "--set", "face_resolution=4096,2048", "--steps", "1"]
    code = main([*argv, "--out", str(tmp_path / "x.npz")])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "face_resolution=4096,2048 needs" in err, err
    width, height = map(int, err.rsplit("the largest face_resolution it takes is ", 1)[1].split(","))
    assert height <= 2048 and width == height, (width, height)  # capped at one value v: (min(4096, v), min(2048, v))
    scene = scenes()["multiplane_projection"]
    cpu = bool(runtime.device.type & cl.device_type.CPU)

    def host_bytes(size) -> int:
        return sum(a.total for a in scene.simulation.allocations(scene.params(face_resolution=size)) if a.host or cpu)

    assert host_bytes((width, height)) <= 64 << 20 < host_bytes((width + 1, height + 1))


def test_a_control_groups_memory_limit_caps_the_memory_available(tmp_path, monkeypatch):
    """A container or a batch job's cgroup: the headroom of the tightest group on the way up (v2 and v1 layouts),
    none where no group sets a limit, and ``host_memory_available`` is the smaller of that and the machine's."""
    v2 = tmp_path / "v2"
    for folder, limit, usage in (("", "max", 9 << 30), ("job", str(16 << 30), 4 << 30), ("job/run", "max", 3 << 30)):
        (v2 / folder).mkdir(parents=True, exist_ok=True)
        (v2 / folder / "memory.max").write_text(limit + "\n")
        (v2 / folder / "memory.current").write_text(f"{usage}\n")
    membership = tmp_path / "cgroup"
    membership.write_text("0::/job/run\n")
    assert resources.cgroup_memory_left(v2, membership) == 12 << 30  # the job's 16 GiB less its 4 in use
    v1 = tmp_path / "v1"
    (v1 / "memory" / "box").mkdir(parents=True)
    for folder, limit, usage in (("memory", 9223372036854771712, 1 << 30), ("memory/box", 2 << 30, 1 << 29)):
        (v1 / folder / "memory.limit_in_bytes").write_text(f"{limit}\n")
        (v1 / folder / "memory.usage_in_bytes").write_text(f"{usage}\n")
    membership.write_text("9:name=systemd:/\n4:memory:/box\n0::/\n")
    assert resources.cgroup_memory_left(v1, membership) == (2 << 30) - (1 << 29)
    membership.write_text("4:memory:/\n")
    assert resources.cgroup_memory_left(v1, membership) is None  # the root's "no limit"
    assert resources.cgroup_memory_left(v1, tmp_path / "missing") is None
    monkeypatch.setattr(resources, "cgroup_memory_left", lambda: 1 << 20)
    assert resources.host_memory_available() == 1 << 20
