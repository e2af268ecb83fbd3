"""`ugpcl sweep`: a grid times seeds as Dask tasks gives the files `ugpcl run` gives, one by one; a rerun computes
only what is not finished; a failing run is a row of the index, not the end of the sweep; a worker killed mid-sweep
loses no finished file."""

from __future__ import annotations

import csv
import json
import os
import signal
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from ugpcl.cli import main

BOIDS = ["sweep", "boids", "--set", "max_object_num=256", "--steps", "5", "--quiet"]
GRID = ["--grid", "max_speed=2,5", "--grid", "separate_weight=1,3", "--seeds", "0-1"]


def run(capsys, *argv) -> tuple[int, str, str]:
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def index(folder: Path) -> dict[str, dict]:
    with open(folder / "index.csv", newline="") as f:
        return {row["run"]: row for row in csv.DictReader(f)}


def arrays(path: Path) -> dict[str, np.ndarray]:
    with np.load(path) as data:
        return {k: data[k] for k in data.files}


def ok_rows(folder: Path) -> list[str]:
    try:
        return [name for name, row in index(folder).items() if row["status"] == "ok"]
    except FileNotFoundError:
        return []


def landed(folder: Path) -> list[Path]:
    """The runs' .npz files, less a run's '.NAME.partial.npz' (io.written_whole) still being written."""
    return [p for p in folder.glob("*.npz") if not p.name.startswith(".")]


def stamps(folder: Path) -> dict[str, int]:
    return {p.name: p.stat().st_mtime_ns for p in landed(folder)}


@pytest.fixture(scope="module")
def cluster():
    """A LocalCluster of 2 single-threaded worker processes, reached by address like one started elsewhere."""
    from distributed import Client, LocalCluster

    with LocalCluster(n_workers=2, threads_per_worker=1, dashboard_address=":0") as local, Client(local) as client:
        yield local, client


def test_grid_times_seeds_equals_single_runs_and_a_rerun_skips_them(capsys, runtime, tmp_path):
    from ugpcl.sweep import local_cluster_size

    workers, threads = local_cluster_size(None)
    if runtime.is_gpu:  # one worker per GPU of the chosen one's kind
        assert workers >= 1 and threads == 1
    else:  # two single-threaded workers on a CPU device
        assert (workers, threads) == (min(2, os.cpu_count()), 1)
    code, out, err = run(capsys, *BOIDS, *GRID, "--out", tmp_path)
    assert code == 0, err
    assert "8 ok, 0 failed, 0 finished before" in out
    rows = index(tmp_path)
    assert len(rows) == 8 and {r["status"] for r in rows.values()} == {"ok"}
    assert sorted(p.stem for p in tmp_path.glob("*.npz")) == sorted(rows)
    assert not list(tmp_path.glob(".*"))  # no partial file left behind
    points = {(r["max_speed"], r["separate_weight"], r["seed"]) for r in rows.values()}
    assert points == {(v, w, s) for v in ("2.0", "5.0") for w in ("1.0", "3.0") for s in ("0", "1")}

    for name, row in rows.items():  # each file is what `ugpcl run` writes for the same parameters and seed
        single = tmp_path / "single" / f"{name}.npz"
        sets = ["max_object_num=256", f"max_speed={row['max_speed']}", f"separate_weight={row['separate_weight']}"]
        code, _, err = run(capsys, "run", "boids", "--steps", 5, "--seed", row["seed"], "--quiet", "--set", *sets,
                           "--out", single)  # fmt: skip
        assert code == 0, err
        got, want = arrays(tmp_path / f"{name}.npz"), arrays(single)
        assert got.keys() == want.keys()
        for key in want:
            assert np.array_equal(got[key], want[key]), f"{name}: {key} differs from ugpcl run's"
        assert json.loads(str(got["params"]))["max_speed"] == float(row["max_speed"])
        assert float(row["stat:mean speed"]) > 0 and row["device"] == str(got["device"])
    # the seeds and the grid values reach the runs: no two files hold the same positions
    positions = [arrays(tmp_path / f"{name}.npz")["position"].tobytes() for name in rows]
    assert len(set(positions)) == 8

    before = stamps(tmp_path)
    code, out, _ = run(capsys, *BOIDS, *GRID, "--out", tmp_path)
    assert code == 0 and "0 ok, 0 failed, 8 finished before" in out
    assert stamps(tmp_path) == before and index(tmp_path) == rows  # nothing rewritten, same wall times and stamps

    (tmp_path / "max_speed=5.0_separate_weight=3.0_seed=1.npz").unlink()  # a lost file is run again, alone
    code, out, _ = run(capsys, *BOIDS, *GRID, "--out", tmp_path)
    assert code == 0 and "1 ok, 0 failed, 7 finished before" in out
    again = index(tmp_path)
    changed = {name for name in rows if again[name]["finished"] != rows[name]["finished"]}
    assert changed <= {"max_speed=5.0_separate_weight=3.0_seed=1"}
    now = stamps(tmp_path)
    assert {k for k in now if now[k] != before[k]} == {"max_speed=5.0_separate_weight=3.0_seed=1.npz"}

    code, out, _ = run(capsys, *BOIDS[:-3], "--steps", "6", "--quiet", *GRID, "--out", tmp_path)
    assert "8 ok, 0 failed, 0 finished before" in out  # other steps: not the same runs


def test_a_failing_run_is_recorded_and_the_others_finish(capsys, tmp_path, cluster):
    local, _ = cluster
    code, out, err = run(
        capsys, "sweep", "cloth", "--grid", "stiffness=10000,1e20", "--seeds", "0-1", "--set", "res=8,8",
        "--steps", "20", "--quiet", "--out", tmp_path, "--scheduler", local.scheduler_address,
    )  # fmt: skip
    assert code == 1 and "2 ok, 2 failed" in out
    rows = index(tmp_path)
    assert [r["status"] for r in rows.values()] == ["ok", "ok", "failed", "failed"]
    for name, row in rows.items():
        if row["status"] == "failed":
            assert row["error"].startswith(f"{name}: error: diverged between steps")
            assert row["error"] in err.splitlines()  # the same one line on stderr
            assert "\n" not in row["error"] and not (tmp_path / f"{name}.npz").exists()
        else:
            assert row["error"] == "" and np.isfinite(arrays(tmp_path / f"{name}.npz")["pos"]).all()
    code, out, _ = run(capsys, "sweep", "cloth", "--grid", "stiffness=10000,1e20", "--seeds", "0-1", "--set",
                       "res=8,8", "--steps", "20", "--quiet", "--out", tmp_path)  # fmt: skip
    assert code == 1 and "0 ok, 2 failed, 2 finished before" in out  # failed runs are tried again, ok ones not


def test_a_killed_worker_loses_no_finished_run_and_the_rerun_completes(capsys, tmp_path, cluster):
    local, client = cluster
    argv = ["sweep", "boids", "--set", "max_object_num=2048", "--steps", "60", "--quiet", *GRID, "--out", tmp_path]
    argv += ["--scheduler", local.scheduler_address]
    result = {}
    sweep = threading.Thread(target=lambda: result.setdefault("code", main([str(a) for a in argv])))
    sweep.start()
    deadline = time.monotonic() + 120
    while not ok_rows(tmp_path) and time.monotonic() < deadline:
        time.sleep(0.01)
    os.kill(next(iter(client.run(os.getpid).values())), signal.SIGKILL)
    recorded = {name: stamps(tmp_path)[f"{name}.npz"] for name in ok_rows(tmp_path)}
    whole = {p.name: arrays(p) for p in landed(tmp_path)}
    sweep.join(timeout=300)
    assert not sweep.is_alive() and 1 <= len(recorded) < 8, len(recorded)
    capsys.readouterr()

    main([str(a) for a in argv])  # the rerun: whatever the kill cost is run now, nothing finished is run again
    out, _ = capsys.readouterr()
    rows = index(tmp_path)
    assert {r["status"] for r in rows.values()} == {"ok"} and len(stamps(tmp_path)) == 8, out
    for name, stamp in recorded.items():  # recorded before the kill: never run again
        assert stamps(tmp_path)[f"{name}.npz"] == stamp
    for name, data in whole.items():  # landed: whole, and the same if it was run again
        assert all(np.array_equal(arrays(tmp_path / name)[k], v) for k, v in data.items())


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--grid", "max_speed"], "--grid expects name=value"),
        (["--grid", "max_speed="], "--grid expects name=value"),
        (["--grid", "nope=1,2"], "unknown parameter 'nope'"),
        (["--grid", "max_speed=2,x"], "max_speed expects float"),
        (["--grid", "max_speed=2,-1"], "max_speed"),  # out of range: found before anything runs
        (["--grid", "max_speed=2,2"], "repeats a value"),
        (["--grid", "max_speed=2", "--grid", "max_speed=3"], "names max_speed twice"),
        (["--grid", "max_speed=2", "--set", "max_speed=3"], "both --grid and --set"),
        (["--seeds", "3-1"], "--seeds 3-1"),
        (["--seeds", "a"], "--seeds expects"),
        (["--mesh", "stl"], "--mesh must be one of"),
        (["--steps", "-1"], "--steps must be >= 0"),
    ],
)
def test_bad_sweep_input_is_one_line_and_exit_2(capsys, tmp_path, argv, message):
    code, out, err = run(capsys, "sweep", "boids", "--out", tmp_path / "s", *argv)
    assert code == 2 and out == ""
    assert len(err.splitlines()) == 1 and err.startswith("ugpcl: error:") and message in err, err
    assert not (tmp_path / "s").exists()  # nothing ran, no index


def test_tuple_values_and_run_names():
    from ugpcl.registry import get
    from ugpcl.sweep import parse_grid, parse_seeds, run_name

    grid = parse_grid(get("boids"), ["wall_size=8,8,8/16,16,16", "variant=naive,grid"])
    assert grid == {"wall_size": [(8.0, 8.0, 8.0), (16.0, 16.0, 16.0)], "variant": ["naive", "grid"]}
    assert parse_seeds("1,4,7-9") == [1, 4, 7, 8, 9]
    assert (
        run_name({"wall_size": (8.0, 8.0, 8.0), "input": "a/b c.png"}, 3)
        == "wall_size=8.0,8.0,8.0_input=a-b-c.png_seed=3"
    )


# {{{ hostile input: seed ranges, damaged indexes, schedulers that are not Dask


def test_a_huge_seed_range_is_refused_before_anything_is_listed(capsys, tmp_path):
    start = time.perf_counter()
    code, _, err = run(capsys, *BOIDS, "--seeds", "0-100000000", "--out", tmp_path / "s")
    assert code == 2 and err.count("\n") == 1 and "100000001 seeds, over the 100000 runs" in err, err
    code, _, err = run(capsys, *BOIDS, "--grid", "max_speed=2,3,4", "--seeds", "0-40000", "--out", tmp_path / "s")
    assert code == 2 and err.count("\n") == 1 and "make 120003 runs, over the 100000" in err, err
    code, _, err = run(capsys, *BOIDS, "--seeds", "0-9,5-20", "--out", tmp_path / "s")
    assert code == 2 and "a seed appears twice" in err, err
    assert time.perf_counter() - start < 5, "the seeds were listed before they were counted"
    assert not (tmp_path / "s").exists()


@pytest.mark.parametrize(
    "text, says",
    [
        ("name,seed\nx,1\n", "not a sweep index (no run, status, steps, params column)"),
        (b"\x89PNG\r\n\x1a\n\x00\xff\xfe", "not a sweep index"),
        ("run,scene,seed,steps,status,params\nseed=0,boids,0,5,ok,{},extra\n", "line 2 does not match its header"),
        ("run,scene,seed,steps,status,params\nseed=0,boids\n", "line 2 does not match its header"),
    ],
    ids=["no-run-column", "binary", "extra-cell", "truncated-row"],
)
def test_a_damaged_index_is_one_line(capsys, tmp_path, text, says):
    out = tmp_path / "s"
    out.mkdir()
    (out / "index.csv").write_bytes(text if isinstance(text, bytes) else text.encode())
    code, _, err = run(capsys, *BOIDS, "--seeds", "0", "--out", out)
    assert code == 2 and err.strip().splitlines()[-1].startswith("ugpcl: error: ") and says in err, err
    assert err.count("\n") == 1, err  # the error alone: the sweep is announced only once its index is good


def test_a_scheduler_that_is_not_dask_is_refused_in_one_line(capsys, monkeypatch, tmp_path):
    import socket

    from ugpcl import sweep

    monkeypatch.setattr(sweep, "HANDSHAKE_SECONDS", 1.0)
    with socket.socket() as listener:  # accepts connections and never says a word
        listener.bind(("127.0.0.1", 0))
        listener.listen(4)
        address = f"tcp://127.0.0.1:{listener.getsockname()[1]}"
        start = time.perf_counter()
        code, _, err = run(capsys, *BOIDS, "--seeds", "0", "--out", tmp_path / "s", "--scheduler", address)
    assert time.perf_counter() - start < 10
    assert code == 2 and err.count("\n") == 1 and "not a Dask scheduler (no greeting within 1 s)" in err, err
    for address, says in [("tls://10.0.0.1:8786", "TLS needs certificates"), ("tcp://127.0.0.1", "HOST:PORT")]:
        code, _, err = run(capsys, *BOIDS, "--seeds", "0", "--out", tmp_path / "s", "--scheduler", address)
        assert code == 2 and err.count("\n") == 1 and says in err, err


# }}}


def start_scheduler(tmp_path):
    """A dask scheduler process on a free port of 127.0.0.1, listening: (process, address, port)."""
    import socket
    import subprocess
    import sys

    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    quiet = {"stdout": subprocess.DEVNULL, "stderr": subprocess.DEVNULL}
    scheduler = subprocess.Popen(
        [sys.executable, "-m", "distributed.cli.dask_scheduler", "--host", "127.0.0.1", "--port", str(port),
         "--no-dashboard"], cwd=tmp_path, **quiet,
    )  # fmt: skip
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:  # the scheduler takes a second or two to listen
        with socket.socket() as knock:
            if knock.connect_ex(("127.0.0.1", port)) == 0:
                break
        time.sleep(0.2)
    return scheduler, f"tcp://127.0.0.1:{port}"


def start_worker(address: str, folder: Path, *flags):
    import subprocess
    import sys

    folder.mkdir(exist_ok=True)
    return subprocess.Popen(
        [sys.executable, "-m", "distributed.cli.dask_worker", address, "--nthreads", "1", "--no-dashboard",
         "--local-directory", str(folder), *flags], cwd=folder, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
    )  # fmt: skip


def test_with_no_live_worker_the_sweep_says_so_and_waits_or_ends(capsys, tmp_path, monkeypatch):
    """The only worker (no nanny to restart it) is killed mid-sweep: after NO_WORKER_SECONDS (2 s here) the sweep
    says so in one line and waits; a new worker finishes it. With --no-worker-timeout it ends instead (exit 1)."""
    import ugpcl.sweep

    monkeypatch.setattr(ugpcl.sweep, "NO_WORKER_SECONDS", 2.0)
    scheduler, address = start_scheduler(tmp_path)
    workers = []
    try:
        for give_up in (False, True):
            out = tmp_path / f"runs-{give_up}"
            argv = ["sweep", "boids", "--set", "max_object_num=1024", "--steps", "300", "--quiet", "--seeds", "0-5"]
            argv += ["--out", str(out), "--scheduler", address] + (["--no-worker-timeout"] if give_up else [])
            workers.append(start_worker(address, tmp_path / f"w{len(workers)}", "--no-nanny"))
            result: dict = {}
            thread = threading.Thread(target=lambda a=argv, r=result: r.setdefault("code", main(a)))
            thread.start()
            deadline = time.monotonic() + 120
            while not ok_rows(out) and time.monotonic() < deadline:
                time.sleep(0.05)
            workers[-1].kill()
            workers[-1].wait(timeout=30)
            if give_up:
                thread.join(timeout=60)
                assert not thread.is_alive() and result["code"] == 1
                err = capsys.readouterr().err
                assert "no live worker for 2 s with" in err and "(--no-worker-timeout)" in err, err
            else:
                deadline = time.monotonic() + 60
                said = ""
                while "no live worker" not in said and time.monotonic() < deadline:
                    time.sleep(0.2)
                    said += capsys.readouterr().err
                assert "ugpcl: sweep: no live worker for 2 s" in said and thread.is_alive(), said
                workers.append(start_worker(address, tmp_path / f"w{len(workers)}"))
                thread.join(timeout=120)
                assert not thread.is_alive() and result["code"] == 0
                assert len(ok_rows(out)) == 6
                workers[-1].kill()  # the next sweep starts with a single worker again
                workers[-1].wait(timeout=30)
    finally:
        for process in [*workers, scheduler]:
            process.kill()
            process.wait(timeout=30)


def test_a_relative_out_lands_under_the_clients_folder_with_a_worker_started_elsewhere(capsys, tmp_path, monkeypatch):
    """A real scheduler and worker (separate processes on 127.0.0.1, the worker in its own folder), a relative
    --out given in the client's folder: every file lands under the client's folder, none in the worker's, and a
    rerun runs nothing."""
    client_dir, worker_dir = tmp_path / "client", tmp_path / "worker"
    client_dir.mkdir()
    scheduler, address = start_scheduler(tmp_path)
    worker = start_worker(address, worker_dir)
    try:
        monkeypatch.chdir(client_dir)
        argv = [*BOIDS, "--seeds", "0-1", "--out", "runs", "--scheduler", address]
        code, out, err = run(capsys, *argv)
        assert code == 0 and "2 ok, 0 failed, 0 finished before" in out, err
        assert sorted(p.name for p in landed(client_dir / "runs")) == ["seed=0.npz", "seed=1.npz"]
        assert not list(worker_dir.rglob("*.npz")) and not (worker_dir / "runs").exists()
        code, out, _ = run(capsys, *argv)
        assert code == 0 and "0 ok, 0 failed, 2 finished before" in out, out
    finally:
        for process in (worker, scheduler):
            process.terminate()
            process.wait(timeout=30)
