"""The parameter panel: one widget per field of a scene's ``Params``, generated, never written per scene.

The model (which widget a field gets, its range, its tooltip, and how a change reaches the simulation) needs no
window and is what the tests drive; ``draw_widget`` is the thin Dear ImGui layer the viewer calls each frame.
A change to a live field (``param(..., live=True)``) goes to ``Simulation.update`` at once; the others wait in
``Panel.pending`` until ``apply()``, which resets the simulation (the "reset to apply" button).
"""

from __future__ import annotations

import dataclasses
import typing
from dataclasses import dataclass

from ugpcl import resources
from ugpcl.scene import Params, field_docs

LOG_SPAN = 1000.0
"""A range this many times wider than the field's default (or 1 where that is 0), or whose ends differ by this
factor, gets a logarithmic slider: a linear one from 0 to 10000 could not set a radius of 2."""
INT_LIMIT = 2**30 - 1
"""Largest integer an ImGui slider or drag can span to (it asserts a range within half the int32 range)."""
OPEN_END = 1e-6
"""Where the widget of a range open at its low end ``(lo, hi]`` stops: this fraction of the range above lo."""


@dataclass(frozen=True)
class Widget:
    """How the panel shows one Params field."""

    name: str
    kind: str
    """checkbox (bool), combo (choices), text (free str), color (a 3/4-tuple in [0, 1] named *color), slider (a
    number), drag (a tuple of numbers: one drag per component)."""
    types: tuple[type, ...]
    """Type of each component (a scalar has one)."""
    vector: bool = False
    """The field is a tuple (its value is one even with one component)."""
    lo: float | None = None
    hi: float | None = None
    log: bool = False
    speed: float = 1.0
    """Change per pixel of a drag."""
    choices: tuple = ()
    live: bool = False
    tooltip: str = ""

    @property
    def components(self) -> int:
        return len(self.types)

    @property
    def integer(self) -> bool:
        return all(t is int for t in self.types)

    def coerce(self, value):
        """``value`` as the field holds it: the GUI hands back floats and lists, a field may want ints and tuples."""
        if self.kind in ("checkbox", "text", "combo"):
            return value
        values = list(value) if self.vector else [value]
        typed = tuple(round(v) if t is int else float(v) for t, v in zip(self.types, values, strict=True))
        return typed if self.vector else typed[0]


def widget_for(f: dataclasses.Field, kind, default, doc: str, ignored_when: str = "") -> Widget:
    """The widget of field ``f`` of type ``kind`` whose scene default is ``default``; ``ignored_when``: the other
    settings that leave it unused (``Params.ignored_when``), said in the tooltip."""
    meta = f.metadata or {}
    vector = typing.get_origin(kind) is tuple
    parts = typing.get_args(kind) if vector else (kind,)
    tooltip = doc + ("" if meta.get("live") else " (changing it resets the simulation)")
    tooltip += f" (ignored while {ignored_when})" if ignored_when else ""
    common = {"name": f.name, "types": parts, "vector": vector, "live": bool(meta.get("live")), "tooltip": tooltip}
    if meta.get("choices") is not None:
        return Widget(kind="combo", choices=tuple(meta["choices"]), **common)
    if parts == (bool,):
        return Widget(kind="checkbox", **common)
    if parts == (str,):
        return Widget(kind="text", **common)
    lo, hi = meta.get("lo"), meta.get("hi")
    if vector and f.name.endswith("color") and (lo, hi) == (0.0, 1.0) and len(parts) in (3, 4):
        return Widget(kind="color", lo=lo, hi=hi, **common)
    bounded = lo is not None and hi is not None
    if bounded and parts[0] is int:  # ImGui integer widgets: within half the int32 range
        lo, hi = max(lo, -INT_LIMIT), min(hi, INT_LIMIT)
    if bounded and meta.get("lo_open"):  # (lo, hi]: the widget stops just above lo
        lo = lo + 1 if parts[0] is int else lo + (hi - lo) * OPEN_END
    scale = max(abs(d) for d in (default if vector else (default,))) or 1.0
    log = bounded and (hi - lo >= LOG_SPAN * scale or 0 < lo * LOG_SPAN <= hi)
    kind = "slider" if bounded and not vector else "drag"
    return Widget(kind=kind, lo=lo, hi=hi, log=log, speed=scale / 100.0, **common)


def widgets(defaults: Params) -> list[Widget]:
    """One widget per field of ``defaults``' class, in declaration order (the order of ``ugpcl params``)."""
    cls = type(defaults)
    hints, docs = typing.get_type_hints(cls), field_docs(cls)
    return [
        widget_for(f, hints[f.name], getattr(defaults, f.name), docs.get(f.name, ""), cls.ignored_when(f.name))
        for f in dataclasses.fields(cls)
    ]


class Panel:
    """What the panel shows of ``sim`` and how a change reaches it. ``set`` validates (a bad value or a broken
    rule across fields is kept in ``error``, not applied); live fields go to ``sim.update`` at once, the others to
    ``pending`` until ``apply()``."""

    def __init__(self, sim, defaults: Params):
        self.sim, self.defaults = sim, defaults
        self.widgets = widgets(defaults)
        self.pending: dict = {}
        self.error = ""

    def value(self, name: str):
        """What the widget shows: the pending value, else the simulation's."""
        return self.pending[name] if name in self.pending else getattr(self.sim.params, name)

    def set(self, widget: Widget, value) -> bool:
        """Take the user's ``value`` for ``widget``; False (and ``error`` says why) when the parameters refuse it."""
        value = widget.coerce(value)
        try:
            self.sim.params.replace(**{**self.pending, widget.name: value})  # validates ranges and limits
            if widget.live:
                self.sim.update(**{widget.name: value})
            elif value == getattr(self.sim.params, widget.name):
                self.pending.pop(widget.name, None)
            else:
                self.pending[widget.name] = value
        except ValueError as err:
            self.error = str(err)
            return False
        self.error = ""
        return True

    def apply(self) -> bool:
        """Apply the pending changes (the simulation resets); False with ``error`` when the device cannot hold them."""
        try:
            params = self.sim.params.replace(**self.pending)
            resources.check(type(self.sim), params, self.sim.runtime.device)
            self.sim.update(**self.pending)
        except ValueError as err:
            self.error = str(err)
            return False
        self.pending, self.error = {}, ""
        return True

    def revert(self) -> None:
        """Forget the pending changes."""
        self.pending, self.error = {}, ""

    def restore_defaults(self) -> bool:
        """The scene's start parameters (the simulation resets)."""
        self.pending = {w.name: getattr(self.defaults, w.name) for w in self.widgets}
        return self.apply()


# {{{ Dear ImGui


def draw_widget(imgui, widget: Widget, value) -> tuple[bool, object]:
    """Draw ``widget`` showing ``value``; (changed, new value as the GUI holds it). Ctrl+click a slider or drag to
    type a number."""
    label = widget.name
    if widget.kind == "checkbox":
        changed, value = imgui.checkbox(label, value)
    elif widget.kind == "combo":
        names = [str(c) for c in widget.choices]
        changed, index = imgui.combo(label, names.index(str(value)), names)
        value = widget.choices[index]
    elif widget.kind == "text":
        changed, value = imgui.input_text(label, value, imgui.InputTextFlags_.enter_returns_true)
    elif widget.kind == "color":
        changed, value = getattr(imgui, f"color_edit{widget.components}")(label, list(value))
    else:
        flags = imgui.SliderFlags_.always_clamp | (
            imgui.SliderFlags_.logarithmic | imgui.SliderFlags_.no_round_to_format if widget.log else 0
        )
        number = "int" if widget.integer else "float"
        fmt = "%d" if widget.integer else "%.4g"
        if widget.kind == "slider":
            changed, value = getattr(imgui, f"slider_{number}")(label, value, widget.lo, widget.hi, fmt, flags)
        else:  # no bounds: 0, 0 (ImGui's "unbounded")
            drag = getattr(imgui, f"drag_{number}{widget.components if widget.vector else ''}")
            bounds = (widget.lo, widget.hi) if widget.lo is not None and widget.hi is not None else (0, 0)
            shown = list(value) if widget.vector else value
            changed, value = drag(label, shown, widget.speed, *bounds, fmt, flags)
    if widget.tooltip:
        imgui.set_item_tooltip(widget.tooltip)
    return changed, value


# }}}
