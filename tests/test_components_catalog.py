"""`cosim components`: the component types a scene can name, each type's parameters (with units,
defaults and bounds), ports and messages, and docs/components.md generated from the same code."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import pytest

from cosim.cli import main
from cosim.params import describe, param, yaml_text
from cosim.registry import project_types, registered, type_info, types_page

ROOT = Path(__file__).resolve().parents[1]
OWN = project_types()


def test_the_reference_page_is_the_one_the_code_makes():
    """docs/components.md is what `cosim components --markdown` writes from the code as it is: a
    parameter, port or message changed without regenerating the page fails here."""
    page = (ROOT / "docs" / "components.md").read_text(encoding="utf-8")
    assert page == types_page(OWN), "regenerate: cosim components --markdown docs/components.md"


def test_every_registered_type_is_listed_with_what_it_does(capsys):
    assert main(["components"]) == 0
    out = capsys.readouterr().out
    for names in registered().values():
        assert f"{names[0]}" in out
    assert ("WaterCoupler (also: Coupler): Stone-water interaction per water column: displacement, buoyancy, "
            "pressure, friction, wave drag, added mass.") in out.splitlines()


def test_a_type_shows_its_parameters_with_units_defaults_and_bounds_and_its_ports(capsys):
    assert main(["components", "RigidBody"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0] == "RigidBody - components.rigid_body:RigidBody"
    assert "  radius: a number = 0.05 [m], > 0" in lines
    assert "  velocity: a list of 3 numbers = [0.0, 0.0, 0.0] [m/s]" in lines
    assert "  mass: a number or null = null [kg], > 0" in lines
    assert "  shape: one of 'disk', 'sphere' = disk" in lines
    assert "  wrench (input): Wrench - external force and torque about the centre of mass, held over the step" in lines
    assert "  impulse (input, event): Impulse - contact impulses, applied once at the start of the step" in lines
    assert "  state (output): BodyState - state at the end of the step" in lines


def test_an_unknown_type_is_bad_input_naming_the_known_ones(capsys, tmp_path):
    assert main(["components", "WaterCouplr"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: cosim components: unknown component type 'WaterCouplr' "
                          "(known: Coupler, DropSource, FMU, ")
    assert len(err.splitlines()) == 1
    assert main(["components", "WaterCouplr", "--markdown", str(tmp_path / "c.md")]) == 2  # no page of it
    assert not (tmp_path / "c.md").exists()


def test_every_parameter_of_every_type_is_described():
    """No parameter of this project's types goes undocumented: each has a description."""
    for name in OWN:
        for row in type_info(name).params:
            assert row.doc, f"{name}.{row.name} has no description"


@pytest.mark.parametrize("value, text", [(None, "null"), (True, "true"), ((0.0, -1.5), "[0.0, -1.5]"),
                                         ("ring", "ring"), ([[0.0, 1.0]], "[[0.0, 1.0]]"), ({"a": 1}, "{a: 1}")])
def test_defaults_are_written_as_a_scene_writes_them(value, text):
    assert yaml_text(value) == text


@dataclass(frozen=True)
class _Inner:
    level: float = param(0.0, unit="m", ge=-1, doc="the level")


@dataclass(frozen=True)
class _Outer:
    inner: _Inner = field(default_factory=_Inner, metadata={"doc": "a group"})


def test_a_nested_mapping_lists_its_own_keys_after_it():
    rows = describe(_Outer)
    assert [(r.name, r.kind, r.default, r.unit, r.bounds) for r in rows] == [
        ("inner", "a mapping", "{level: 0.0}", "", ""), ("inner.level", "a number", "0.0", "m", ">= -1")]
