"""The bare package and its extras: a command that needs a missing extra is refused before it runs, in one line
naming the extra (exit 2). Missing modules are simulated here (``find_spec`` says None); .ci/wheel-check installs
the bare wheel in a fresh venv and checks the same lines for real."""

from __future__ import annotations

import importlib.util

import pytest

from ugpcl import extras
from ugpcl.cli import main, view


@pytest.fixture
def without(monkeypatch):
    """Make the given top-level modules look uninstalled to ``find_spec``."""

    def hide(*names):
        real = importlib.util.find_spec

        def find_spec(name, *args):
            return None if name.split(".")[0] in names else real(name, *args)

        monkeypatch.setattr(extras, "find_spec", find_spec)
        return find_spec

    return hide


@pytest.mark.parametrize(
    "hidden, argv, says",
    [
        (("moderngl",), ["run", "boids", "--png", "x.png"], "--png needs the render extra (moderngl not installed)"),
        (("imageio",), ["run", "boids", "--video", "x.mp4"], "--video (MP4) needs the video extra (imageio not"),
        (("trimesh",), ["run", "marching_cubes", "--mesh", "m.glb"], "--mesh (.glb) needs the render extra"),
        (("dask",), ["sweep", "boids", "--seeds", "0", "--out", "s"], "ugpcl sweep needs the sweep extra"),
    ],
)
def test_a_missing_extra_is_one_line_naming_it(capsys, tmp_path, monkeypatch, without, hidden, argv, says):
    monkeypatch.chdir(tmp_path)
    without(*hidden)
    code = main(argv)
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and says in err[0], err
    extra = says.split(" extra")[0].split()[-1]
    assert err[0].endswith(f"pip install 'ugpcl[{extra}]'") and not list(tmp_path.iterdir())


def test_the_viewer_without_its_extra(capsys, without):
    without("imgui_bundle", "moderngl_window")
    assert view(["boids"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [
        "ugpcl-view: error: ugpcl-view needs the viewer extra (moderngl_window, imgui_bundle not installed): "
        "pip install 'ugpcl[viewer]'"
    ]


def test_a_headless_run_needs_no_extra(capsys, tmp_path, monkeypatch, without):
    monkeypatch.chdir(tmp_path)
    without(*{m for modules in extras.EXTRAS.values() for m in modules})
    assert main(["run", "boids", "--steps", "2", "--set", "max_object_num=256", "--out", "x.npz", "--quiet"]) == 0
