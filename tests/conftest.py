"""Fixtures shared by every test module: the PoCL runtime, the Oclgrind runtime with its report check, GL."""

from __future__ import annotations

import gc
import os
import re
import sys

# Oclgrind reads its options when its ICD loads, i.e. at the first platform enumeration: set them before that.
os.environ.setdefault("OCLGRIND_DATA_RACES", "1")
# Tables wrap to the terminal: every test (and every command it starts) sees the same width, whether pytest runs
# in a terminal, in CI or in an xdist worker. Tests of the wrapping set their own.
os.environ["COLUMNS"] = "160"

import pytest  # noqa: E402

from ugpcl.runtime import Runtime  # noqa: E402

OCLGRIND_REPORT = re.compile(r"Kernel: |data race|Invalid (read|write)|divergence|Uninitiali[sz]ed|Oclgrind -")


def pytest_collection_modifyitems(items: list) -> None:
    """Oclgrind tests first: once Mesa has loaded its LLVM for a GL test, an Oclgrind build crashes the process."""
    items.sort(key=lambda item: item.get_closest_marker("oclgrind") is None)  # a stable sort keeps file order


_oclgrind: list[Runtime] = []  # the Oclgrind runtime, kept to the end (see pytest_unconfigure)


def pytest_sessionfinish(session, exitstatus) -> None:
    session.config.stash[EXIT_STATUS] = int(exitstatus)


EXIT_STATUS = pytest.StashKey[int]()


def pytest_unconfigure(config) -> None:
    """Freeing Oclgrind's OpenCL objects once Mesa has loaded its own LLVM (an EGL context) segfaults, as an
    Oclgrind build does (pytest_collection_modifyitems). make test and make test-oclgrind never load both; a run of
    both kinds (e.g. `pytest tests/test_cloth.py`) frees the Oclgrind tests' garbage after each of them (they run
    first, before any GL) and keeps the Oclgrind runtime itself to the end, then leaves without the interpreter's
    teardown, with pytest's own exit status."""
    if _oclgrind and "glcontext.egl" in sys.modules:
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(config.stash.get(EXIT_STATUS, 0))


@pytest.fixture(scope="session")
def runtime() -> Runtime:
    """The device under test: UGPCL_DEVICE if set (e.g. nvidia on the GPU machine), else PoCL."""
    return Runtime(os.environ.get("UGPCL_DEVICE") or "pocl")


@pytest.fixture(scope="session")
def _oclgrind_runtime() -> Runtime:
    _oclgrind.append(Runtime("oclgrind"))
    return _oclgrind[0]


@pytest.fixture
def oclgrind(_oclgrind_runtime, capfd):
    """The Oclgrind simulator; the test fails if Oclgrind printed any report (races, out-of-bounds, divergence)."""
    capfd.readouterr()
    yield _oclgrind_runtime
    _oclgrind_runtime.finish()
    gc.collect()  # free the test's Oclgrind objects now, before a GL test loads Mesa (see pytest_unconfigure)
    err = capfd.readouterr().err
    reports = [block.strip() for block in err.split("\n\n") if OCLGRIND_REPORT.search(block)]
    assert not reports, f"Oclgrind reported {len(reports)} problem(s); the first:\n{reports[0]}"


@pytest.fixture
def seed() -> int:
    return 20260522


@pytest.fixture(scope="session")
def gl_context(runtime):
    """One EGL context for the session, created after OpenCL (see ugpcl.runtime.all_devices)."""
    from ugpcl.viewer.offscreen import context

    return context()


@pytest.fixture
def gl(gl_context):
    """The GL context, with no GL error before or after the test."""
    assert gl_context.error == "GL_NO_ERROR"
    yield gl_context
    assert gl_context.error == "GL_NO_ERROR"
