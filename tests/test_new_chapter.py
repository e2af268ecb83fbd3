"""docs/adding-a-chapter.md works, and the chapter pages are numbered by ``ugpcl.docs.CHAPTERS``.

The guide's template chapter (its code blocks, each under a line ``File `path`:``) is written into a temporary folder
and found the way a chapter of one's own is, through ``UGPCL_SCENES`` and ``UGPCL_KERNELS``. In fresh processes it
must pass the tests that loop over every scene, its own test module (reference, invariants, view, Oclgrind), and
``ugpcl list``, ``params``, ``run`` and ``bench``. The registry and kernel-folder lookups behind that are tested here
too.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from test_kernel_names import defined_kernels, listed_kernels

import ugpcl.scenes
from ugpcl import registry
from ugpcl.buffers import Pool
from ugpcl.docs import CHAPTERS, ROOT, chapter_doc, chapter_page
from ugpcl.runtime import KERNEL_DIR, BuildError, kernel_dirs, kernel_file

GUIDE = ROOT / "docs" / "adding-a-chapter.md"
FILE_BLOCK = re.compile(r"^File `([^`]+)`:\n\n```\w*\n(.*?)^```$", re.M | re.S)
STEM = "decay"
TEMPLATE = {
    f"clkernels/{STEM}.cl",
    f"ugpcl/scenes/{STEM}.py",
    f"ugpcl/bench/{STEM}.py",
    f"viewer/views/{STEM}.py",
    f"tests/test_{STEM}.py",
}
"""The template chapter's files, at the paths they would have in the repository."""

GENERIC = (
    "tests/test_params.py",
    "tests/test_interactive.py",
    "tests/test_panel.py",
    "tests/test_properties.py",
    "tests/test_api.py",
)
"""Test modules that loop over every scene of the registry and neither render nor open a window (test_docs.py and
test_animations.py judge pictures the template has no business committing; test_window.py opens a window)."""
SELECT = f"{STEM} or test_params or test_api"
"""``-k``: the template's cases of the modules parametrised by scene name, and test_params.py and test_api.py whole
(they may loop over the scenes inside one test)."""

PLUGIN = '''"""pytest -p template_chapter: the template's scene module loaded by the registry (UGPCL_SCENES), so that
``import ugpcl.scenes.decay`` works, and its view found where the viewer looks for views."""

from __future__ import annotations

from pathlib import Path

import ugpcl.viewer.views
from ugpcl.registry import modules

modules()
ugpcl.viewer.views.__path__.append(str(Path(__file__).resolve().parents[1] / "viewer" / "views"))
'''

BENCH = """import sys

import ugpcl.bench
from ugpcl.cli import main
from ugpcl.registry import modules

modules()  # ugpcl.scenes.decay, from UGPCL_SCENES, which the bench imports
ugpcl.bench.__path__.append(sys.argv[1])  # where `ugpcl bench` looks for ugpcl/bench/<stem>.py
sys.exit(main(["bench", sys.argv[2], "--size", "4096", "65536"]))
"""

SUBPROCESS_SECONDS = 300


def guide_files() -> dict[str, str]:
    """{path: text} of the guide's code blocks that a ``File `path`:`` line names."""
    return {m[1]: m[2] for m in FILE_BLOCK.finditer(GUIDE.read_text())}


@pytest.fixture(scope="module")
def chapter(tmp_path_factory) -> Path:
    """A folder holding the guide's template chapter in the repository's layout, and the pytest plugin above. The
    subprocesses run in its parent (its ugpcl/ folder, first on sys.path, would hide the package)."""
    root = tmp_path_factory.mktemp("chapter") / "tree"
    for name, text in guide_files().items():
        path = root / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
    (root / "plugins").mkdir(parents=True)
    (root / "plugins" / "template_chapter.py").write_text(PLUGIN)
    return root


def run(chapter: Path, *argv: str, **env: str) -> subprocess.CompletedProcess:
    """``python argv`` with the template chapter's folders in UGPCL_SCENES and UGPCL_KERNELS, run in the chapter's
    folder (what a run leaves in its working folder, such as ImGui's imgui.ini, stays out of the checkout)."""
    environment = {
        **os.environ,
        "UGPCL_SCENES": str(chapter / "ugpcl" / "scenes"),
        "UGPCL_KERNELS": str(chapter / "clkernels"),
        **env,
    }
    return subprocess.run(
        [sys.executable, *argv],
        cwd=chapter.parent,
        env=environment,
        capture_output=True,
        text=True,
        timeout=SUBPROCESS_SECONDS,
    )


def output(result: subprocess.CompletedProcess, lines: int = 60) -> str:
    """The end of a subprocess's output, for a failure message."""
    return "\n".join((result.stdout + result.stderr).splitlines()[-lines:])


# {{{ the guide's template chapter


def test_the_guide_holds_every_file_of_the_template():
    files = guide_files()
    assert set(files) == TEMPLATE, f"the guide's `File` blocks: {sorted(files)}"
    for name in files:
        assert (ROOT / name).parent.is_dir(), f"{name}: no such folder in the repository"
        assert not (ROOT / name).exists(), f"{name}: the template's stem is taken by a real chapter"


def test_the_template_kernel_file_lists_its_kernels():
    source = guide_files()[f"clkernels/{STEM}.cl"]
    assert listed_kernels(source) == defined_kernels(source) == ["Decay"]


def test_the_generic_tests_pass_for_the_template_scene(chapter):
    result = run(
        chapter,
        *("-m", "pytest", "-p", "no:cacheprovider", "-v", "-m", "not gl and not oclgrind", "-k", SELECT),
        *(str(ROOT / module) for module in GENERIC),
    )
    assert result.returncode == 0, output(result)
    passed = re.findall(r"^\S*/(test_\w+\.py)::(.+?) PASSED", result.stdout, re.M)
    assert {module for module, _ in passed} == {Path(module).name for module in GENERIC}, output(result)
    ours = [name for _, name in passed if STEM in name]
    assert ours, f"no test case of scene {STEM!r} was collected:\n{output(result)}"


def test_the_template_test_module_passes(chapter):
    """Its reference, invariant, view and Oclgrind tests, with the repository's fixtures (``-p conftest``)."""
    result = run(
        chapter,
        *("-m", "pytest", "-p", "no:cacheprovider", "-v", "-c", str(ROOT / "setup.cfg")),
        *("-p", "conftest", "-p", "template_chapter", str(chapter / "tests" / f"test_{STEM}.py")),
        PYTHONPATH=os.pathsep.join(
            [str(ROOT / "tests"), str(chapter / "plugins"), *filter(None, [os.environ.get("PYTHONPATH")])]
        ),
    )
    assert result.returncode == 0, output(result)
    passed = re.findall(r"::(\w+)(?:\[.*?\])? PASSED", result.stdout)
    assert {"test_view_draws_a_line_per_value_as_high_as_the_value", "test_decay_on_oclgrind"} <= set(passed)
    assert " skipped" not in result.stdout.splitlines()[-1], output(result)


def test_ugpcl_lists_describes_and_runs_the_template_scene(chapter):
    listed = run(chapter, "-m", "ugpcl", "list")
    assert listed.returncode == 0, output(listed)
    names = [line.split()[0] for line in listed.stdout.splitlines() if line.strip()]
    assert {"boids", STEM, f"{STEM}_fast"} <= set(names), listed.stdout
    params = run(chapter, "-m", "ugpcl", "params", STEM)
    assert params.returncode == 0, output(params)
    rows = {line.split()[0]: line for line in params.stdout.splitlines()[2:]}
    assert set(rows) == {"count", "rate", "amplitude"} and "Number of values N." in rows["count"], params.stdout
    out = chapter / "out" / "x.npz"
    ran = run(chapter, "-m", "ugpcl", "run", STEM, "--steps", "5", "--out", str(out))
    assert ran.returncode == 0, output(ran)
    with np.load(out) as saved:
        assert saved["value"].shape == (4096,) and saved["value"].dtype == np.float32
        assert int(saved["steps"]) == 5 and str(saved["scene"]) == STEM


def test_ugpcl_bench_prints_the_template_rows_with_their_device_shares(chapter):
    result = run(chapter, "-c", BENCH, str(chapter / "ugpcl" / "bench"), STEM)
    assert result.returncode == 0, output(result)
    assert f"## {STEM}" in result.stdout and "bytes/s" in result.stdout and "% copy bw" in result.stdout, result.stdout


# }}}

# {{{ UGPCL_SCENES and UGPCL_KERNELS


@pytest.fixture
def fresh_registry(monkeypatch):
    """The registry read again under the test's UGPCL_SCENES; afterwards as it was (the package's scenes only)."""
    before = set(sys.modules)
    registry.modules.cache_clear()
    registry.scenes.cache_clear()
    yield monkeypatch
    registry.modules.cache_clear()
    registry.scenes.cache_clear()
    for name in set(sys.modules) - before:
        if name.startswith("ugpcl.scenes."):
            del sys.modules[name]


def test_scene_folders_are_loaded_after_the_package_as_its_modules(tmp_path, fresh_registry):
    first, second = tmp_path / "first", tmp_path / "second"
    first.mkdir()
    second.mkdir()
    (first / f"{STEM}.py").write_text(guide_files()[f"ugpcl/scenes/{STEM}.py"])
    (first / "_helper.py").write_text("raise AssertionError('a private module is not a chapter')\n")
    (second / "second_template.py").write_text("from ..scenes.decay import SCENES as FIRST\n\nSCENES = []\n")
    fresh_registry.setenv("UGPCL_SCENES", os.pathsep.join([str(first), "", str(second)]))
    stems = list(registry.modules())
    assert stems[-2:] == [STEM, "second_template"] and "boids" in stems[:-2], "the package's modules come first"
    module = registry.modules()[STEM]
    assert module.__name__ == f"ugpcl.scenes.{STEM}" and sys.modules[module.__name__] is module
    assert registry.get(STEM).stem == STEM and registry.get(f"{STEM}_fast").params().rate == 5.0
    assert registry.modules()["second_template"].FIRST is module.SCENES, "a later module imports an earlier one"


def test_a_scene_folder_that_is_missing_or_takes_a_package_stem_is_one_line(tmp_path, fresh_registry):
    fresh_registry.setenv("UGPCL_SCENES", str(tmp_path / "absent"))
    with pytest.raises(ValueError, match=r"^UGPCL_SCENES: .*absent is not a folder$"):
        registry.modules()
    (tmp_path / "boids.py").write_text("SCENES = []\n")
    fresh_registry.setenv("UGPCL_SCENES", str(tmp_path))
    with pytest.raises(ValueError, match=r"boids.py has the stem of the scene module .*scenes/boids.py; rename it$"):
        registry.modules()


APPEND = """#include "pool.h"
__kernel void AppendAll(__global int* counter, __global int* items, const int capacity)
{
    pool_append_index(counter, items, capacity, (int)get_global_id(0));
}
"""


def test_kernel_folders_are_searched_first_and_the_headers_stay_the_packages(runtime, tmp_path, monkeypatch):
    first, second = tmp_path / "first", tmp_path / "second"
    (first / "include").mkdir(parents=True)
    second.mkdir()
    (first / "ugpcl_folder_test.cl").write_text(APPEND)
    (first / "include" / "pool.h").write_text('#error "a kernel folder\'s include/ is not on the include path"\n')
    (second / "ugpcl_folder_test.cl").write_text('#error "the first folder that has the file wins"\n')
    (second / "boids.cl").write_text('#error "an edited copy"\n')
    monkeypatch.setenv("UGPCL_KERNELS", os.pathsep.join([str(first), str(second)]))
    assert kernel_dirs() == [first, second, KERNEL_DIR]
    assert kernel_file("ugpcl_folder_test") == first / "ugpcl_folder_test.cl"
    assert kernel_file("boids") == second / "boids.cl", "a package stem in a kernel folder is used instead"
    assert kernel_file("sph_2d") == KERNEL_DIR / "sph_2d.cl", "every other stem is the package's"
    program = runtime.program("ugpcl_folder_test")  # with the package's pool.h, not first/include/pool.h
    assert program.path == first / "ugpcl_folder_test.cl"
    pool = Pool(runtime, 8)
    program.kernel("AppendAll")(10, None, pool.counter, pool.items, pool.capacity)
    items = pool.read()
    assert pool.counts() == (8, 2) and len(set(items)) == 8 and set(items) <= set(range(10))
    with pytest.raises(BuildError, match=r"ugpcl_absent.cl: no such kernel file in .*first, .*second, "):
        runtime.program("ugpcl_absent")


# }}}

# {{{ chapter pages: one table


PAGE = re.compile(r"(\d{2})-([a-z0-9]+(?:-[a-z0-9]+)*)\.md")


def test_every_chapter_page_has_the_number_and_title_of_its_stem_in_the_table():
    pages = sorted((ROOT / "docs" / "chapters").glob("*.md"))
    for page in pages:
        name = PAGE.fullmatch(page.name)
        assert name, f"{page.name}: not NN-<stem>.md"
        stem = name[2].replace("-", "_")
        assert stem in CHAPTERS, f"{page.name}: add {stem!r} to ugpcl.docs.CHAPTERS"
        number, title = CHAPTERS[stem]
        assert int(name[1]) == number, f"{page.name}: CHAPTERS numbers {stem} {number}"
        assert page.read_text().splitlines()[0] == f"# {title}", f"{page.name}: the first line is not '# {title}'"
    assert sorted(chapter_page(stem) for stem in CHAPTERS) == pages, "every entry of CHAPTERS has its page"
    numbers = [number for number, _ in CHAPTERS.values()]
    assert numbers == sorted(numbers), "CHAPTERS lists the chapters in the books' order"


def test_every_scene_of_the_package_is_documented_on_a_chapter_page():
    package = Path(ugpcl.scenes.__file__).parent
    ours = {
        name: scene
        for name, scene in registry.scenes().items()
        if Path(sys.modules[scene.simulation.__module__].__file__).parent == package
    }
    assert [name for name, scene in ours.items() if chapter_doc(scene) is None] == []


# }}}
