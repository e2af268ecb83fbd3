"""Files out and checkpoints in: the outputs of a run are whole or absent and committed together, an interrupted
run says exactly what it wrote, no NaN or inf leaves the program, and a damaged or foreign checkpoint is one line."""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import time
import zipfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from ugpcl import io
from ugpcl.cli import main

UGPCL = str(Path(sys.executable).parent / "ugpcl")


def run(capsys, *argv) -> tuple[int, str, str]:
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def temporaries(folder: Path) -> list[Path]:
    return sorted(folder.glob(".*.partial*"))


def size(path: Path) -> int:
    try:
        return path.stat().st_size
    except FileNotFoundError:  # renamed or removed since it was listed
        return 0


# {{{ Outputs: prepared, committed together, the record of what was written


@pytest.mark.parametrize("renamed", [1, 2], ids=["before the second rename", "just after it"])
def test_outputs_commit_in_order_and_an_interrupt_names_exactly_what_was_replaced(tmp_path, monkeypatch, renamed):
    """Three files prepared; an interrupt at the second rename, before it or just after it (before its record):
    the renamed files are new, the others old, no temporary file is left, and the summary names exactly those."""
    paths = [tmp_path / name for name in ("a.npz", "a.obj", "a.png")]
    for path in paths:
        path.write_text("old")
    renames = []
    real_replace = os.replace

    def replace(src, dst):
        if len(renames) == renamed:
            raise KeyboardInterrupt
        renames.append(Path(dst))
        real_replace(src, dst)
        if len(renames) == renamed == 2:
            raise KeyboardInterrupt

    monkeypatch.setattr(io.os, "replace", replace)
    outputs = io.Outputs()
    with pytest.raises(KeyboardInterrupt), outputs:
        for path in paths:
            outputs.prepare("--x", path, lambda temporary: temporary.write_text("new"))
        assert [p.read_text() for p in paths] == ["old"] * 3, "nothing is replaced before the commit"
        outputs.commit()
    assert renames == paths[:renamed]
    assert [p.read_text() for p in paths] == ["new"] * renamed + ["old"] * (3 - renamed)
    assert temporaries(tmp_path) == []
    new, old = ", ".join(map(str, paths[:renamed])), ", ".join(map(str, paths[renamed:]))
    assert outputs.summary() == f"wrote only {new} (not {old})"


def test_an_interrupt_while_preparing_writes_nothing(tmp_path):
    out = tmp_path / "a.npz"
    out.write_text("old")
    outputs = io.Outputs()

    def interrupted(temporary):
        temporary.write_text("half")
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt), outputs:
        outputs.prepare("--out", out, lambda temporary: temporary.write_text("new"))
        outputs.prepare("--png", tmp_path / "a.png", interrupted)
    assert out.read_text() == "old" and temporaries(tmp_path) == [] and not (tmp_path / "a.png").exists()
    assert outputs.summary() == "nothing was written"


def test_stale_temporaries_of_a_killed_run_are_removed_and_no_others(tmp_path, capsys):
    """A killed run's leftover (its process gone, older than this one) goes; a running process's file, a file
    newer than this process and a file of another name stay."""
    gone = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True)
    dead = int(gone.stdout)
    old = time.time() - 3600
    stale = tmp_path / f".x.{dead}-abcd1234.partial.npz"
    running = tmp_path / f".x.{os.getppid()}-abcd1234.partial.npz"
    young = tmp_path / f".x.{dead}-efgh5678.partial.png"
    other = tmp_path / ".x.partial.npz"
    for path in (stale, running, other):
        path.write_bytes(b"left over")
        os.utime(path, (old, old))
    young.write_bytes(b"being written")
    argv = ["run", "boids", "--steps", "0", "--set", "max_object_num=16", "--out", str(tmp_path / "x.npz")]
    assert run(capsys, *argv)[0] == 0
    assert not stale.exists() and running.exists() and young.exists() and other.exists()


def test_a_temporary_name_fits_where_the_name_does(tmp_path):
    path = tmp_path / ("n" * 250 + ".npz")
    with io.written_whole(path) as temporary:
        assert temporary.suffix == ".npz" and io.TEMPORARY.fullmatch(temporary.name)
        temporary.write_bytes(b"x")
    assert path.read_bytes() == b"x" and path.stat().st_mode & 0o777 == 0o666 & ~io.UMASK


# }}}

# {{{ no NaN or inf leaves


def test_a_mesh_with_nan_is_refused_and_nothing_is_written(capsys, tmp_path, monkeypatch):
    from ugpcl.scenes import cloth

    mesh = cloth.Simulation.mesh

    def broken(self):
        m = mesh(self)
        m.vertices[3, 1] = np.inf
        return m

    monkeypatch.setattr(cloth.Simulation, "mesh", broken)
    out, obj = tmp_path / "c.npz", tmp_path / "c.obj"
    out.write_text("old")
    argv = ["run", "cloth", "--steps", "1", "--set", "res=8,8", "--out", str(out), "--mesh", str(obj)]
    code, stdout, err = run(capsys, *argv)
    assert code == 1 and err.count("error") == 1, err  # after the line saying which device runs it
    assert err.splitlines()[-1] == f"ugpcl: error: --mesh {obj}: mesh vertices hold NaN or inf; nothing was written"
    assert out.read_text() == "old" and not obj.exists() and temporaries(tmp_path) == [] and "wrote" not in stdout


@pytest.mark.parametrize("suffix", [".obj", ".ply", ".glb"])
def test_every_mesh_format_refuses_nan(tmp_path, suffix):
    from ugpcl.geometry.mesh import Mesh
    from ugpcl.geometry.mesh_io import NonFinite, write_mesh

    mesh = Mesh(np.array([[0, 0, 0], [1, 0, 0], [0, np.nan, 0]], np.float32), np.array([[0, 1, 2]], np.int32))
    with pytest.raises(NonFinite, match="mesh vertices hold NaN or inf"):
        write_mesh(tmp_path / f"m{suffix}", mesh)
    assert list(tmp_path.iterdir()) == []


def test_a_record_with_nan_is_refused(tmp_path):
    outputs = io.Outputs()
    arrays = {"sim_time": np.float64(np.nan), "n": np.int64(3)}
    with pytest.raises(io.NonFinite, match=r"--out .*a.npz: sim_time hold NaN or inf; nothing was written"):
        outputs.prepare("--out", tmp_path / "a.npz", io.save_npz(arrays), arrays)
    assert list(tmp_path.iterdir()) == []


# }}}

# {{{ the command line


@pytest.mark.parametrize(
    "argv, line",
    [
        (["run", "boids", "--out", ""], "ugpcl: error: --out is empty; give a file name ending in .npz"),
        (["run", "boids", "--png", ""], "ugpcl: error: --png is empty; give a file name ending in .png"),
        (["run", "cloth", "--mesh", ""], "ugpcl: error: --mesh is empty; give a file name ending in .obj or .ply"),
        (["run", "boids", "--checkpoint", ""], "ugpcl: error: --checkpoint is empty; give a file name ending in"),
        (["run", "boids", "--frames", ""], "ugpcl: error: --frames is empty; give a folder"),
        (["run", "--resume", ""], "ugpcl: error: --resume is empty; give the .npz of a run"),
        (["run", "boids", "--out", "n" * 256 + ".npz"], "bytes, over the 255 this file system holds"),
        (["run", "boids", "--out", "d" * 256 + "/x.npz"], "ugpcl: error: --out: the name dddddddddddddddddddddddd..."),
        (["run", "boids", "--out", "/".join(["d" * 200] * 25) + "/x.npz"], "bytes, over the 4095 allowed"),
        (
            ["run", "boids", "--set", "max_speed=2", "max_object_num=8", "max_speed=3"],
            "ugpcl: error: --set max_speed is given twice ('max_speed=2' and 'max_speed=3'); give each parameter once",
        ),
        (["run", "boids", "--set", "max_speed=x", "max_speed=3"], "max_speed expects float"),
    ],
)
def test_cli_edges_are_one_line_before_the_run(capsys, tmp_path, monkeypatch, argv, line):
    monkeypatch.chdir(tmp_path)
    code, _, err = run(capsys, *argv)
    assert code == 2 and err.count("\n") == 1 and line in err, err
    assert list(tmp_path.iterdir()) == [], "refused before the run: nothing made"


@pytest.mark.parametrize(
    "argv, error",
    [
        (["run", "boids", "--step", "3"], "ugpcl: error: unrecognized arguments: --step 3"),
        (["run", "boids", "--steps", "x"], "ugpcl run: error: argument --steps: invalid int value: 'x'"),
        ([], "ugpcl: error: the following arguments are required: command"),
        (["sweep"], "ugpcl sweep: error: the following arguments are required: scene, --out"),
    ],
)
def test_usage_errors_are_two_lines(capsys, argv, error):
    with pytest.raises(SystemExit) as exit_:
        main(argv)
    err = capsys.readouterr().err
    assert exit_.value.code == 2 and err.splitlines()[1:] == [error], err
    assert len(err.splitlines()) == 2 and err.startswith("usage: ugpcl") and "--help" in err.splitlines()[0]


def test_the_viewers_usage_errors_are_two_lines(capsys):
    from ugpcl.viewer.app import main as view

    with pytest.raises(SystemExit) as exit_:
        view(["boids", "--sizee", "3"])
    err = capsys.readouterr().err
    assert exit_.value.code == 2 and err.splitlines() == [
        "usage: ugpcl-view ... (see ugpcl-view --help)",
        "ugpcl-view: error: unrecognized arguments: --sizee 3",
    ], err


# }}}

# {{{ two runs, one --out; Ctrl-C while the PNG is written


def wrote(stdout: str, path: Path) -> int:
    """The size a run's 'wrote PATH (N bytes, ...)' line says it wrote."""
    return int(re.search(rf"^wrote {re.escape(str(path))} \((\d+) bytes", stdout, re.M)[1])


def test_two_runs_with_one_out_both_end_cleanly_and_the_file_is_one_of_them(tmp_path):
    out = tmp_path / "same.npz"
    sizes = {11: 300, 12: 700}  # seed -> boids
    procs = {
        seed: subprocess.Popen(
            [UGPCL, "run", "boids", "--steps", "2", "--seed", str(seed), "--set", f"max_object_num={n}", "--quiet"]
            + ["--out", str(out), "--checkpoint-every", "1"],  # the checkpoints share one name too
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        for seed, n in sizes.items()
    }
    results = {seed: proc.communicate(timeout=120) for seed, proc in procs.items()}
    for seed, proc in procs.items():
        assert proc.returncode == 0, results[seed][1]
        assert "Traceback" not in results[seed][1]
    with np.load(out) as data:
        found = {k: data[k] for k in data.files}  # every member read: the CRCs hold
    seed = int(found["seed"])
    assert seed in sizes and found["position"].shape == (sizes[seed], 3)
    assert out.stat().st_size == wrote(results[seed][0], out), "the file is what that run's line says it wrote"
    with np.load(tmp_path / "same.checkpoint.npz") as data:
        assert int(data["seed"]) in sizes and data["position"].shape == (sizes[int(data["seed"])], 3)
    assert temporaries(tmp_path) == []


@pytest.mark.gl
def test_ctrl_c_while_a_large_png_is_written_keeps_or_names_each_file(tmp_path):
    """SIGINT while the PNG's bytes are written (the .npz is prepared by then, not yet renamed): exit 130, and
    each of the two files is either the previous one or named in the message as written."""
    out, png = tmp_path / "x.npz", tmp_path / "x.png"
    out.write_bytes(b"previous npz")
    png.write_bytes(b"previous png")
    argv = [UGPCL, "run", "boids", "--steps", "1", "--set", "max_object_num=64", "--quiet"]
    proc = subprocess.Popen(
        argv + ["--out", str(out), "--png", str(png), "--png-size", "4096x4096"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )
    deadline = time.monotonic() + 120
    while not sum(size(p) for p in tmp_path.glob(".x.*.partial.png")):  # the PNG's bytes are being written
        assert proc.poll() is None and time.monotonic() < deadline, "the run never began writing its PNG"
        time.sleep(0.002)
    proc.send_signal(signal.SIGINT)
    err = proc.stderr.read()
    assert proc.wait(timeout=60) == 130 and "Traceback" not in err, err
    line = err.strip().splitlines()[-1]
    assert line.startswith("ugpcl: interrupted; "), err
    named = (
        set() if line.endswith("nothing was written") else set(line.split("wrote only ")[1].split(" (")[0].split(", "))
    )
    assert named <= {str(out), str(png)}, line
    assert (out.read_bytes() == b"previous npz") == (str(out) not in named)
    assert (png.read_bytes() == b"previous png") == (str(png) not in named)
    assert temporaries(tmp_path) == []


# }}}

# {{{ checkpoints: a fuzzer of damaged, foreign and hand-edited files


@pytest.fixture(scope="module")
def checkpoint(tmp_path_factory) -> bytes:
    """A real checkpoint of a small boids run (step 2), as bytes."""
    folder = tmp_path_factory.mktemp("checkpoint")
    argv = ["run", "boids", "--steps", "3", "--set", "max_object_num=64", "--checkpoint-every", "2", "--quiet"]
    assert main([*argv, "--out", str(folder / "b.npz")]) == 0
    return (folder / "b.checkpoint.npz").read_bytes()


def rewrite(data: bytes, path: Path, change) -> None:
    """``path`` is the checkpoint ``data`` with ``change(arrays)`` applied to its arrays."""
    path.write_bytes(data)
    with np.load(path) as npz:
        arrays = {k: npz[k] for k in npz.files}
    change(arrays)
    with open(path, "wb") as f:
        np.savez(f, **arrays)


def member_spans(data: bytes, path: Path) -> list[tuple[int, int]]:
    """(start, end) of each member's stored bytes: damage there is what the CRC must catch."""
    path.write_bytes(data)
    with zipfile.ZipFile(path) as z:
        spans = []
        for info in z.infolist():
            header = data[info.header_offset : info.header_offset + 30]
            start = (
                info.header_offset
                + 30
                + int.from_bytes(header[26:28], "little")
                + int.from_bytes(header[28:30], "little")
            )
            spans.append((start, start + info.compress_size))
    return spans


def params_edit(key, value):
    def change(arrays):
        params = json.loads(str(arrays["params"]))
        if value is DELETE:
            params.pop(key)
        else:
            params[key] = value
        arrays["params"] = np.array(json.dumps(params))

    return change


DELETE = object()
ARRAYS = ("position", "velocity", "force")
damages = st.one_of(
    st.tuples(st.just("truncate"), st.floats(0, 0.999)),
    st.tuples(st.just("flip"), st.floats(0, 0.999), st.integers(1, 255)),
    st.tuples(st.just("npy"), st.sampled_from(ARRAYS)),
    st.tuples(st.just("drop"), st.sampled_from(ARRAYS + ("scene", "params", "seed", "steps", "sim_time"))),
    st.tuples(
        st.just("array"),
        st.sampled_from(ARRAYS),
        st.sampled_from(["float64", "int32", "shape", "nan", "inf", "scalar"]),
    ),
    st.tuples(
        st.just("field"),
        st.sampled_from(
            [
                ("seed", np.array([1, 2])),
                ("seed", np.int64(-1)),
                ("seed", np.float64(1.5)),
                ("seed", np.array("1")),
                ("steps", np.int64(-5)),
                ("steps", np.array([3])),
                ("steps", np.float64(2.0)),
                ("sim_time", np.float64(np.nan)),
                ("sim_time", np.float64(np.inf)),
                ("sim_time", np.float64(-1)),
                ("sim_time", np.array("0")),
                ("scene", np.array("sph_2d")),
                ("scene", np.array("grass")),
                ("scene", np.array("no_such_scene")),
                ("scene", np.int64(3)),
                ("diverged", np.bool_(True)),
                ("params", np.array("[1, 2]")),
                ("params", np.array("{")),
                ("params", np.array("5")),
                ("params", np.array("null")),
                ("params", np.float64(1)),
            ]
        ),  # fmt: skip
    ),
    st.tuples(
        st.just("param"),
        st.sampled_from(
            [
                ("dt", DELETE),
                ("dt", float("nan")),
                ("dt", 0),
                ("dt", 2.0),
                ("dt", "fast"),
                ("speed", 1.0),
                ("max_object_num", DELETE),
                ("max_object_num", 65),
                ("max_object_num", -1),
                ("max_object_num", 1.5),
                ("max_object_num", "64"),
                ("max_object_num", [64]),
                ("max_speed", float("inf")),
                ("max_speed", None),
                ("variant", "nope"),
            ]
        ),  # fmt: skip
    ),
)


@settings(max_examples=120, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(damage=damages)
def test_a_damaged_checkpoint_is_one_line_and_a_nonzero_exit(capsys, tmp_path, checkpoint, damage):
    path = tmp_path / "damaged.npz"
    kind, *how = damage
    if kind == "truncate":
        path.write_bytes(checkpoint[: int(how[0] * len(checkpoint))])
    elif kind == "flip":
        spans = member_spans(checkpoint, path)
        start, end = spans[int(how[0] * len(spans))]
        at = start + int(how[0] * len(spans) % 1 * (end - start))
        path.write_bytes(checkpoint[:at] + bytes([checkpoint[at] ^ how[1]]) + checkpoint[at + 1 :])
    elif kind == "npy":
        rewrite(checkpoint, path, lambda arrays: None)
        with np.load(path) as npz:
            array = npz[how[0]]
        with open(path, "wb") as f:
            np.save(f, array)
    elif kind == "drop":
        rewrite(checkpoint, path, lambda arrays: arrays.pop(how[0]))
    elif kind == "array":
        name, change = how
        changes = {
            "float64": lambda a: a.astype(np.float64),
            "int32": lambda a: a.astype(np.int32),
            "shape": lambda a: a[:-1],
            "nan": lambda a: np.where(np.arange(a.size).reshape(a.shape) == 7, np.nan, a).astype(a.dtype),
            "inf": lambda a: np.where(np.arange(a.size).reshape(a.shape) == 7, np.inf, a).astype(a.dtype),
            "scalar": lambda a: np.float32(1),
        }
        rewrite(checkpoint, path, lambda arrays: arrays.update({name: changes[change](arrays[name])}))
    elif kind == "field":
        key, value = how[0]
        rewrite(checkpoint, path, lambda arrays: arrays.update({key: value}))
    else:
        rewrite(checkpoint, path, params_edit(*how[0]))
    out = tmp_path / "resumed.npz"
    out.unlink(missing_ok=True)
    code, _, err = run(capsys, "run", "--resume", str(path), "--steps", "1", "--quiet", "--out", str(out))
    assert code != 0 and err.count("\n") == 1 and err.startswith("ugpcl: error: --resume "), (damage, err)
    assert "Traceback" not in err and not out.exists()


@pytest.mark.parametrize(
    "change, line",
    [
        (lambda a: a.update(position=a["position"].astype(np.float64)), "array position is float64 of shape (64, 3);"),
        (lambda a: a.pop("velocity"), "no array 'velocity' (scene boids keeps it)"),
        (lambda a: a.update(seed=np.array([1, 2])), "seed must be an integer, got int64 of shape (2,)"),
        (lambda a: a.update(steps=np.int64(-5)), "steps must be >= 0, got -5"),
        (lambda a: a.update(sim_time=np.float64(np.nan)), "sim_time must be a finite time >= 0, got nan"),
        (lambda a: a.update(scene=np.array("sph_2d")), "for scene sph_2d"),
        (params_edit("dt", DELETE), "params has no dt"),
        (params_edit("extra", 1), "params has unknown parameter 'extra' for scene boids"),
        (lambda a: a.update(params=np.array("[1]")), "params is not a JSON object, got list"),
    ],
)
def test_each_checkpoint_check_names_itself(capsys, tmp_path, checkpoint, change, line):
    path = tmp_path / "c.npz"
    rewrite(checkpoint, path, change)
    code, _, err = run(capsys, "run", "--resume", str(path), "--steps", "1", "--out", str(tmp_path / "o.npz"))
    assert code == 2 and err.startswith(f"ugpcl: error: --resume {path}: ") and line in err, err
    assert err.count("\n") == 1


def test_a_flipped_byte_is_a_crc_error(capsys, tmp_path, checkpoint):
    start, end = member_spans(checkpoint, tmp_path / "c.npz")[0]
    at = end - 1  # the last byte of the first array's data
    (tmp_path / "c.npz").write_bytes(checkpoint[:at] + bytes([checkpoint[at] ^ 1]) + checkpoint[at + 1 :])
    code, _, err = run(capsys, "run", "--resume", str(tmp_path / "c.npz"), "--out", str(tmp_path / "o.npz"))
    assert code == 2 and "damaged or truncated (Bad CRC-32 for file" in err and err.count("\n") == 1, err


# }}}
