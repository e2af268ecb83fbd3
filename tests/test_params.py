"""Every parameter of every scene has a range that means what it says: finite bounds that float32 and the kernels
hold, rejections that name the parameter, the value and the range, and cross-field limits that are declared,
enforced and shown. Construction only (no kernels), but for one SPH run at the edges of smoothlen."""

from __future__ import annotations

import dataclasses
import math
import re
import typing
from dataclasses import dataclass

import numpy as np
import pytest

from ugpcl.docs import params_table
from ugpcl.registry import scenes
from ugpcl.scene import FLOAT32_MAX, LIMIT, Params, _describe_range, param, show_value
from ugpcl.scenes.sph_2d import Params as SphParams
from ugpcl.scenes.sph_2d import Simulation as SphSimulation

FIRST_SCENE = {}
for _scene in scenes().values():
    FIRST_SCENE.setdefault(_scene.simulation.Params, _scene)
"""One scene per Params class: its defaults are the base every case below changes one field of."""


def _parts(cls, f) -> tuple:
    """The component types of field f: (float,) for a float, (float, float, int) for tuple[float, float, int]."""
    kind = typing.get_type_hints(cls)[f.name]
    return typing.get_args(kind) if typing.get_origin(kind) is tuple else (kind,)


def _fields(kinds: tuple[type, ...], *, choices: bool | None = False, only: bool = False) -> list[tuple]:
    """(scene, field) for every field of every Params with a component of one of ``kinds`` (``only``: every
    component of one of them); ``choices`` False keeps the fields with a range, True those with choices, None both.
    A check runs only over the fields it applies to: none passes by returning early."""
    cases = []
    for cls, scene in FIRST_SCENE.items():
        for f in dataclasses.fields(cls):
            parts = _parts(cls, f)
            if not (all if only else any)(p in kinds for p in parts):
                continue
            if choices is None or (f.metadata.get("choices") is not None) == choices:
                cases.append((scene, f))
    return cases


def _each(cases: list[tuple], check, label=lambda scene, f: f"{scene.name}.{f.name}") -> None:
    """``check(scene, item)`` for every case (an item is a field, or a rule of ``limits``), then one assertion
    naming each case that failed (``label``) and why (a failed assert, a pytest.raises that saw nothing, an
    unexpected error): one test, every field's verdict."""
    assert cases, "nothing to check: the selection is wrong"
    failures = []
    for scene, item in cases:
        try:
            check(scene, item)
        except (Exception, pytest.fail.Exception) as err:
            failures.append(f"{label(scene, item)}: {type(err).__name__}: {err}")
    assert not failures, f"{len(failures)} of {len(cases)} fail:\n" + "\n".join(failures)


FLOATS = _fields((float,))
"""Fields with a float component and a range (no float field takes choices)."""
INTS = _fields((int,), only=True, choices=None)
"""Fields all of whose components are ints, with a range or choices (a mixed tuple like sph_2d's mouse is a float
field: FLOATS checks its bounds)."""
NUMBERS = _fields((float, int))
"""Numeric fields with a range."""
CHOICES = _fields((float, int, str), choices=True)
"""Fields that take one of a list of values."""


def _value(cls, f, number) -> object:
    """Field f set to ``number`` in every component (ints as ints)."""
    parts = tuple(int(number) if p is int else float(number) for p in _parts(cls, f))
    return parts if typing.get_origin(typing.get_type_hints(cls)[f.name]) is tuple else parts[0]


def _broke(rule: str, err: Exception) -> bool:
    """Whether err is the message of ``Params.broken(rule)``."""
    left, op, right = LIMIT.fullmatch(rule).groups()
    return str(err).startswith(f"{left} must be {op} {right}, got ")


# {{{ declared ranges


def test_book_defaults_are_inside_their_ranges():
    def check(scene, _):
        params = scene.params()
        assert params.to_dict() == {**params.to_dict(), **scene.defaults}

    _each([(scene, None) for scene in scenes().values()], check, label=lambda scene, _: scene.name)


def test_float_fields_have_finite_bounds_inside_float32():
    def check(scene, f):
        meta = f.metadata
        assert meta, f"{f.name}: declare its range with param(default, lo, hi)"
        lo, hi = meta["lo"], meta["hi"]
        assert lo is not None and hi is not None, f"{f.name}: range {_describe_range(meta)} is not finite"
        assert -FLOAT32_MAX <= lo <= hi <= FLOAT32_MAX, f"{f.name}: range {_describe_range(meta)} leaves float32"

    _each(FLOATS, check)


def test_int_fields_have_bounds_an_int32_holds():
    def check(scene, f):
        meta = f.metadata
        assert meta, f"{f.name}: declare its range with param(default, lo, hi)"
        values = meta["choices"] if meta["choices"] is not None else (meta["lo"], meta["hi"])
        assert None not in values and all(-(2**31) <= v < 2**31 for v in values), f"{f.name}: {_describe_range(meta)}"

    _each(INTS, check)


# }}}

# {{{ rejections name the parameter, the value and the range


def test_values_outside_the_range_are_rejected_naming_field_and_range():
    def check(scene, f):
        defaults, meta = scene.params(), f.metadata
        cls = type(defaults)
        if float in _parts(cls, f):  # the nearest float32-or-wider values outside
            above, below = math.nextafter(meta["hi"], math.inf), math.nextafter(meta["lo"], -math.inf)
        else:
            above, below = meta["hi"] + 1, meta["lo"] - 1
        below = meta["lo"] if meta["lo_open"] else below
        for number in (above, below, 1e39, -1e39):
            value = _value(cls, f, number)
            if isinstance(value, tuple):  # one bad component is enough
                value = (value[0], *getattr(defaults, f.name)[1:])
            with pytest.raises(ValueError) as err:
                scene.params(**{f.name: value})
            assert str(err.value) == f"{f.name} must be {_describe_range(meta)}, got {value!r}"

    _each(NUMBERS, check)


def test_values_outside_the_choices_are_rejected_naming_field_and_choices():
    def check(scene, f):
        choices = f.metadata["choices"]
        value = "not-a-choice" if isinstance(choices[0], str) else max(choices) + 1
        with pytest.raises(ValueError) as err:
            scene.params(**{f.name: value})
        assert str(err.value) == f"{f.name} must be {_describe_range(f.metadata)}, got {value!r}"

    _each(CHOICES, check)


def test_the_upper_bound_itself_is_accepted():
    together = {"mass_min": "mass_max"}  # mass_min <= mass_max: raise both

    def check(scene, f):
        cls, hi = type(scene.params()), f.metadata["hi"]
        overrides = {f.name: _value(cls, f, hi)}
        if f.name in together:
            overrides[together[f.name]] = hi
        try:
            params = scene.params(**overrides)
        except ValueError as err:  # only a declared limit of the field may refuse its bound (root_inner < root_outer)
            refusing = [rule for rule in scene.limits() if re.search(rf"\b{f.name}\b", rule) and _broke(rule, err)]
            assert refusing, f"{f.name}={hi} is refused by a rule missing from {cls.__qualname__}.limits: {err}"
        else:
            assert getattr(params, f.name) == overrides[f.name]

    _each(FLOATS, check)


def test_parse_errors_give_the_type_and_the_range():
    def check(scene, f):
        cls = type(scene.params())
        with pytest.raises(ValueError) as err:
            cls.parse(f.name, "abc")
        message = str(err.value)
        assert message.startswith(f"{f.name} expects ") and message.endswith(", got 'abc'"), message
        if bool in _parts(cls, f):
            assert "(true|false|yes|no|on|off|1|0)" in message, message
        else:
            assert _describe_range(f.metadata) in message, message

    _each(_fields((float, int, bool), choices=None), check)


def test_messages_for_every_kind_of_bad_value():
    from ugpcl.scenes.boids import Params as Boids
    from ugpcl.scenes.cloth import Params as Cloth

    cases = [
        (lambda: Boids.parse("max_object_num", "abc"), "max_object_num expects int in [1, 4194304], got 'abc'"),
        (lambda: Boids.parse("wall_size", "1,2"), "wall_size expects float,float,float each in (0.0, 10000.0]"),
        (lambda: Cloth.parse("sphere", "maybe"), "sphere expects bool (true|false|yes|no|on|off|1|0), got 'maybe'"),
        (lambda: Boids(max_speed=1e39), "max_speed must be in (0.0, 10000.0], got 1e+39"),
        (lambda: Boids(max_speed=float("nan")), "max_speed must be a finite number in (0.0, 10000.0], got nan"),
        (lambda: Boids(max_object_num=2.5), "max_object_num must be of type int in [1, 4194304], got 2.5"),
        (lambda: Boids(wall_size=(1.0, 2.0)), "wall_size must be 3 numbers each in (0.0, 10000.0], got (1.0, 2.0)"),
        (lambda: Cloth(gravity=(1e39, 1.0, 1.0)), "gravity must be in [-10000.0, 10000.0], got (1e+39, 1.0, 1.0)"),
    ]
    for make, message in cases:
        with pytest.raises(ValueError) as err:
            make()
        assert str(err.value).startswith(message), (str(err.value), message)


@dataclass(frozen=True)
class Unbounded(Params):
    scale: float = param(1.0, 0.0)
    offset: float = 0.0
    limits = ("scale <= offset + 10",)

    def check(self) -> None:
        if self.scale > self.offset + 10:
            raise self.broken(self.limits[0], f"{self.offset + 10:g}")
        if self.scale == 5.0:
            raise self.broken("scale != 5")


def test_fields_without_a_finite_range_still_refuse_what_float32_cannot_hold():
    with pytest.raises(ValueError, match=r"^scale must be in \[0.0, inf\] and within float32 \(\|x\| <= 3.4e38\)"):
        Unbounded(scale=1e39, offset=1e39)
    with pytest.raises(ValueError, match=r"^offset must be within float32 \(\|x\| <= 3.4e38\), got 1e\+39"):
        Unbounded(offset=1e39)
    with pytest.raises(ValueError, match=r"^scale must be <= offset \+ 10, got scale=20, offset=1 \(11\)$"):
        Unbounded(scale=20.0, offset=1.0)
    with pytest.raises(AssertionError, match="Unbounded.limits lacks 'scale != 5'"):
        Unbounded(scale=5.0)  # a rule check() enforces but ``limits`` does not show is a bug
    with pytest.raises(ValueError, match=r"param range \[2, 1\] is empty"):
        param(1, 2, 1)


# }}}

# {{{ limits across fields

LIMITS = {
    "res[0]*res[1] <= 4194304": ({"res": (2048, 2049)}, {"res": (2048, 2048)}),
    "2*planes[0]*planes[1]*plane_resolution**2 <= 4194304 blades": (
        {"planes": (8, 1), "plane_resolution": 513},
        {"planes": (8, 1), "plane_resolution": 512},
    ),
    "mass_min <= mass_max": ({"mass_min": 2.0, "mass_max": 1.0}, {"mass_min": 2.0, "mass_max": 2.0}),
    "root_inner < root_outer": ({"root_inner": 50.0, "root_outer": 50.0}, {"root_inner": 49.9, "root_outer": 50.0}),
    "mouse frames (third number) >= 0": ({"mouse": (1.0, 2.0, -1)}, {"mouse": (1.0, 2.0, 0)}),
    "width >> lod and height >> lod >= 3": ({"width": 11, "lod": 2}, {"width": 12, "lod": 2}),
    "(width >> lod) * (height >> lod) <= 16777216": ({"width": 4096, "height": 4097}, {"width": 4096, "height": 4096}),
    "width*height*depth <= 33554432": (
        {"width": 1024, "height": 1024, "depth": 33},
        {"width": 1024, "height": 1024, "depth": 32},
    ),
    "distance from eye to every face of room_size >= 0.05 m": ({"eye": (0.0, 0.0499, 0.0)}, {"eye": (0.0, 0.05, 0.0)}),
    "width // divide >= 1": ({"width": 6}, {"width": 7}),
    "height // divide >= 1": ({"height": 6}, {"height": 7}),
    "chains*samples <= 33554432": ({"chains": 3355444, "samples": 10}, {"chains": 3355443, "samples": 10}),
    "(L+5)*oversample <= 400 with density=grid": (
        {"L": 96, "oversample": 4, "density": "grid"},
        {"L": 95, "oversample": 4, "density": "grid"},
    ),
    "batches*limit <= 16777216": ({"batches": 16778, "limit": 1000}, {"batches": 16777, "limit": 1000}),
    "prod(ceil(size*sqrt(dim)/r) + 1) <= 67108864": (  # dim 4: axes x, y, z, x of 2 * size / r + 1 cells
        {"dim": 4, "r": 2.0, "size": (127.0, 63.0, 64.0)},
        {"dim": 4, "r": 2.0, "size": (127.0, 63.0, 63.0)},
    ),
    "r <= size*sqrt(dim) with method=gpu": (
        {"method": "gpu", "r": 2.9, "size": (2.0, 2.0, 1.0)},
        {"method": "gpu", "r": 2 * math.sqrt(2), "size": (2.0, 2.0, 1.0)},
    ),
}
"""For each rule of every ``Params.limits``: a set that breaks it by one, and the set on its edge, which passes."""


def test_every_limit_is_enforced_up_to_its_edge():
    def check(scene, rule):
        assert rule in LIMITS, f"add a breaking and an edge case for {rule!r} to LIMITS"
        bad, edge = LIMITS[rule]
        scene.params(**edge)
        with pytest.raises(ValueError) as err:
            scene.params(**bad)
        message = str(err.value)
        assert _broke(rule, err.value), message
        named = [name for name in scene.params().names() if re.search(rf"\b{name}\b", rule)]
        assert named and set(bad) <= set(named), f"{rule!r} names {named}"
        defaults = scene.params().to_dict()
        for name in named:  # every field of the rule with the value it had
            assert f"{name}={show_value(bad.get(name, defaults[name]))}" in message, message

    rules = [(scene, rule) for scene in FIRST_SCENE.values() for rule in scene.limits()]
    _each(rules, check, label=lambda scene, rule: f"{scene.name}: {rule}")


def test_limits_are_shown_under_the_parameter_table():
    rows = {name: scene for name, scene in scenes().items() if scene.limits()}
    assert {"cloth", "grass", "stable_fluids_2d", "stable_fluids_3d", "space_colonization", "sph_2d"} <= set(rows)
    for name, scene in rows.items():
        text = params_table(name)
        table, _, below = text.partition("\n\nLimits across parameters:\n\n")
        assert below.splitlines() == [f"- `{rule}`" for rule in scene.limits()], text
        assert table.count("\n") == len(scene.table()) + 1, "the table's rows stay one per field"
    assert "Limits" not in params_table("boids")


# }}}

# {{{ the edges run


@pytest.mark.parametrize("smoothlen", [1e-4, 1e4], ids=["lo", "hi"])
def test_sph_at_the_edges_of_smoothlen_stays_finite(runtime, smoothlen):
    """smoothlen^8 and 1/smoothlen^8 are the kernel coefficients' largest powers: both bounds give finite runs."""
    params = SphParams(particle_num=64, smoothlen=smoothlen, local_size=64)
    assert all(math.isfinite(c) for c in (params.density_coef, params.grad_pressure_coef, params.lap_viscosity_coef))
    assert all(abs(c) < FLOAT32_MAX for c in (params.density_coef, params.grad_pressure_coef))
    sim = SphSimulation(runtime, params, seed=1)
    for _ in range(3):
        sim.step()
    state = sim.state()
    assert all(np.isfinite(state[k]).all() for k in ("position", "velocity", "density", "pressure", "acceleration"))
    assert sim.steps == 3 and state["density"].max() < FLOAT32_MAX


# }}}
