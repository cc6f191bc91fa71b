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


# values each of its own component's rules takes, refused by what they do to the scene as a whole:
# the message says that (and names the component that found it), not the parameter
CROSS_CHECKS = {
    "components.stone.radius=1e5": "the body is 2e+05 m across, wider than the water feeding it",
    "components.stone.position=[1e-320, 1e-320, 1e-320]": "past the open edge of the water feeding it",
    "components.stone.position=[-1e5, -1e5, -1e5]": "past the open edge of the water feeding it",
    f"components.pond.nx={2**62}": "the scene needs about 1.03e+14 GB of memory (pond 1.03e+14 GB)",
    f"components.pond.ny={2**62}": "the scene needs about 4.13e+14 GB of memory (pond 4.13e+14 GB)",
    "components.pond.rest_level=1e5": "the body starts 1e+05 m below the water's bed",
    "components.floor_flat.point=[1e5, 1e5, 1e5]": "the body starts 1e+05 m inside the ground",
}


def test_the_sweep_covers_each_component_types_numbers():
    """The list is not empty by accident: every kind of component contributes its numbers."""
    assert len(OVERRIDES) > 150
    assert {o.split(".")[1] for _, o in OVERRIDES} == {"stone", "pond", "coupler", "stages", "floor_flat", "drop"}


@pytest.mark.filterwarnings("error::RuntimeWarning")  # numpy's overflow warnings on stderr are noise too
@pytest.mark.parametrize(("scene_name", "override"), OVERRIDES)
def test_an_extreme_number_is_refused_or_fails_in_words(scene_name, override):
    try:
        scene = load(SCENES / scene_name, [override, "until=0.004"])
    except ScenarioError as exc:
        # refused when the scene loads: bad input, said in words, naming what was given (its
        # --set path, or its component and parameter), not an exception of the component's set-up
        # (a drop's radius of 1e308 was "components.drop: ... OverflowError: cannot convert float
        # infinity to integer")
        text = str(exc)
        assert not ESCAPED.search(text), text
        key = override.split("=", 1)[0]
        component, parameter = key.split(".")[1:]
        said = text.removeprefix(f"{SCENES / scene_name}: ")  # the file's name is no naming of the value
        if override in CROSS_CHECKS:  # refused by what it does to another component, said in those words
            assert CROSS_CHECKS[override] in said, text
            return
        assert key in said or (re.search(rf"\b{component}\b", said) and re.search(rf"\b{parameter}\b", said)), text
        return
    outcome = run_scene(scene, None, progress=False)
    if outcome.failed:
        assert not ESCAPED.search(outcome.result.reason), outcome.result.reason
