"""No silent no-ops: a parameter that other settings leave unused is declared so beside its field
(``param(ignored_when=...)``, ``param(used_only_when=...)``), shown by ``ugpcl params`` and on the chapter pages, and
said when a user sets it (``ugpcl run --set``, ``Scene.create``, ``Simulation.update``). Parameter checks only, but
for one ``ugpcl run`` of one step."""

from __future__ import annotations

import dataclasses
import json
import subprocess
import sys
import typing
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from ugpcl.cli import main
from ugpcl.registry import get, scenes
from ugpcl.scene import ParameterIgnored, Params, Unused, param, warn_ignored

FIRST_SCENE = {}
for _scene in scenes().values():
    FIRST_SCENE.setdefault(_scene.simulation.Params, _scene)
"""One scene per Params class: its defaults are the base every case starts from."""

DEPENDENCIES = [(scene, d) for cls, scene in FIRST_SCENE.items() for d in cls.dependencies()]
"""Every declared dependency of every scene, collected from the Params classes."""


def _input_file(stem: str, folder: Path) -> str:
    """A file that a free-text ``input`` setting of chapter ``stem`` takes (other than its ``used_only_when``
    value), which the parameter checks read."""
    if stem == "ear_clipping":
        path = folder / "rings.json"
        path.write_text(json.dumps({"rings": [[[0, 0], [4, 0], [0, 4]]]}))
        return str(path)
    if stem == "star_glow":
        path = folder / "frame.npy"
        np.save(path, np.full((16, 16, 3), 2.0, np.float32))
        return str(path)
    raise AssertionError(f"no input file for {stem}: add one here")


def _other(scene, setting: str, values: tuple, folder: Path):
    """A value of ``setting`` that is none of ``values``, valid for the scene's Params."""
    cls = scene.simulation.Params
    f = next(f for f in dataclasses.fields(cls) if f.name == setting)
    kind = typing.get_type_hints(cls)[setting]
    if f.metadata.get("choices") is not None:
        return next(c for c in f.metadata["choices"] if c not in values)
    if kind is bool:
        return not values[0]
    if kind is str:
        return _input_file(scene.stem, folder)
    return next(v for v in (values[0] + 1, values[0] - 1) if v not in values)


def _using(scene, d: Unused, folder: Path):
    """A value of d.setting under which d does not leave its field unused."""
    return _other(scene, d.setting, d.values, folder) if d.equal else d.values[0]


def _holding(scene, d: Unused, folder: Path):
    """A value of d.setting under which d leaves its field unused."""
    return d.values[0] if d.equal else _other(scene, d.setting, d.values, folder)


@pytest.mark.parametrize(
    "scene, d", DEPENDENCIES, ids=[f"{scene.name}.{d.field}:{d.rule}" for scene, d in DEPENDENCIES]
)
def test_each_declared_dependency_is_said_and_released(scene, d, tmp_path):
    """With only this condition holding, setting the field gives one line naming the field and the setting that
    overrides it (the same line as a ParameterIgnored warning); the setting at a using value gives none."""
    cls = scene.simulation.Params
    same_field = [other for other in cls.dependencies() if other.field == d.field]
    released = {other.setting: _using(scene, other, tmp_path) for other in same_field}
    used = scene.params(**released)
    assert not any(other.holds(used) for other in same_field)
    assert used.ignored({d.field}) == [], f"{d.field} is used with {released}"

    overridden = scene.params(**{**released, d.setting: _holding(scene, d, tmp_path)})
    assert d.holds(overridden)
    lines = overridden.ignored({d.field})
    assert len(lines) == 1 and lines[0].startswith(f"{d.field} is ignored while {d.setting}="), lines
    assert overridden.ignored(set()) == [] and overridden.ignored({d.setting}) == [], "only the field set is said"
    with pytest.warns(ParameterIgnored) as caught:
        warn_ignored(overridden, {d.field})
    assert [str(w.message) for w in caught] == lines


def test_dependencies_cover_the_known_overrides():
    """The issue's case and one of each kind: a flag, a mode, a variant of choices, a text input over a preset."""
    declared = {(scene.name, d.field, d.rule) for scene, d in DEPENDENCIES}
    assert {
        ("kleinian", "u", "use_uv_animation=true"),
        ("kleinian", "v", "use_uv_animation=true"),
        ("kleinian", "time_scale", "use_uv_animation=false"),
        ("kleinian", "samples", "mode=0"),
        ("kleinian", "circle", "mode!=2"),
        ("mcmc", "n", "mode!=pi"),
        ("star_glow", "color", "composite_type!=colored_additive|colored_screen"),
        ("ear_clipping", "preset", 'input!=""'),
        ("stable_fluids_2d", "visc", "density_only=true"),
    } <= declared


def test_the_issue_case_says_both_fields_in_one_line():
    p = get("kleinian").params(u=1.94, v=0.02)
    assert p.ignored({"u", "v"}) == ["u and v are ignored while use_uv_animation=true"]
    assert get("kleinian").params(u=1.94, use_uv_animation=False).ignored({"u", "use_uv_animation"}) == []
    circle = get("kleinian").params(circle=(1.0, 1.0), animator=True)  # two reasons at once: both said
    assert circle.ignored({"circle"}) == ["circle is ignored while animator=true and mode=0 (used only with mode=2)"]


def test_create_and_update_warn_once_per_call_site():
    """Scene.create and Simulation.update warn (ParameterIgnored) for the fields given, attributed to the caller's
    line, shown once per line by Python's default filter. Kleinian's reset builds nothing (a frame is rendered when
    state() asks), so no device is needed."""
    scene = get("kleinian")
    with warnings.catch_warnings(record=True) as caught:
        warnings.resetwarnings()  # Python's defaults: a UserWarning is shown once per location
        sim = scene.create(None, u=1.94)
        for _ in range(3):
            sim.update(v=0.1)  # three calls from one line: said once
        sim.update(v=0.2)  # another line: said again
        sim.update(use_uv_animation=False, u=1.9)  # u is used now: nothing
    assert [(w.category, str(w.message)) for w in caught] == [
        (ParameterIgnored, "u is ignored while use_uv_animation=true"),
        (ParameterIgnored, "v is ignored while use_uv_animation=true"),
        (ParameterIgnored, "v is ignored while use_uv_animation=true"),
    ]
    assert {w.filename for w in caught} == {__file__}


def test_scene_overrides_never_set_an_ignored_field():
    """The pictures (preview, animation) and the viewer's CPU sizes set only fields their settings use: `make png`,
    `make anim` and the viewer say nothing."""
    for name, scene in scenes().items():
        preview = {k: v for k, v in scene.preview.items() if k != "steps"}
        loop = {**preview, **(scene.animation.overrides if scene.animation else {})}
        for what, overrides in (("preview", preview), ("animation", loop), ("interactive", scene.interactive)):
            assert scene.params(**overrides).ignored(overrides) == [], f"{name} {what}"


def test_params_table_shows_the_dependencies(capsys):
    assert main(["params", "kleinian"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert "ignored when" in lines[0]
    row = next(line for line in lines if line.startswith("u "))
    assert "use_uv_animation=true" in row
    for scene in FIRST_SCENE.values():  # the column where a field of the scene declares one, and only there
        declared = scene.simulation.Params.dependencies()
        assert ("ignored when" in scene.table()[0]) == bool(declared), scene.name
        for row in scene.table():
            expected = " or ".join(d.rule for d in declared if d.field == row["name"])
            assert row.get("ignored when", "") == expected, (scene.name, row["name"])


def test_panel_tooltip_says_when_a_field_is_ignored():
    from ugpcl.viewer.panel import widgets

    shown = {w.name: w.tooltip for w in widgets(get("kleinian").params())}
    assert shown["u"].endswith("(ignored while use_uv_animation=true)")
    assert "ignored" not in shown["iteration"]


def test_a_declaration_that_names_no_field_or_a_bad_value_fails():
    @dataclass(frozen=True)
    class Unknown(Params):
        a: int = param(1, 0, 9, ignored_when={"b": True})

    @dataclass(frozen=True)
    class BadValue(Params):
        mode: int = param(0, choices=(0, 1))
        a: int = param(1, 0, 9, used_only_when={"mode": 2})

    with pytest.raises(AssertionError, match="Unknown.a: ignored_when names 'b', not another field"):
        Unknown()
    with pytest.raises(AssertionError, match=r"BadValue.a: used_only_when: mode must be one of 0\|1, got 2"):
        BadValue()


def test_run_says_an_ignored_set_in_one_line_and_goes_on(tmp_path):
    """The issue's command: the run goes on (exit 0) and says why u changes nothing, one line, no source line."""
    ugpcl = str(Path(sys.executable).parent / "ugpcl")
    argv = [ugpcl, "run", "kleinian", "--set", "u=1.94", "--steps", "1", "--out", str(tmp_path / "k.npz")]
    result = subprocess.run(argv, capture_output=True, text=True, timeout=120, cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    lines = result.stderr.splitlines()
    assert [line for line in lines if "ignored" in line] == ["ugpcl: warning: u is ignored while use_uv_animation=true"]
    assert len(lines) == 2 and lines[1].startswith("ugpcl: kleinian on "), lines  # and the usual device line
    assert (tmp_path / "k.npz").exists()
