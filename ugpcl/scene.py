"""The scene interface every chapter implements (docs/architecture.md, "Contracts").

* ``Params``: a frozen dataclass whose defaults are the book's values. Fields declared with ``param()`` carry
  their range; construction validates every field and raises ``ValueError`` naming it, the range and the value.
  Rules across fields are declared in ``limits`` (shown under the table) and enforced by ``check()``.
* ``Simulation(runtime, params, seed)``: the chapter writes ``_reset()`` (buffers, programs, first kernels),
  ``_step(dt)`` (one method per book kernel, called in the book's order), ``state() -> dict`` (exactly what ``.npz``
  holds) and ``stats() -> dict``. The base class's ``step(dt)`` checks ``dt``, calls ``_step`` and advances
  ``time`` and ``steps``: no chapter does that bookkeeping itself.
* ``Scene``: a name the CLI and viewer know (``ugpcl run boids``), bound to a Simulation class and, for scenes
  that are variants of one chapter, parameter overrides; everything docs and tests need to know about a scene
  (its preview, its page's loop, its CPU sizes) is a field here.
"""

from __future__ import annotations

import ast
import dataclasses
import inspect
import json
import math
import os
import re
import sys
import typing
import warnings
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

# {{{ parameters

FLOAT32_MAX = float(np.finfo(np.float32).max)
"""Largest float parameter: every kernel argument is float32."""


def param(
    default,
    lo=None,
    hi=None,
    *,
    lo_open: bool = False,
    choices=None,
    live: bool = False,
    ignored_when: dict | None = None,
    used_only_when: dict | None = None,
):
    """A Params field with its book default and allowed range ``[lo, hi]`` (``(lo, hi]`` with ``lo_open``) or
    ``choices``. For tuple fields the range applies to every component. ``live``: a change takes effect on the
    next step; changing a field that is not live resets the simulation (``Simulation.update``).

    ``ignored_when={"use_uv_animation": True}``: other settings that leave this field unused, the field unused while
    any of them has its value; ``used_only_when={"mode": 2}``: unused while any of them has another value. A set of
    values stands for any of them (``used_only_when={"composite_type": {"colored_additive", "colored_screen"}}``).
    ``ugpcl params`` shows them (``ignored when``), and setting the field while they hold says so
    (``Params.ignored``, ``ParameterIgnored``)."""
    if lo is not None and hi is not None and not lo <= hi:
        raise ValueError(f"param range [{lo}, {hi}] is empty")
    metadata = {"lo": lo, "hi": hi, "lo_open": lo_open, "choices": choices, "live": live}
    metadata["unused"] = tuple(
        (setting, _value_set(values), equal)
        for conditions, equal in ((ignored_when, True), (used_only_when, False))
        for setting, values in (conditions or {}).items()
    )
    return field(default=default, metadata=metadata)


def _value_set(values) -> tuple:
    """The values of one condition of ``ignored_when`` / ``used_only_when``: a set (or frozenset) is several, anything
    else (a tuple too: the value of a tuple field) one."""
    return tuple(sorted(values, key=str)) if isinstance(values, set | frozenset) else (values,)


@dataclass(frozen=True)
class Unused:
    """One declared dependency: ``field`` is unused while ``setting`` has one of ``values`` (``equal``) or while it has
    none of them (not ``equal``). Declared beside the field with ``param(ignored_when=...)`` or
    ``param(used_only_when=...)``."""

    field: str
    setting: str
    values: tuple
    equal: bool

    def holds(self, params: Params) -> bool:
        """Whether ``params`` leave the field unused."""
        return (getattr(params, self.setting) in self.values) == self.equal

    @property
    def rule(self) -> str:
        """As ``ugpcl params`` shows it: ``use_uv_animation=true``, ``mode!=2``."""
        return f"{self.setting}{'=' if self.equal else '!='}{'|'.join(_word(v) for v in self.values)}"

    def why(self, params: Params) -> str:
        """What in ``params`` leaves the field unused: ``use_uv_animation=true``, ``mode=0 (used only with mode=2)``."""
        now = f"{self.setting}={_word(getattr(params, self.setting))}"
        return now if self.equal else f"{now} (used only with {self.setting}={'|'.join(map(_word, self.values))})"


def _word(value) -> str:
    """A value as ``--set`` takes it, for the lines about unused fields: true or false, "" for an empty text."""
    if isinstance(value, bool):
        return "true" if value else "false"
    return '""' if value == "" else show_value(value)


_DEPENDENCIES: dict[type, tuple[Unused, ...]] = {}
"""Params class -> its checked ``Unused`` declarations (``Params.dependencies``)."""


def _describe_range(meta) -> str:
    if meta.get("choices") is not None:
        return "one of " + "|".join(str(c) for c in meta["choices"])
    lo, hi = meta.get("lo"), meta.get("hi")
    if lo is None and hi is None:
        return "any"
    left = "(" if meta.get("lo_open") or lo is None else "["
    return f"in {left}{'-inf' if lo is None else lo}, {'inf' if hi is None else hi}]"


def _allowed(meta) -> str:
    """`` in [lo, hi]`` (or `` one of ...``) for the end of a message; empty for a field without a range."""
    allowed = _describe_range(meta) if meta else "any"
    return "" if allowed == "any" else " " + allowed


LIMIT = re.compile(r"(.*) (<=|>=|<|>) (.*)")
"""A rule of ``Params.limits``: left side, comparison, right side (the last comparison splits)."""


BOOL_WORDS = {"true": True, "false": False, "yes": True, "no": False, "on": True, "off": False, "1": True, "0": False}
"""What ``--set`` takes for a bool."""


def _parse_bool(text: str) -> bool:
    try:
        return BOOL_WORDS[text.strip().lower()]
    except KeyError:
        raise ValueError from None


@dataclass(frozen=True)
class Params:
    """Base of every scene's parameters. Subclasses add fields and may extend ``check()``."""

    limits: ClassVar[tuple[str, ...]] = ()
    """Rules across fields that ``check()`` enforces, as ``ugpcl params`` and the chapter pages show them under the
    table: ``"LEFT OP RIGHT"`` with OP one of <= >= < > (``"width*height*depth <= 33554432"``). ``check()`` raises
    ``self.broken(rule)`` for each rule that fails."""

    def __post_init__(self):
        hints = typing.get_type_hints(type(self))
        for f in dataclasses.fields(self):
            value = self._coerce(f.name, hints[f.name], getattr(self, f.name), _allowed(f.metadata))
            object.__setattr__(self, f.name, value)
            self._check_range(f, value)
        self.check()
        self.dependencies()  # a declaration that names no field, or a value it cannot take, fails on first use

    def check(self) -> None:
        """Cross-field checks: the rules of ``limits``, each raising ``self.broken(rule)``."""

    def broken(self, rule: str, result: str = "") -> ValueError:
        """The error for a broken rule of ``limits``: "LEFT must be OP RIGHT, got FIELD=VALUE, ... (RESULT)", with
        every field the rule names and its value; ``result`` says what they come to ("33554432 cells")."""
        if rule not in self.limits:
            raise AssertionError(f"{type(self).__qualname__}.limits lacks {rule!r}")
        left, op, right = LIMIT.fullmatch(rule).groups()
        named = [n for n in self.names() if re.search(rf"\b{n}\b", rule)]
        values = ", ".join(f"{n}={show_value(getattr(self, n))}" for n in named)
        return ValueError(f"{left} must be {op} {right}, got {values}" + (f" ({result})" if result else ""))

    @staticmethod
    def _coerce(name: str, kind, value, allowed: str = ""):
        """``value`` as ``kind`` (int -> float, list -> tuple); ``allowed`` (" in [lo, hi]") ends the messages."""
        origin = typing.get_origin(kind)
        if origin is tuple:
            parts = typing.get_args(kind)
            if not isinstance(value, list | tuple | np.ndarray) or len(value) != len(parts):
                each = f" each{allowed}" if allowed else ""
                raise ValueError(f"{name} must be {len(parts)} numbers{each}, got {value!r}")
            return tuple(Params._coerce(name, p, v, allowed) for p, v in zip(parts, value, strict=True))
        if kind is bool:
            if isinstance(value, bool | np.bool_):
                return bool(value)
        elif kind is int:
            if isinstance(value, int | np.integer) and not isinstance(value, bool):
                return int(value)
        elif kind is float:
            if isinstance(value, int | float | np.integer | np.floating) and not isinstance(value, bool):
                if not math.isfinite(value):
                    raise ValueError(f"{name} must be a finite number{allowed}, got {value!r}")
                return float(value)
        elif kind is str:
            if isinstance(value, str):
                return value
        else:
            return value
        raise ValueError(f"{name} must be of type {kind.__name__}{allowed}, got {value!r}")

    @staticmethod
    def _check_range(f: dataclasses.Field, value) -> None:
        meta = f.metadata
        values = value if isinstance(value, tuple) else (value,)
        for v in values if meta else ():  # a field declared without param() has no range
            bad = meta["choices"] is not None and v not in meta["choices"]
            if meta["lo"] is not None:
                bad |= v <= meta["lo"] if meta["lo_open"] else v < meta["lo"]
            if meta["hi"] is not None:
                bad |= v > meta["hi"]
            if bad:
                raise ValueError(f"{f.name} must be {_describe_range(meta)}, got {value!r}")
        for v in values:  # a field without a finite range: the kernels compute in float32, where 1e39 is inf
            if isinstance(v, float) and abs(v) > FLOAT32_MAX:
                allowed = _allowed(meta).strip()
                allowed = f"{allowed} and " if allowed else ""
                raise ValueError(f"{f.name} must be {allowed}within float32 (|x| <= 3.4e38), got {value!r}")

    # {{{ conversions for the CLI, .npz and docs

    @classmethod
    def names(cls) -> list[str]:
        return [f.name for f in dataclasses.fields(cls)]

    @classmethod
    def live_names(cls) -> frozenset[str]:
        """Fields declared ``param(..., live=True)``: changing them needs no reset."""
        return frozenset(f.name for f in dataclasses.fields(cls) if f.metadata.get("live"))

    @classmethod
    def dependencies(cls) -> tuple[Unused, ...]:
        """Every field's ``ignored_when`` / ``used_only_when`` (``param()``) as ``Unused``, in field order. Checked the
        first time: each names another field, with values that field takes (AssertionError otherwise)."""
        found = _DEPENDENCIES.get(cls)
        if found is None:
            fields, hints = {f.name: f for f in dataclasses.fields(cls)}, typing.get_type_hints(cls)
            found = tuple(
                # a bool setting says the value that leaves the field unused: time_scale, used_only_when
                # use_uv_animation is true, is ignored while use_uv_animation=false
                Unused(f.name, setting, (not values[0],), True)
                if hints.get(setting) is bool and not equal and len(values) == 1 and isinstance(values[0], bool)
                else Unused(f.name, setting, values, equal)
                for f in fields.values()
                for setting, values, equal in f.metadata.get("unused", ())
            )
            for d in found:
                where = f"{cls.__qualname__}.{d.field}: {'ignored_when' if d.equal else 'used_only_when'}"
                if d.setting not in fields or d.setting == d.field:
                    raise AssertionError(f"{where} names {d.setting!r}, not another field of {cls.__qualname__}")
                for value in d.values:
                    try:
                        setting = fields[d.setting]
                        cls._check_range(setting, cls._coerce(d.setting, hints[d.setting], value))
                    except ValueError as err:
                        raise AssertionError(f"{where}: {err}") from None
            _DEPENDENCIES[cls] = found
        return found

    def ignored(self, names) -> list[str]:
        """For the fields of ``names`` (those a user set) that these parameters leave unused, one line per reason:
        ``u and v are ignored while use_uv_animation=true``. Empty when every one is used."""
        reasons: dict[str, list[str]] = {}
        for name in (n for n in self.names() if n in names):
            why = [d.why(self) for d in self.dependencies() if d.field == name and d.holds(self)]
            if why:
                reasons.setdefault(" and ".join(why), []).append(name)
        return [
            f"{_joined(fields)} {'is' if len(fields) == 1 else 'are'} ignored while {why}"
            for why, fields in reasons.items()
        ]

    @classmethod
    def ignored_when(cls, name: str) -> str:
        """When field ``name`` is unused, as the ``ignored when`` column shows it (``mode!=2 or animator=true``);
        empty for a field that is always used."""
        return " or ".join(d.rule for d in cls.dependencies() if d.field == name)

    @classmethod
    def parse(cls, name: str, text: str):
        """Convert the text of ``--set name=text`` with the field's type (tuples: comma-separated). A text that is
        not of the type names the field, the type and its range: ``count expects int in [1, 10], got 'x'``."""
        if name not in cls.names():
            raise ValueError(f"unknown parameter {name!r}; valid: {', '.join(cls.names())}")
        kind = typing.get_type_hints(cls)[name]
        parts = typing.get_args(kind) if typing.get_origin(kind) is tuple else None
        try:
            if parts:
                items = [t.strip() for t in text.split(",")]
                if len(items) != len(parts):
                    raise ValueError
                return tuple(_parse_one(p, t) for p, t in zip(parts, items, strict=True))
            return _parse_one(kind, text)
        except ValueError:
            meta = next(f.metadata for f in dataclasses.fields(cls) if f.name == name)
            shape = ",".join(p.__name__ for p in parts) if parts else kind.__name__
            if kind is bool:
                allowed = " (" + "|".join(BOOL_WORDS) + ")"
            else:
                allowed = _allowed(meta)
                allowed = f" each{allowed}" if parts and allowed else allowed
            raise ValueError(f"{name} expects {shape}{allowed}, got {text!r}") from None

    def replace(self, **changes) -> Params:
        unknown = sorted(set(changes) - set(self.names()))
        if unknown:
            raise ValueError(f"unknown parameter {unknown[0]!r}; valid: {', '.join(self.names())}")
        return dataclasses.replace(self, **changes)

    def to_dict(self) -> dict[str, Any]:
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}

    def to_json(self, **extra) -> str:
        return json.dumps({**self.to_dict(), **extra})

    @classmethod
    def table(cls) -> list[dict[str, str]]:
        """One row per field: name, default, range, live, when other settings leave it unused (``ignored when``, a
        column only where a field declares it) and the attribute docstring (for ``ugpcl params`` and docs)."""
        docs, dependent = field_docs(cls), bool(cls.dependencies())
        return [
            {
                "name": f.name,
                "default": show_value(f.default),
                "range": _describe_range(f.metadata) if f.metadata else "any",
                "live": "yes" if f.metadata.get("live") else "",
                **({"ignored when": cls.ignored_when(f.name)} if dependent else {}),
                "meaning": docs.get(f.name, ""),
            }
            for f in dataclasses.fields(cls)
        ]

    # }}}


def _joined(names: list[str]) -> str:
    """``u``, ``u and v``, ``a, b and c``."""
    return names[0] if len(names) == 1 else f"{', '.join(names[:-1])} and {names[-1]}"


def _parse_one(kind, text: str):
    if kind is bool:
        return _parse_bool(text)
    if kind is int:
        return int(text, 0)
    if kind is float:
        return float(text)
    return text


def show_value(value) -> str:
    """A parameter value as the tables, messages and the viewer show it: floats short (%g), tuples in parentheses."""
    if isinstance(value, tuple):
        return "(" + ", ".join(show_value(v) for v in value) + ")"
    if isinstance(value, float):
        return f"{value:g}"
    return str(value)


def field_docs(cls) -> dict[str, str]:
    """Attribute docstrings (the string literal under each field) of a dataclass and its bases."""
    docs: dict[str, str] = {}
    for klass in reversed(cls.__mro__):
        try:
            tree = ast.parse(inspect.getsource(klass).lstrip() if klass.__module__ != "builtins" else "")
        except (OSError, TypeError, SyntaxError):
            continue
        body = tree.body[0].body if tree.body and isinstance(tree.body[0], ast.ClassDef) else []
        for node, nxt in zip(body, body[1:], strict=False):
            if isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
                if (
                    isinstance(nxt, ast.Expr)
                    and isinstance(nxt.value, ast.Constant)
                    and isinstance(nxt.value.value, str)
                ):
                    docs[node.target.id] = " ".join(nxt.value.value.split())
    return docs


# }}}

# {{{ simulation


class ParamError(ValueError):
    """A parameter set that passes its ranges and limits but that the scene finds unusable when it builds its state
    (a figure sampled so coarsely that no point falls inside it). Like a range error: one line, exit 2."""


class Simulation:
    """Base of every scene's simulation; subclasses set ``Params`` and implement the four methods."""

    Params: ClassVar[type[Params]] = Params
    default_dt: ClassVar[float] = 1.0 / 60.0
    """Fixed step for headless runs (the book uses Time.deltaTime)."""
    history: ClassVar[tuple[str, ...]] = ()
    """State arrays that ``--every K`` stacks into ``<name>_history``."""
    may_be_infinite: ClassVar[tuple[str, ...]] = ()
    """State arrays where inf is a value, not a divergence (NaN still is): poisson_disk's nn_dist of a lone sample."""
    scene: Scene | None = None
    """The scene this simulation was created for (``Scene.create``): its name, defaults and view."""
    first_scene: ClassVar[Scene | None] = None
    """The first ``Scene`` declared for this class (set by ``Scene``): whose defaults ``default_params`` gives."""
    warns_ignored: bool = True
    """Whether ``update`` says a given field that the other settings leave unused (``ParameterIgnored``); False for
    a simulation that another one drives from its own parameters (tessellation's fluid), whose own ``update``
    already said it of the fields the user gave."""

    def __init__(self, runtime, params: Params | None = None, seed: int = 0):
        self.runtime = runtime
        self.params = params if params is not None else self.default_params()
        if not isinstance(self.params, self.Params):
            raise TypeError(f"{type(self).__name__} needs {self.Params.__qualname__}, got {type(self.params).__name__}")
        if not isinstance(seed, int | np.integer) or seed < 0:
            raise ValueError(f"seed must be an integer >= 0, got {seed!r}")
        self.seed = int(seed)
        self.reset()

    @classmethod
    def default_params(cls) -> Params:
        """The Params of the first scene that runs this class (its ``Scene.defaults`` applied), else the class's."""
        first = cls.__dict__.get("first_scene")
        return first.params() if first is not None else cls.Params()

    def reset(self) -> None:
        """Back to the initial state for the current params and seed: time and step count to 0, then the
        chapter's own ``_reset()`` (buffers, programs, initial kernels)."""
        self.time, self.steps = 0.0, 0
        self._reset()

    def _reset(self) -> None:
        raise NotImplementedError

    def step(self, dt: float | None = None) -> None:
        """One step of ``dt`` seconds (None: ``default_dt``): ``dt`` is checked (``check_dt``), the chapter's
        ``_step(dt)`` runs its kernels, then ``time`` and ``steps`` advance. A chapter whose kernels draw the frame
        at the end of the step passes them ``self.time + dt``."""
        dt = check_dt(dt, self.default_dt)
        simulated = self._step(dt)
        self.time += dt if simulated is None else simulated
        self.steps += 1

    def _step(self, dt: float) -> float | None:
        """The chapter's kernels for one step, in the book's order. Returns None, or the time the step simulated
        where that is not ``dt`` (SPH's sub-steps capped at the stable time step)."""
        raise NotImplementedError

    def state(self) -> dict[str, np.ndarray]:
        raise NotImplementedError

    def stats(self) -> dict[str, Any]:
        return {"steps": self.steps, "time": self.time}

    def incomplete(self) -> str:
        """Why the result falls short of what was asked, in one line ('' when it does not): a chapter whose
        algorithm can give up part-way (ear clipping that runs out of ears) says so here, and ``ugpcl run`` prints it
        as a warning (``--strict``, or the chapter's own ``strict`` parameter: exit 1)."""
        return ""

    picture = None
    """How ``_repr_png_`` draws a simulation: set by the ``ugpcl`` package (``ugpcl.render``), which may import the
    viewer; this module may not."""

    def _repr_png_(self) -> bytes | None:
        """Jupyter shows a simulation as its picture (640 x 360, offscreen); None (text instead) without one."""
        return type(self).picture(self) if type(self).picture else None

    @property
    def strict(self) -> bool:
        """The chapter's own ``strict`` parameter where it has one: an incomplete result is then an error."""
        return bool(getattr(self.params, "strict", False))

    def restore(self, state: dict[str, np.ndarray]) -> None:
        """Put a ``state()`` back on the device after ``reset()`` (``ugpcl run --resume``). A scene that can resume
        overrides this; its ``state()`` must then hold everything a step reads."""
        raise NotImplementedError(f"{type(self).__name__} cannot restore a saved state")

    @classmethod
    def allocations(cls, params: Params) -> list:
        """The large device buffers and images ``params`` ask for (``ugpcl.resources.Allocation``), each with the
        parameter that sizes it: checked against the device before a run (``resources.check``)."""
        return []

    @classmethod
    def resumable(cls) -> bool:
        return cls.restore is not Simulation.restore

    def update(self, **changes) -> bool:
        """Change parameters (validated); reset unless every changed one is live (``param(..., live=True)``, the
        ``live`` column of ``ugpcl params``). A reset is said with a ``ParameterReset`` warning naming the fields
        (the viewer, which resets on purpose, ignores it), a field given that the other settings leave unused with a
        ``ParameterIgnored`` one. Returns whether it reset."""
        new = self.params.replace(**changes)
        if self.warns_ignored:
            warn_ignored(new, changes)
        changed = {k for k in changes if getattr(new, k) != getattr(self.params, k)}
        self.params = new
        fixed = sorted(changed - new.live_names())
        if fixed:
            self.reset()
            warnings.warn(
                f"{', '.join(fixed)} {'is' if len(fixed) == 1 else 'are'} not live: {type(self).__module__} was reset "
                f"(step {self.steps}, time {self.time:g})",
                ParameterReset,
                stacklevel=2,
            )
        return bool(fixed)


class ParameterReset(UserWarning):
    """``Simulation.update`` changed a parameter that is not live, so the simulation started again."""


class ParameterIgnored(UserWarning):
    """A parameter was set (``Scene.create``, ``ugpcl.create``, ``Simulation.update``) that the other settings leave
    unused: ``u is ignored while use_uv_animation=true``. Python shows it once per call site; ``ugpcl run`` and
    ``ugpcl sweep`` print the same line for ``--set`` themselves."""


PACKAGE = os.path.dirname(os.path.abspath(__file__))
"""The ugpcl package's folder: a ParameterIgnored names the first caller outside it."""


def warn_ignored(params: Params, names) -> None:
    """A ``ParameterIgnored`` for each line of ``params.ignored(names)``, attributed to the first frame outside the
    ugpcl package (the user's call, however deep inside ugpcl it was made), so that it shows once per call site."""
    lines = params.ignored(names)
    if not lines:
        return
    level, frame = 1, sys._getframe(1)
    while frame is not None and os.path.abspath(frame.f_code.co_filename).startswith(PACKAGE + os.sep):
        level, frame = level + 1, frame.f_back
    for line in lines:
        warnings.warn(line, ParameterIgnored, stacklevel=level + 1)


def check_dt(dt: float | None, default: float) -> float:
    """The step to use: ``default`` for None; otherwise a finite dt in (0, 1] (else ValueError naming ``dt``)."""
    if dt is None:
        return default
    if isinstance(dt, bool) or not (
        isinstance(dt, int | float | np.integer | np.floating) and math.isfinite(dt) and 0 < dt <= 1.0
    ):
        raise ValueError(f"dt must be in (0, 1], got {dt!r}")
    return float(dt)


# }}}

# {{{ scenes


@dataclass(frozen=True)
class Animation:
    """How the loop of a chapter page's picture scene (docs/img/<scene>.webp, ``make anim``) is recorded: ``start``
    steps (default: the preview's), then ``frames`` frames ``every`` steps apart, with the parameters the preview
    sets and ``overrides``; ``swing`` turns a still scene's orbit camera ``swing`` degrees either side of the
    picture's (one period per loop, so the loop has no seam). Scenes of many small dots compress badly: a lower WebP
    ``quality`` keeps them within the size budget."""

    shows: str
    """What the loop shows (the page's caption)."""
    every: int = 1
    start: int | None = None
    frames: int = 45
    swing: float = 0.0
    quality: int = 70
    overrides: dict = field(default_factory=dict)


@dataclass(frozen=True)
class AtScale:
    """The scene at the size a GPU is bought for (``gpu``, parameter overrides): ``ugpcl bench frames`` times its
    whole frame there and ``loop`` is its clip in the gpu gallery row (``python -m ugpcl.docs animations --gpu``).
    ``cpu`` is the same workload shrunk until a CPU device runs a frame in well under a second (the bench's rows
    there, and the test of the command)."""

    gpu: dict
    cpu: dict
    loop: Animation | None = None
    frame: tuple[int, int] = (1280, 720)
    """The frame's size on a GPU (a CPU device draws the previews' 1280x720)."""


@dataclass(frozen=True)
class PreviewCheck:
    """How the tests judge docs/img/<scene>.png: the subject (pixels unlike the background) covers more than
    ``min_subject`` of the frame, and its bounding box stays clear of the frame's edge unless ``fills_frame`` says
    why it may not. A scene drawn in thin lines or small marks lowers ``min_subject`` and says why in ``sparse``."""

    min_subject: float = 0.05
    """5 % of a 1280x720 frame is a 215-pixel square."""
    sparse: str = ""
    fills_frame: str = ""


@dataclass(frozen=True)
class Scene:
    """A runnable name: ``simulation`` with ``defaults`` applied to its Params.

    ``defaults`` is the one way a scene changes the values of its Params class (the book's scene files differ from
    the script defaults; CellularGrowthSphere.unity from CellularGrowth.unity). A Params subclass adds fields; it
    never re-declares an inherited one to change its default. Everything else the project knows about a scene is
    a field here, read by the viewer, docs and tests: no list elsewhere names scenes."""

    name: str
    simulation: type[Simulation]
    summary: str
    defaults: dict = field(default_factory=dict)
    view: str | None = None
    """Name of the view class in ``viewer/views/<stem>.py`` (None: the module's ``View``)."""
    preview: dict = field(default_factory=lambda: {"steps": 300})
    """How docs/img/<name>.png is made (``make png``): ``steps`` and parameter overrides."""
    preview_check: PreviewCheck = PreviewCheck()
    """How the tests judge that picture."""
    animation: Animation | None = None
    """The loop of the chapter page this scene is the picture of (``make anim``); None for the other scenes."""
    interactive: dict = field(default_factory=dict)
    """Parameter overrides the viewer starts with on a CPU device, sized to run at interactive rates there (the
    book's sizes are for a GPU); ``--set`` still wins, and ``ugpcl run`` ignores them. The tests step every scene
    that has them at these sizes (a scene too slow at its book size on PoCL must have them)."""
    at_scale: AtScale | None = None
    """The flagship scenes' production sizes (a million particles, 256^3 grids), None for the others."""

    def __post_init__(self):
        if "first_scene" not in vars(self.simulation):  # Simulation.default_params: the class's first scene
            self.simulation.first_scene = self

    @property
    def stem(self) -> str:
        return self.simulation.__module__.rsplit(".", 1)[-1]

    def params(self, **overrides) -> Params:
        return self.simulation.Params(**{**self.defaults, **overrides})

    def limits(self) -> tuple[str, ...]:
        """The rules across fields its Params checks (``Params.limits``), shown under the table."""
        return self.simulation.Params.limits

    def table(self) -> list[dict[str, str]]:
        """``Params.table()`` with this scene's defaults (``ugpcl params``, the chapter pages)."""
        rows = self.simulation.Params.table()
        for row in rows:
            if row["name"] in self.defaults:
                row["default"] = show_value(self.defaults[row["name"]])
        return rows

    def create(self, runtime, seed: int = 0, **overrides) -> Simulation:
        """A new simulation with ``overrides`` over the scene's defaults; an override that the other settings leave
        unused is said with a ``ParameterIgnored`` warning."""
        params = self.params(**overrides)
        warn_ignored(params, overrides)
        sim = self.simulation(runtime, params, seed)
        sim.scene = self
        return sim


# }}}
