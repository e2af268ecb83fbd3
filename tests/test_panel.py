"""The viewer's parameter panel (viewer/panel.py): the widget each Params field gets, and how a change reaches the
simulation (live at once, the others after "reset to apply"). No window: the ImGui layer runs in a headless context
with synthetic mouse events."""

from __future__ import annotations

import dataclasses
import typing

import numpy as np
import pytest
from imgui_bundle import imgui
from ugpcl.viewer.panel import INT_LIMIT, LOG_SPAN, OPEN_END, Panel, draw_widget, widgets

from ugpcl.registry import get, scenes


def expected_kind(kind, meta, name) -> str:
    """The widget a field should get, from its type and metadata alone."""
    parts = typing.get_args(kind) if typing.get_origin(kind) is tuple else (kind,)
    if meta.get("choices") is not None:
        return "combo"
    if parts == (bool,):
        return "checkbox"
    if parts == (str,):
        return "text"
    if typing.get_origin(kind) is tuple:
        is_color = name.endswith("color") and (meta["lo"], meta["hi"]) == (0, 1) and len(parts) in (3, 4)
        return "color" if is_color else "drag"
    return "slider"


@pytest.mark.parametrize("name", sorted(scenes()))
def test_every_field_gets_the_widget_of_its_type_with_its_range_and_doc(name):
    scene = get(name)
    defaults = scene.params()
    cls = type(defaults)
    hints = typing.get_type_hints(cls)
    docs = {row["name"]: row["meaning"] for row in cls.table()}
    shown = widgets(defaults)
    assert [w.name for w in shown] == cls.names()
    for f, widget in zip(dataclasses.fields(cls), shown, strict=True):
        meta = f.metadata
        assert widget.kind == expected_kind(hints[f.name], meta, f.name), f.name
        assert widget.live == (f.name in cls.live_names()), f.name
        assert docs[f.name] and widget.tooltip.startswith(docs[f.name]), f.name
        if widget.kind in ("slider", "drag"):
            clamp = INT_LIMIT if widget.integer else float("inf")
            lo, hi = max(meta["lo"], -clamp), min(meta["hi"], clamp)
            if meta["lo_open"]:  # the widget never offers the excluded end
                lo = lo + 1 if widget.integer else lo + (hi - lo) * OPEN_END
            assert (widget.lo, widget.hi) == (lo, hi), f.name
            value = getattr(defaults, f.name)
            scale = float(np.abs(value).max()) or 1.0
            decades = widget.hi - widget.lo >= LOG_SPAN * scale or 0 < widget.lo * LOG_SPAN <= widget.hi
            assert widget.log == decades, f.name
        if widget.kind == "combo":
            assert widget.choices == tuple(meta["choices"])


def test_spot_checks_of_the_mapping():
    boids = {w.name: w for w in widgets(get("boids").params())}
    assert boids["max_object_num"].kind == "slider" and boids["max_object_num"].log  # 1 .. 4194304
    assert boids["wall_center"].kind == "drag" and boids["wall_center"].components == 3
    assert boids["variant"].choices == ("auto", "tiled", "lanes", "naive", "grid")
    assert "resets" in boids["max_object_num"].tooltip and "resets" not in boids["max_speed"].tooltip
    fluids = {w.name: w for w in widgets(get("marching_cubes").params())}
    assert fluids["threshold"].kind == "slider" and not fluids["threshold"].log  # [0, 1]: linear
    assert fluids["diffuse_color"].kind == "color"
    sph = {w.name: w for w in widgets(get("sph_2d").params())}
    assert sph["mouse"].types == (float, float, int)
    assert sph["mouse"].coerce([1.5, 2.5, 0.9]) == (1.5, 2.5, 1)  # the GUI hands back floats
    assert {w.name: w for w in widgets(get("cloth").params())}["sphere"].kind == "checkbox"
    assert {w.name: w for w in widgets(get("ear_clipping").params())}["text"].kind == "text"


@pytest.fixture
def boids(runtime):
    scene = get("boids")
    sim = scene.create(runtime, seed=3, max_object_num=256)
    return sim, Panel(sim, sim.params)


def test_a_live_change_reaches_the_simulation_at_once(boids):
    sim, panel = boids
    for _ in range(5):
        sim.step()
    assert np.linalg.norm(sim.state()["velocity"][:, :3], axis=1).max() > 0.1
    max_speed = next(w for w in panel.widgets if w.name == "max_speed")
    assert panel.set(max_speed, 0.05)
    assert sim.params.max_speed == 0.05 and sim.steps == 5 and not panel.pending  # no reset
    sim.step()
    speeds = np.linalg.norm(sim.state()["velocity"][:, :3], axis=1)
    assert speeds.max() <= 0.05 * (1 + 1e-5), "IntegrateCS did not see the new max_speed"


def test_a_change_that_needs_a_reset_waits_for_reset_to_apply(boids):
    sim, panel = boids
    sim.step()
    count = next(w for w in panel.widgets if w.name == "max_object_num")
    assert panel.set(count, 512.0)  # a slider hands back what it holds
    assert panel.pending == {"max_object_num": 512} and panel.value("max_object_num") == 512
    assert sim.params.max_object_num == 256 and len(sim.state()["position"]) == 256 and sim.steps == 1
    assert panel.apply()
    assert not panel.pending and sim.steps == 0
    assert sim.params.max_object_num == 512 and len(sim.state()["position"]) == 512
    assert panel.set(count, 256) and panel.pending == {"max_object_num": 256}
    panel.revert()
    assert not panel.pending and sim.params.max_object_num == 512


def test_a_value_out_of_range_is_refused_with_the_range(boids):
    sim, panel = boids
    max_speed = next(w for w in panel.widgets if w.name == "max_speed")
    assert not panel.set(max_speed, -1.0)
    assert "max_speed" in panel.error and "(0.0, 10000.0]" in panel.error
    assert sim.params.max_speed == 5.0
    assert panel.set(max_speed, 2.0) and panel.error == ""


def test_defaults_restores_the_start_parameters(boids):
    sim, panel = boids
    panel.set(next(w for w in panel.widgets if w.name == "separate_weight"), 9.0)
    panel.set(next(w for w in panel.widgets if w.name == "max_object_num"), 1024)
    assert panel.restore_defaults()
    assert sim.params == panel.defaults and not panel.pending


# {{{ the ImGui layer, headless


@pytest.fixture
def gui():
    """A headless ImGui context: no window, no GL (ImGui builds its font atlas on the CPU)."""
    context = imgui.create_context()
    io = imgui.get_io()
    io.display_size = (800, 600)
    io.backend_flags |= imgui.BackendFlags_.renderer_has_textures
    yield io
    imgui.destroy_context(context)


def frames(io, widget, value, events=()):
    """Draw ``widget`` once per frame, feeding ``events[i]`` (a function of io) before frame i, after two frames
    in which a new ImGui window appears; the last value."""
    for event in [None, None, *events, None]:
        if event:
            event(io)
        io.delta_time = 1 / 60
        imgui.new_frame()
        imgui.set_next_window_pos((0, 0))
        imgui.set_next_window_size((400, 600))
        imgui.begin("panel", flags=imgui.WindowFlags_.no_title_bar)
        changed, got = draw_widget(imgui, widget, value)
        value = widget.coerce(got) if changed else value
        imgui.end()
        imgui.render()
    return value


def drag(x0, x1, y=12):
    """Press at (x0, y), move to (x1, y), release: one event per frame."""
    return [
        lambda io: io.add_mouse_pos_event(x0, y),
        lambda io: io.add_mouse_button_event(0, True),
        lambda io: io.add_mouse_pos_event((x0 + x1) / 2, y),
        lambda io: io.add_mouse_pos_event(x1, y),
        lambda io: io.add_mouse_button_event(0, False),
    ]


@pytest.mark.parametrize("name", sorted(scenes()))
def test_every_widget_draws_and_holds_its_value(gui, name):
    defaults = get(name).params()
    for widget in widgets(defaults):
        value = getattr(defaults, widget.name)
        held = frames(gui, widget, value)
        assert held == value, widget.name


def test_dragging_a_slider_a_drag_and_clicking_a_checkbox_change_the_value(gui):
    shown = {w.name: w for w in widgets(get("boids").params())}
    slowest = frames(gui, shown["max_speed"], 5.0, drag(100, 0))  # to the left end of (0, 10000]
    assert slowest == pytest.approx(10000 * OPEN_END) and get("boids").params(max_speed=slowest)
    assert frames(gui, shown["max_speed"], 5.0, drag(100, 400)) == 10000.0
    moved = frames(gui, shown["wall_size"], (32.0, 32.0, 32.0), drag(40, 90))
    assert moved[0] > 32.0 and moved[1:] == (32.0, 32.0)
    sphere = {w.name: w for w in widgets(get("cloth").params())}["sphere"]
    assert frames(gui, sphere, True, [lambda io: io.add_mouse_pos_event(16, 16)] + drag(16, 16, 16)[1:]) is False


# }}}
