"""docs/scenes.md, the reference of a scene file's own keys, says what the loader does: its key tables
list exactly the keys :mod:`cosim.scenario` accepts, their defaults are the ones a scene gets, the
keys it calls required are refused when missing, its limits are the code's, and its example loads."""

from __future__ import annotations

import copy
import dataclasses
import re
from pathlib import Path
from typing import Any

import pytest
import yaml

from cosim import scenario
from cosim.errors import ScenarioError
from cosim.registry import registered
from cosim.scenario import COMPONENT_KEYS, TOP_KEYS, RecordConfig, loads

PAGE = Path(__file__).resolve().parents[1] / "docs" / "scenes.md"

# the smallest scene: only the required keys, one component with no required input
MINIMAL: dict[str, Any] = {"dt": 0.001, "until": 0.01, "components": {"disk": {"type": "RigidBody"}}}


def page() -> str:
    return PAGE.read_text(encoding="utf-8")


def section(heading: str) -> str:
    """The text under ``## heading`` (or ``### heading``), up to the next heading of any level."""
    match = re.search(rf"^#{{2,3}} {re.escape(heading)}\n(.*?)(?=^#|\Z)", page(), re.M | re.S)
    assert match, f"docs/scenes.md has no section {heading!r}"
    return match.group(1)


def table(heading: str) -> dict[str, dict[str, str]]:
    """The key table of a section: key -> {column: cell}, the key without its backticks."""
    lines = [line.strip() for line in section(heading).splitlines() if line.strip().startswith("|")]
    header = [cell.strip() for cell in lines[0].strip("|").split("|")]
    rows = {}
    for line in lines[2:]:  # past the header and its |---| line
        cells = [cell.strip() for cell in re.split(r"(?<!\\)\|", line.strip("|"))]
        assert len(cells) == len(header), f"a row of {heading!r} has {len(cells)} cells: {line}"
        key = cells[0].strip("`")
        assert key not in rows, f"{key!r} is listed twice under {heading!r}"
        rows[key] = dict(zip(header, cells, strict=True))
    return rows


def value_default(cell: str) -> tuple[bool, Any]:
    """(True, value) for a default written as one YAML value in backticks; (False, None) for prose."""
    match = re.fullmatch(r"`([^`]*)`", cell)
    return (True, yaml.safe_load(match.group(1))) if match else (False, None)


def load(data: dict[str, Any]) -> scenario.Scene:
    return loads(yaml.safe_dump(data), source="minimal.yaml")


def problems(data: dict[str, Any]) -> str:
    with pytest.raises(ScenarioError) as caught:
        load(data)
    return str(caught.value)


def test_the_documented_keys_are_the_ones_the_loader_accepts():
    assert set(table("Top-level keys")) == TOP_KEYS
    assert set(table("Component keys")) == COMPONENT_KEYS
    # the record block is parsed into RecordConfig: its fields are the keys it takes
    assert set(table("Record keys")) == {f.name for f in dataclasses.fields(RecordConfig)}
    # a connection's mapping form says the keys it knows when given another
    said = problems({**MINIMAL, "connections": [{"from": "a.b", "to": "c.d", "bogus": 1}]})
    known = re.search(r"unknown key 'bogus' \(known: ([^)]*)\)", said)
    assert known, said
    assert set(table("Connections")) == {k.strip() for k in known.group(1).split(",")}


def test_the_documented_defaults_are_the_ones_a_scene_gets():
    scene = load(MINIMAL)
    disk = scene.components["disk"]
    actual = {
        ("Top-level keys", "description"): scene.description,
        ("Top-level keys", "on_unstable"): disk.on_unstable,  # no component says otherwise
        ("Top-level keys", "connections"): scene.connections,
        ("Component keys", "every"): disk.every,
        ("Record keys", "channels"): scene.record.channels,
        ("Record keys", "every"): scene.record.every,
        ("Record keys", "checkpoint_every"): scene.record.checkpoint_every,
        ("Record keys", "visual_rate"): scene.record.visual_rate,
    }
    checked = set()
    for heading in ("Top-level keys", "Component keys", "Record keys"):
        for key, row in table(heading).items():
            is_value, documented = value_default(row["default"])
            if is_value:
                assert (heading, key) in actual, f"{heading}: {key}'s default {row['default']} is not checked here"
                assert documented == actual[heading, key], f"{heading}: {key} defaults to {actual[heading, key]!r}"
                checked.add((heading, key))
    assert checked == set(actual)
    # the record defaults are RecordConfig's own
    fields = {f.name: f.default for f in dataclasses.fields(RecordConfig)}
    assert {k: v for (h, k), v in actual.items() if h == "Record keys"} == fields
    # the prose defaults
    assert "the file's name without its extension" in table("Top-level keys")["name"]["default"]
    assert scene.name == "minimal"
    assert "the scene's `on_unstable`" in table("Component keys")["on_unstable"]["default"]
    assert load({**MINIMAL, "on_unstable": "substep"}).components["disk"].on_unstable == "substep"
    assert load({**MINIMAL, "record": None}).record == RecordConfig()


def test_the_keys_called_required_are_refused_when_missing():
    for heading, where in (("Top-level keys", ()), ("Component keys", ("components", "disk"))):
        required = {key for key, row in table(heading).items() if row["default"] == "required"}
        assert required, heading
        for key in required:
            data = copy.deepcopy(MINIMAL)
            node = data
            for part in where:
                node = node[part]
            del node[key]
            path = ".".join([*where, key])
            assert f"{path}: missing (required" in problems(data), path
    # and no other key is: the minimal scene holds only the required ones
    assert set(MINIMAL) == {k for k, row in table("Top-level keys").items() if row["default"] == "required"}
    assert set(MINIMAL["components"]["disk"]) == {k for k, row in table("Component keys").items()
                                                  if row["default"] == "required"}


def test_the_documented_choices_and_limits_are_the_code_s():
    text = " ".join(page().split())
    assert set(scenario.ON_UNSTABLE) == {"error", "substep"}
    assert "`error` or `substep`" in table("Top-level keys")["on_unstable"]["takes"]
    for phrase in (f"{scenario.MAX_SCENE_BYTES >> 20} MiB", f"{scenario.MAX_DEPTH} levels",
                   f"{scenario.MAX_VALUES:,} values", f"{scenario.MEMORY_SHARE:.0%} of the machine's memory",
                   f"{scenario.MAX_SUBSTEPS:,} substeps",
                   f"at most {scenario.LARGEST_INITIAL:.0e} in size".replace("e+", "e")):
        assert phrase in text, phrase
    assert scenario.NAME_RE.pattern.endswith("{0,63}") and "at most 64 characters" in text
    assert scenario.SCENE_NAME_RE.pattern.endswith("{0,99}") and "1 to 100 characters" in text
    assert scenario.MIN_STEP_NS == 1 and scenario.MAX_TIME_NS == 2**63 - 1 and "from 1 ns to 2^63 - 1 ns" in text


def test_the_documented_types_are_the_registered_ones():
    own = {name for target, names in registered().items() if target.partition(".")[0] in ("cosim", "components")
           for name in names}
    listed = section("Component types").split("- a class as")[0]
    assert set(re.findall(r"`([A-Za-z]+)`", listed)) == own
    for example in re.findall(r"`([\w.]+:\w+)`", section("Component types")):
        if example not in ("os:system", "package.module:Class"):
            scenario.resolve(example)  # the module:Class examples name real classes


def test_the_example_scene_loads():
    blocks = re.findall(r"```yaml\n(.*?)```", section("Example"), re.S)
    assert len(blocks) == 1
    scene = loads(blocks[0], source="example.yaml")
    assert scene.notices == []
    assert set(scene.data) == TOP_KEYS  # it shows every top-level key
    from cosim.runner import check_channel_patterns

    check_channel_patterns(scene)  # what cosim validate checks beyond loads
    # the connections section's example is the same edges
    edges = yaml.safe_load(re.findall(r"```yaml\n(.*?)```", section("Connections"), re.S)[0])["connections"]
    assert edges == scene.data["connections"]
