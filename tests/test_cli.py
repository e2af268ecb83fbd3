"""The headless CLI: `ugpcl run` writes what the chapter pages say, bad input exits 2 with one line, a failure
during a run exits 1 with one line, output is checked before the run and written whole."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest
from helpers import foreground
from PIL import Image

from ugpcl.cli import main
from ugpcl.scenes.boids import initial_boids


def run(capsys, *argv) -> tuple[int, str, str]:
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def test_run_boids_writes_the_state_and_params(capsys, tmp_path):
    out = tmp_path / "x.npz"
    code, _, _ = run(
        capsys, "run", "boids", "--steps", "1", "--seed", "3", "--set", "max_object_num=1024", "--out", str(out)
    )
    assert code == 0
    data = np.load(out)
    for key in ("position", "velocity", "force"):
        assert data[key].shape == (1024, 3) and data[key].dtype == np.float32
    params = json.loads(str(data["params"]))
    assert params["max_object_num"] == 1024 and params["dt"] == pytest.approx(1 / 60) and params["max_speed"] == 5.0
    assert int(data["seed"]) == 3 and int(data["steps"]) == 1 and "device" in data and "ugpcl_version" in data


def test_zero_steps_writes_the_initial_state(capsys, tmp_path):
    out = tmp_path / "x.npz"
    assert (
        run(capsys, "run", "boids", "--steps", "0", "--seed", "5", "--set", "max_object_num=300", "--out", str(out))[0]
        == 0
    )
    expected = initial_boids(300, 5)
    np.testing.assert_array_equal(np.load(out)["position"], expected["position"][:, :3])


def test_every_k_stacks_a_history(capsys, tmp_path):
    out = tmp_path / "h.npz"
    assert (
        run(
            capsys,
            "run",
            "boids",
            "--steps",
            "6",
            "--every",
            "3",
            "--set",
            "max_object_num=100",
            "--dt",
            "0.02",
            "--out",
            str(out),
        )[0]
        == 0
    )
    data = np.load(out)
    assert data["position_history"].shape == (3, 100, 3) and data["velocity_history"].shape == (3, 100, 3)
    np.testing.assert_allclose(data["time"], [0.0, 0.06, 0.12], atol=1e-6)
    np.testing.assert_array_equal(data["position_history"][-1], data["position"])


@pytest.mark.parametrize(
    "argv, message",
    [
        (["run", "boids", "--set", "max_object_num=0"], "max_object_num must be in [1, 4194304], got 0"),
        (["run", "boids", "--set", "max_speed=fast"], "max_speed expects float in (0.0, 10000.0], got 'fast'"),
        (["run", "boids", "--set", "speed=1"], "unknown parameter 'speed'; valid: max_object_num"),
        (["run", "boids", "--set", "max_speed"], "--set expects name=value"),
        (["run", "boidz"], "unknown scene 'boidz'; valid: boids"),
        (["run", "boids", "--dt", "0"], "dt must be in (0, 1], got 0.0"),
        (["run", "boids", "--steps", "-1"], "--steps must be >= 0"),
        (["run", "boids", "--every", "0"], "--every must be >= 1"),
        (["run", "compute_intro", "--every", "2"], "keeps no history"),
        (["run", "boids", "--mesh", "x.obj"], "--mesh: scene boids makes no mesh"),
        (["run", "marching_cubes", "--mesh", "m.stl"], "--mesh must end in .obj or .ply or .glb, got 'm.stl'"),
        (["run", "boids", "--out", "noext"], "--out must end in .npz, got 'noext'"),
        (["run", "boids", "--png", "x.jpg"], "--png must end in .png"),
        (["run", "boids", "--png-size", "10x10"], "--png-size must be WxH with 16..8192 each"),
        (["run", "boids", "--set", "max_speed=1e39"], "max_speed must be in (0.0, 10000.0], got 1e+39"),
        (["run", "cloth", "--set", "gravity=1e39,1,1"], "gravity must be in [-10000.0, 10000.0], got (1e+39,"),
        (
            ["run", "boids", "--seed", str(2**64)],
            "--seed must be in [0, 9223372036854775807], got 18446744073709551616",
        ),
        (["run", "boids", "--out", "/etc/hostname/x.npz"], "--out /etc/hostname/x.npz: cannot write in /etc/hostname"),
        (["run", "boids", "--png", "/proc/x.png"], "--png /proc/x.png: cannot write in /proc"),  # even as root
    ],
)
def test_bad_input_is_one_clear_line_and_exit_2(capsys, argv, message):
    code, out, err = run(capsys, *argv)
    assert code == 2
    assert err.strip().count("\n") == 0 and message in err, err


def test_misspelt_option_is_an_error_not_an_abbreviation(capsys):
    with pytest.raises(SystemExit) as exit_:
        main(["run", "boids", "--step", "3"])
    assert exit_.value.code == 2
    assert "unrecognized arguments: --step" in capsys.readouterr().err


def test_list_info_and_params(capsys):
    code, out, _ = run(capsys, "list")
    assert code == 0 and "boids" in out and "compute_intro_texture" in out
    code, out, _ = run(capsys, "info")
    assert code == 0 and "chosen because" in out and "SV_DispatchThreadID" in out and "shared memory" in out
    code, out, _ = run(capsys, "params", "boids")
    assert code == 0 and "separate_neighborhood_radius" in out and "_SeparateNeighborhoodRadius" in out


def test_compute_intro_npz_has_the_chapter_page_arrays(capsys, tmp_path):
    out = tmp_path / "ci.npz"
    assert run(capsys, "run", "compute_intro", "--steps", "1", "--set", "int_value=3", "--out", str(out))[0] == 0
    data = np.load(out)
    np.testing.assert_array_equal(data["array_after_a"], [0, 3, 6, 9])
    np.testing.assert_array_equal(data["array_after_b"], [1, 4, 7, 10])
    assert data["tex_a"].shape == (512, 512, 4) and data["tex_a"].dtype == np.uint8
    assert data["probe_global"].shape == (16, 3) and data["probe_flat"].shape == (16,)
    np.testing.assert_array_equal(data["local_size"], [8, 8, 1])


@pytest.mark.gl
def test_run_png_shows_the_flock(capsys, tmp_path, gl):
    png = tmp_path / "boids.png"
    code, _, _ = run(
        capsys,
        "run",
        "boids",
        "--steps",
        "2",
        "--set",
        "max_object_num=2048",
        "--out",
        str(tmp_path / "b.npz"),
        "--png",
        str(png),
        "--png-size",
        "160x120",
    )
    assert code == 0
    pixels = np.asarray(Image.open(png).convert("RGB"))
    assert pixels.shape == (120, 160, 3)
    mask = foreground(pixels, (0.192, 0.302, 0.475))
    # the boids start in the unit ball around the origin; the picture's camera fits them (the cage, blue-ish, is
    # drawn only when it fits too), so the boid pixels (grey: r close to b) are a ball centred in the frame, large
    # and whole
    grey = mask & (np.abs(pixels[..., 0].astype(int) - pixels[..., 2]) < 60)
    ys, xs = np.nonzero(grey)
    assert len(xs) > 4, "no boid pixels"
    assert abs(xs.mean() - 80) < 4 and abs(ys.mean() - 60) < 4
    assert 30 < np.ptp(xs) < 150 and 30 < np.ptp(ys) < 110 and xs.min() > 0 and ys.min() > 0


def test_bench_prints_a_table(capsys):
    code, out, _ = run(capsys, "bench", "boids", "--size", "256")
    assert code == 0
    assert "interactions/s" in out and "flocking" in out
    rows = [line.split() for line in out.splitlines() if line.startswith("256 ")]  # N, state, variant, kernel, ...
    assert [row[2:4] for row in rows if row[2] == "tiled"] == [["tiled", "ForceCS"]] * 2  # start, flocking


def test_bench_frames_times_a_flagship_scene_at_its_cpu_scale(capsys):
    """``ugpcl bench frames --scenes`` on PoCL: the scene's at-scale row (its ``cpu`` sizes here) and, with ``--all``,
    its row at the viewer's sizes; a scene name that does not exist, or ``--scenes`` without the frames bench, is a
    usage error."""
    code, out, _ = run(capsys, "bench", "frames", "--scenes", "cloth", "--all")
    assert code == 0
    rows = [line for line in out.splitlines() if line.startswith("cloth ")]
    assert [row.split()[1] for row in rows] == ["at", "defaults"] and "at scale (cpu)  1280x720" in rows[0]
    assert float(rows[0].split()[5]) > 0  # frames/s of the 128^2 cloth
    code, _, err = run(capsys, "bench", "frames", "--scenes", "clothes")
    assert code == 2 and "--scenes: no scene 'clothes'" in err
    code, _, err = run(capsys, "bench", "copy", "--scenes", "cloth")
    assert code == 2 and "only the frames bench" in err


def test_bench_shares_of_the_device_limits_and_json_records_match_the_table(capsys, tmp_path):
    """`% copy bw` follows every `... bytes/s` column, computed from the measured copy bandwidth; --json holds one
    record per float of the tables, with the row's sizes and variants as labels."""
    from ugpcl.bench.device import device_limits
    from ugpcl.runtime import Runtime
    from ugpcl.table import format_table

    out_json = tmp_path / "b.json"
    code, out, _ = run(capsys, "bench", "copy", "stable_fluids_2d", "--size", "32", "--json", str(out_json))
    assert code == 0 and "## copy" in out and "% copy bw" in out
    records = json.loads(out_json.read_text())
    fluid = [r for r in records if r["chapter"] == "stable_fluids_2d"]
    # the book's kernel in the book's work-groups (the other rows: 64x4 groups, the strips)
    book = [r for r in fluid if r["labels"]["local"] == "32x32" and r["labels"]["sweep kernel"] == "ProjectStep2"]
    by_figure = {r["figure"]: r["value"] for r in book}
    assert book[0]["labels"] == {"grid": "32^2", "sweep kernel": "ProjectStep2", "local": "32x32"}
    assert set(by_figure) >= {"ms/step", "Jacobi bytes/s", "% copy bw"}
    limits = device_limits(Runtime())
    share = 100 * by_figure["Jacobi bytes/s"] / limits.copy_bytes_per_s
    assert by_figure["% copy bw"] == pytest.approx(share)
    for record in records:  # every number of the JSON is in the printed table, as format_table shows it
        shown = format_table([{"x": record["value"]}]).splitlines()[-1].strip()
        assert shown in out, f"{record['figure']}={shown} not in the table"


def test_console_script_runs(tmp_path):
    bin_dir = __import__("pathlib").Path(sys.executable).parent
    result = subprocess.run(
        [str(bin_dir / "ugpcl"), "run", "boids", "--set", "max_object_num=-3"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert result.returncode == 2 and "max_object_num must be in" in result.stderr


def test_output_folder_is_rejected_before_the_run(capsys, tmp_path):
    code, _, err = run(capsys, "run", "boids", "--steps", "1", "--out", str(tmp_path))
    assert code == 2 and "is a folder" in err and err.count("\n") == 1


def test_a_failure_during_the_run_exits_1_with_one_line(capsys, tmp_path, monkeypatch):
    from ugpcl.scenes import boids

    def step(self, dt=None):
        raise ValueError("node pool ran out: 0 free slots of 64")

    monkeypatch.setattr(boids.Simulation, "step", step)
    out = tmp_path / "x.npz"
    out.write_bytes(b"the previous result")
    code, _, err = run(capsys, "run", "boids", "--steps", "3", "--set", "max_object_num=64", "--out", str(out))
    assert code == 1 and err.strip().splitlines()[-1] == "ugpcl: error: node pool ran out: 0 free slots of 64"
    assert out.read_bytes() == b"the previous result", "a failed run must not touch the old file"


def test_device_option_chooses_the_device(capsys, tmp_path):
    out = tmp_path / "x.npz"
    code, _, err = run(capsys, "run", "boids", "--steps", "1", "--device", "pocl", "--out", str(out))
    assert code == 0 and "Portable Computing Language" in str(np.load(out)["device"])
    code, _, err = run(capsys, "run", "boids", "--steps", "1", "--device", "no-such-device", "--out", str(out))
    assert code == 1 and "UGPCL_DEVICE='no-such-device' matches no OpenCL device" in err


def test_params_table_fits_the_terminal(capsys, monkeypatch):
    for columns in (80, 100, 120):
        monkeypatch.setenv("COLUMNS", str(columns))
        code, out, _ = run(capsys, "params", "boids")
        lines = out.splitlines()
        assert code == 0 and max(map(len, lines)) <= columns, (columns, max(lines, key=len))
        # nothing is cut: a long word may be broken across lines, but its pieces follow each other
        assert "(book:_SeparateNeighborhoodRadius)." in "".join(out.split())


def test_broken_pipe_ends_quietly():
    ugpcl = str(__import__("pathlib").Path(sys.executable).parent / "ugpcl")
    for argv in (["params", "boids"], ["list"]):
        result = subprocess.run(
            f"{ugpcl} {' '.join(argv)} | head -1", shell=True, capture_output=True, text=True, timeout=60
        )
        assert result.returncode == 0 and len(result.stdout.splitlines()) == 1
        assert "Traceback" not in result.stderr and "BrokenPipe" not in result.stderr, result.stderr


def test_progress_bar_counts_finished_steps(runtime, tmp_path):
    """On a terminal (a pseudo-terminal made by `script`) the bar moves while the run goes on."""
    ugpcl = __import__("pathlib").Path(sys.executable).parent / "ugpcl"
    # the naive all-pairs kernel at the dense start, about 0.1 s a step (4096 boids on 2 CPU cores, 131072 on an
    # H100): the bar, redrawn at most every 0.1 s, has time to move
    n = 131072 if runtime.is_gpu else 4096
    cmd = f"{ugpcl} run boids --steps 40 --set max_object_num={n} variant=naive --out {tmp_path / 'x.npz'}"
    result = subprocess.run(["script", "-qc", cmd, "/dev/null"], capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stdout
    counts = [int(m) for m in __import__("re").findall(r"\| *(\d+)/40 \[", result.stdout)]
    assert counts[0] < 40 and counts[-1] == 40 and len(set(counts)) >= 3, counts


@pytest.mark.parametrize("display", [None, ":99"], ids=["unset", "no-server"])
def test_view_without_a_display_says_so_in_one_line(display):
    env = {k: v for k, v in __import__("os").environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    if display:
        env["DISPLAY"] = display  # no X server listens there
    view = __import__("pathlib").Path(sys.executable).parent / "ugpcl-view"
    result = subprocess.run([str(view), "boids"], capture_output=True, text=True, timeout=60, env=env)
    assert result.returncode == 1 and result.stderr.count("\n") == 1 and "no display" in result.stderr, result.stderr
    assert ("DISPLAY=:99 does not answer" if display else "DISPLAY is not set") in result.stderr


def test_a_pyopencl_ctx_that_selects_nothing_is_one_line(capsys, monkeypatch, tmp_path):
    monkeypatch.delenv("UGPCL_DEVICE", raising=False)
    monkeypatch.setenv("PYOPENCL_CTX", "9")
    code, _, err = run(capsys, "run", "boids", "--steps", "1", "--out", str(tmp_path / "x.npz"))
    assert code == 1 and err.count("\n") == 1 and "PYOPENCL_CTX='9' does not select a device" in err, err


def _ugpcl() -> str:
    return str(__import__("pathlib").Path(sys.executable).parent / "ugpcl")


@pytest.mark.parametrize("sig, code, line", [("SIGINT", 130, "interrupted"), ("SIGTERM", 143, "terminated (SIGTERM)")])
def test_an_interrupted_run_ends_cleanly_and_keeps_the_old_file(tmp_path, sig, code, line):
    import signal
    import time

    out = tmp_path / "x.npz"
    out.write_bytes(b"the previous result")
    argv = [_ugpcl(), "run", "boids", "--steps", "100000", "--set", "max_object_num=1024", "--out", str(out)]
    proc = subprocess.Popen(argv, stderr=subprocess.PIPE, text=True)
    assert proc.stderr.readline().startswith("ugpcl: boids on")  # the run has started
    time.sleep(1.0)
    proc.send_signal(getattr(signal, sig))
    err = proc.stderr.read()
    assert proc.wait(timeout=60) == code
    assert err.strip().splitlines()[-1] == f"ugpcl: {line}; nothing was written" and "Traceback" not in err
    assert out.read_bytes() == b"the previous result" and sorted(tmp_path.iterdir()) == [out]


def test_sigkill_while_the_npz_is_written_keeps_the_previous_file(tmp_path):
    """The .npz goes to a hidden temporary name and is renamed when complete: killed while writing, the previous
    result stays whole."""
    import time

    out = tmp_path / "x.npz"
    out.write_bytes(b"the previous result")
    argv = [_ugpcl(), "run", "stable_fluids_2d", "--steps", "40", "--every", "1", "--out", str(out)]
    argv += ["--set", "width=1024", "height=1024"]  # ~170 MB of history: the write takes a while
    proc = subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 240

    def writing() -> bool:  # a temporary '.x.PID-RANDOM.partial.npz' (io.temporary_beside) has data
        return any(p.stat().st_size > 0 for p in tmp_path.glob(".x.*.partial.npz"))

    while not writing() and proc.poll() is None:
        assert time.monotonic() < deadline, "the run never started writing"
        time.sleep(0.002)
    proc.kill()
    proc.wait(timeout=60)
    assert out.read_bytes() == b"the previous result", "SIGKILL during the write damaged the previous file"


def test_divergence_is_one_line_exit_1_and_writes_only_when_asked(capsys, tmp_path):
    out = tmp_path / "c.npz"
    out.write_bytes(b"the previous result")
    argv = ["run", "cloth", "--steps", "5", "--set", "res=16,16", "stiffness=1e20", "--out", str(out)]
    code, _, err = run(capsys, *argv)
    assert code == 1 and err.strip().splitlines()[-1].startswith("ugpcl: error: diverged between steps 1 and 5: pos")
    assert "parameters set: res=16,16 stiffness=1e20" in err and out.read_bytes() == b"the previous result"
    code, _, err = run(capsys, *argv, "--keep-diverged")
    assert code == 1 and "diverged between" in err
    data = np.load(out)
    assert bool(data["diverged"]) and not np.isfinite(data["pos"]).all()


def test_inf_where_a_scene_means_it_is_no_divergence(capsys, tmp_path):
    """poisson_disk's nn_dist is inf for a lone sample (the first step's one point); NaN there still diverges."""
    from ugpcl.io import non_finite

    state = {"nn_dist": np.array([np.inf]), "other": np.array([np.inf]), "n": np.array([1])}
    assert non_finite(state, ("nn_dist",)) == ["other"]
    assert non_finite({"nn_dist": np.array([np.nan])}, ("nn_dist",)) == ["nn_dist"]
    argv = ["run", "poisson_disk", "--steps", "0", "--set", "steps_per_frame=36", "--out", str(tmp_path / "p.npz")]
    code, _, err = run(capsys, *argv)
    assert code == 0, err
    assert np.isinf(np.load(tmp_path / "p.npz")["nn_dist"]).all()


# {{{ checkpoints, resume, signs of life, device limits

RESUMABLE = {
    "boids": ["max_object_num=300"],
    "sph_2d": ["particle_num=300"],
    "stable_fluids_2d": ["width=40", "height=24"],
    "stable_fluids_3d": ["width=12", "height=10", "depth=8"],
}


@pytest.mark.parametrize("scene", sorted(RESUMABLE))
def test_resume_from_a_checkpoint_gives_the_uninterrupted_run(capsys, tmp_path, scene):
    """12 steps in one go equal 8 steps, a checkpoint, then 4 resumed steps: bit for bit (the same device)."""
    whole, part, resumed = tmp_path / "whole.npz", tmp_path / "part.npz", tmp_path / "resumed.npz"
    common = ["--set", *RESUMABLE[scene], "--seed", "5"]
    assert run(capsys, "run", scene, "--steps", "12", *common, "--out", str(whole))[0] == 0
    code, _, _ = run(capsys, "run", scene, "--steps", "10", *common, "--checkpoint-every", "4", "--out", str(part))
    checkpoint = tmp_path / "part.checkpoint.npz"
    assert code == 0 and int(np.load(checkpoint)["steps"]) == 8, "the last checkpoint before step 10 is step 8"
    code, _, err = run(capsys, "run", "--resume", str(checkpoint), "--steps", "4", "--out", str(resumed))
    assert code == 0 and "resumed" in err and "at step 8" in err
    a, b = np.load(whole), np.load(resumed)
    assert int(b["steps"]) == 12 and float(b["sim_time"]) == pytest.approx(float(a["sim_time"]))
    assert str(a["params"]) == str(b["params"]) and int(b["seed"]) == 5
    for key in a.files:
        if a[key].dtype.kind == "f":
            assert np.array_equal(a[key], b[key]), f"{key} differs after resuming"


def test_resume_refuses_what_it_cannot_continue(capsys, tmp_path):
    out = tmp_path / "g.npz"
    assert run(capsys, "run", "grass", "--steps", "1", "--out", str(out))[0] == 0
    code, _, err = run(capsys, "run", "--resume", str(out), "--steps", "1", "--out", str(tmp_path / "h.npz"))
    assert code == 2 and "scene grass cannot resume" in err
    not_ours = tmp_path / "other.npz"
    np.savez(not_ours, x=np.zeros(3))
    code, _, err = run(capsys, "run", "--resume", str(not_ours))
    assert code == 2 and "not written by ugpcl run" in err
    code, _, err = run(capsys, "run", "--resume", str(tmp_path / "missing.npz"))
    assert code == 2 and err.count("\n") == 1 and "missing.npz: no such file" in err
    b = tmp_path / "b.npz"
    assert run(capsys, "run", "boids", "--steps", "1", "--set", "max_object_num=64", "--out", str(b))[0] == 0
    code, _, err = run(capsys, "run", "--resume", str(b), "--set", "max_speed=2")
    assert code == 2 and "drop --set/--seed" in err
    code, _, err = run(capsys, "run", "sph_2d", "--resume", str(b))
    assert code == 2 and "holds scene boids, not sph_2d" in err
    code, _, err = run(capsys, "run", "--checkpoint-every", "0", "boids")
    assert code == 2 and "--checkpoint-every must be >= 1" in err


def test_progress_lines_without_a_terminal_and_quiet(capsys, tmp_path, monkeypatch):
    """stderr here is not a terminal: a line every PROGRESS_LINE_SECONDS (0 in this test); --quiet: none."""
    import ugpcl.run

    monkeypatch.setattr(ugpcl.run, "PROGRESS_LINE_SECONDS", 0.0)
    argv = ["run", "boids", "--steps", "6", "--set", "max_object_num=64", "--out", str(tmp_path / "b.npz")]
    code, _, err = run(capsys, *argv)
    lines = [line for line in err.splitlines() if " step " in line]
    assert code == 0 and len(lines) == 5, err  # steps 1..5; the 6th is the end
    assert lines[0].startswith("ugpcl: boids step 1/6 (16%)") and "steps/s" in lines[0] and "s left" in lines[0]
    code, _, err = run(capsys, *argv, "--quiet")
    assert code == 0 and " step " not in err


@pytest.mark.parametrize(
    "scene, setting, expected",
    [
        ("marching_cubes", "triangle_capacity=67108864", "the largest triangle_capacity it takes is "),
        ("compute_intro_texture", "tex_width=16384", "the largest tex_width it takes is "),
    ],
)
def test_requests_beyond_the_device_are_one_line_naming_the_largest_value(capsys, tmp_path, scene, setting, expected):
    """In range, but more than PoCL can hold (2 GiB per buffer, 8192-wide images): exit 2 before anything is
    allocated, naming the parameter and the largest value that fits, and that value fits while one more does not.
    A device that holds the request (a GPU with 80 GB) runs it."""
    from ugpcl import resources
    from ugpcl.registry import get
    from ugpcl.runtime import Runtime

    device, simulation = Runtime().device, get(scene).simulation
    name, value = setting.split("=")
    out = tmp_path / "x.npz"
    code, _, err = run(capsys, "run", scene, "--steps", "1", "--set", setting, "--out", str(out))
    if resources.problem(simulation.allocations(get(scene).params(**{name: int(value)})), device)[0] is None:
        assert code == 0 and out.exists(), err
        return
    assert code == 2 and err.count("ugpcl: error:") == 1 and expected in err, err
    assert not out.exists()
    largest = int(err.split(expected)[1].split()[0])
    resources.check(simulation, get(scene).params(**{name: largest}), device)  # the largest fits ...
    with pytest.raises(resources.ResourceError):  # ... and one more does not
        resources.check(simulation, get(scene).params(**{name: largest + 1}), device)


def test_resource_check_names_the_limit_it_hits():
    """Each device limit, on a made-up device: one buffer, all buffers together, image sides. 640 x 360 cells of
    fluid fields take 120 bytes each (the view's half-float texture among them); at most 3 MiB in all leaves 72
    columns of 360."""
    from types import SimpleNamespace

    import pyopencl as cl

    from ugpcl import resources
    from ugpcl.registry import get

    device = SimpleNamespace(
        name="small device", max_mem_alloc_size=2**20, global_mem_size=3 * 2**20, image2d_max_width=256,
        image2d_max_height=256, image3d_max_width=64, image3d_max_height=64, image3d_max_depth=64,
        type=cl.device_type.GPU,  # its memory is its own: the host's is not what limits it
    )  # fmt: skip
    fluids = get("stable_fluids_2d")
    with pytest.raises(
        resources.ResourceError,
        match=r"width=640 needs a 1.8 MiB velocity field, over the 1.0 MiB .* the largest width it takes is 72",
    ):
        resources.check(fluids.simulation, fluids.params(), device)
    texture = get("compute_intro_texture")
    with pytest.raises(
        resources.ResourceError, match=r"512x256 texture, over the 256x256 .* tex_width it takes is 256"
    ):
        resources.check(texture.simulation, texture.params(tex_height=256), device)
    many = SimpleNamespace(**{**vars(device), "max_mem_alloc_size": 2**30})
    with pytest.raises(
        resources.ResourceError,
        match=r"width=640 needs 26.4 MiB of buffers, over the 3.0 MiB of device memory .* width it takes is 72",
    ):
        resources.check(fluids.simulation, fluids.params(), many)
    resources.check(fluids.simulation, fluids.params(width=64, height=48), device)  # 3072 cells fit


# }}}


@pytest.mark.parametrize(
    "command, option, accepted",
    [
        ("run", "--mesh", (".obj", ".ply", ".glb")),
        ("sweep", "--mesh", (".obj", ".ply", ".glb")),
        ("run", "--video", (".mp4", ".webp")),
        ("run", "--out", (".npz",)),
    ],
)
def test_help_names_every_format_an_option_takes(capsys, command, option, accepted):
    """What `--help` says an option takes is what it takes: each suffix the help names writes, and the ones it
    takes are named (the accepted list here is the code's own: MESH_SUFFIXES and the recorder's formats)."""
    from ugpcl.geometry.mesh_io import MESH_SUFFIXES

    if option == "--mesh":
        assert tuple(MESH_SUFFIXES) == accepted
    with pytest.raises(SystemExit):
        main([command, "--help"])
    lines = capsys.readouterr().out.splitlines()
    start = next(i for i, line in enumerate(lines) if line.lstrip().startswith(option + " "))
    end = next((i for i in range(start + 1, len(lines)) if lines[i].lstrip().startswith("-")), len(lines))
    said = " ".join(" ".join(lines[start:end]).split())  # the option's own entry in the options list
    for suffix in accepted:
        assert suffix in said or suffix.lstrip(".") in said.split(), f"{command} {option} help omits {suffix}: {said}"
