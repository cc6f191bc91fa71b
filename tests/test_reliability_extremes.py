"""Every declared number of every shipped physics component, set to the edges of a float's range.

A value either is refused when the scene loads (a ScenarioError naming it) or runs; a run that then
fails says why in the physics' words (a non-finite output, a step too small to take), never with a
Python exception that escaped a component (a ZeroDivisionError, an OverflowError, a math domain
error), each of which these values once caused.
"""

from __future__ import annotations

import dataclasses
import re
import typing
from pathlib import Path

import pytest

from cosim.errors import ScenarioError
from cosim.runner import run_scene
from cosim.scenario import load

SCENES = Path(__file__).resolve().parents[1] / "scenarios"
# one scene per component type: (scene, its components whose parameters are tried)
CASES = [("skip.yaml", ("stone", "pond", "coupler", "stages")), ("ground_bounce.yaml", ("floor_flat",)),
         ("drop_ripple.yaml", ("drop",))]
FLOATS = ("1e308", "-1e308", "1e-320", "1e5", "-1e5")
INTS = (str(2**62),)
# what a component's own exception looks like in a failed run's reason
ESCAPED = re.compile(r"ZeroDivisionError|OverflowError|FloatingPointError|RuntimeWarning|IndexError|KeyError|TypeError|"
                     r"AttributeError|math domain error|Maximum allowed dimension|singular")


def _values(tp) -> tuple[str, ...]:
    """The extreme values of a parameter of type ``tp`` as --set text (none for other types)."""
    optional = [a for a in typing.get_args(tp) if a is not type(None)]
    if type(None) in typing.get_args(tp) and len(optional) == 1:  # X | None: X's values
        tp = optional[0]
    if tp is float:
        return FLOATS
    if tp is int:
        return INTS
    if typing.get_origin(tp) is tuple and all(a is float for a in typing.get_args(tp)):
        n = len(typing.get_args(tp))
        return tuple("[" + ", ".join([v] * n) + "]" for v in FLOATS)
    return ()


def _overrides() -> list[tuple[str, str]]:
    out = []
    for scene_name, names in CASES:
        scene = load(SCENES / scene_name)
        for name in names:
            params = scene.components[name].cls.Params
            hints = typing.get_type_hints(params)
            for field in dataclasses.fields(params):
                out += [(scene_name, f"components.{name}.{field.name}={v}") for v in _values(hints[field.name])]
    return out


OVERRIDES = _overrides()


def test_the_sweep_covers_each_component_types_numbers():
    """The list is not empty by accident: every kind of component contributes its numbers."""
    assert len(OVERRIDES) > 150
    assert {o.split(".")[1] for _, o in OVERRIDES} == {"stone", "pond", "coupler", "stages", "floor_flat", "drop"}


@pytest.mark.filterwarnings("error::RuntimeWarning")  # numpy's overflow warnings on stderr are noise too
@pytest.mark.parametrize(("scene_name", "override"), OVERRIDES)
def test_an_extreme_number_is_refused_or_fails_in_words(scene_name, override):
    try:
        scene = load(SCENES / scene_name, [override, "until=0.004"])
    except ScenarioError:
        return  # refused when the scene loads: bad input, said in words (the other tests check the words)
    outcome = run_scene(scene, None, progress=False)
    if outcome.failed:
        assert not ESCAPED.search(outcome.result.reason), outcome.result.reason
