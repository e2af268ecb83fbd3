"""Ctrl-C and SIGTERM end a run within two seconds even while the device is busy with a kernel that runs for
minutes (ugpcl.stopping): exit 128 + the signal, one line, no traceback, the previous output untouched."""

from __future__ import annotations

import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

UGPCL = str(Path(sys.executable).parent / "ugpcl")

# On PoCL each of these sits for minutes inside the device: a burn-in of 100,000 Metropolis sweeps per chain, and
# one all-pairs step of four million boids (2^44 interactions).
LONG_RUNS = {
    "mcmc burn-in": ["mcmc", "--set", "burn_in=100000"],
    "boids all-pairs": ["boids", "--set", "max_object_num=4194304", "variant=naive"],
}


@pytest.mark.parametrize("sig", ["SIGTERM", "SIGINT"])
@pytest.mark.parametrize("run", LONG_RUNS, ids=lambda r: r.replace(" ", "-"))
def test_a_signal_ends_a_run_stuck_in_a_long_kernel_within_two_seconds(runtime, tmp_path, run, sig):
    if runtime.is_gpu:
        pytest.skip("the runs are long only on a CPU device; on a GPU they finish before the signal")
    out = tmp_path / "x.npz"
    out.write_bytes(b"the previous result")
    argv = [UGPCL, "run", *LONG_RUNS[run], "--steps", "3", "--quiet", "--out", str(out)]
    proc = subprocess.Popen(argv, stderr=subprocess.PIPE, text=True)
    assert proc.stderr.readline().startswith("ugpcl: ")  # the run has opened its device
    time.sleep(2.0)  # building and launching: the kernel is running now
    assert proc.poll() is None, "the run ended before the signal: it is not long enough to test this"
    sent = time.monotonic()
    proc.send_signal(getattr(signal, sig))
    code = proc.wait(timeout=30)
    took = time.monotonic() - sent
    err = proc.stderr.read()
    assert code == 128 + getattr(signal, sig) and took < 2.0, (code, took, err)
    assert "Traceback" not in err and err.strip().splitlines()[-1].startswith("ugpcl: "), err
    assert out.read_bytes() == b"the previous result"
