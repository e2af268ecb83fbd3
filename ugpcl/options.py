"""Command-line input that the front ends share (``ugpcl run``, ``ugpcl sweep``, ``ugpcl-view``): a scene by name,
``--set`` pairs, parameters checked by their Params, sizes, seeds, the help layout and a closed stdout. Each bad
input is a UsageError naming the option."""

from __future__ import annotations

import argparse
import os
import sys

from .io import UsageError
from .registry import get
from .scene import Params, Scene

MAX_SEED = 2**63 - 1
"""Largest --seed: the .npz stores it as int64."""
MAX_FPS = 240
"""Largest --fps of a --video."""
MAX_STEPS_BETWEEN_FRAMES = 1 << 30
"""Largest --video-every."""


class HelpFormatter(argparse.ArgumentDefaultsHelpFormatter):
    """Shows ``(default: X)`` once, and not at all for options whose absence is their default (None, False)."""

    def _get_help_string(self, action) -> str:
        if action.default is None or action.default is False or "default:" in (action.help or ""):
            return action.help or ""
        return super()._get_help_string(action)


class ArgumentParser(argparse.ArgumentParser):
    """argparse's parser whose usage errors are two lines, not the whole usage: the short form and the error."""

    def error(self, message: str):
        self.exit(2, f"usage: {self.prog} ... (see {self.prog} --help)\n{self.prog}: error: {message}\n")


def scene_named(name: str) -> Scene:
    try:
        return get(name)
    except ValueError as err:  # unknown scene: the message lists the valid names
        raise UsageError(str(err)) from None


def parse_sets(scene: Scene, pairs: list[str]) -> dict:
    """``--set NAME=VALUE`` pairs converted with each field's type; UsageError names the bad one, and a name
    given twice (no last-one-wins: a typo in a long command line would hide)."""
    params = scene.simulation.Params
    out, given = {}, {}
    for pair in pairs:
        name, sep, text = pair.partition("=")
        name = name.strip()
        if not sep:
            raise UsageError(f"--set expects name=value, got {pair!r}")
        if name in given:
            raise UsageError(f"--set {name} is given twice ({given[name]!r} and {pair!r}); give each parameter once")
        given[name] = pair
        try:
            out[name] = params.parse(name, text)
        except ValueError as err:
            raise UsageError(str(err)) from None
    return out


def scene_params(scene: Scene, overrides: dict) -> Params:
    """The scene's Params with ``overrides``; UsageError when they fail its range or cross-field checks."""
    try:
        return scene.params(**overrides)
    except ValueError as err:  # a range or cross-field check of Params
        raise UsageError(str(err)) from None


def parse_size(text: str, option: str = "--png-size") -> tuple[int, int]:
    """``WxH`` (16..8192 each) as (width, height); UsageError naming ``option`` otherwise."""
    try:
        w, h = (int(v) for v in text.lower().split("x"))
        if not (16 <= w <= 8192 and 16 <= h <= 8192):
            raise ValueError
    except ValueError:
        raise UsageError(f"{option} must be WxH with 16..8192 each, got {text!r}") from None
    return w, h


def quiet_broken_pipe() -> int:
    """The reader of our stdout went away (``ugpcl params boids | head -1``): stop quietly. stdout is pointed at
    /dev/null so that Python's flush at exit does not raise again."""
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, sys.stdout.fileno())
    return 0
