"""tools/foxglove/layout.json: a classic configById layout whose panels point at channels runs write."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest
import yaml

from components.messages import BodyState, Stage
from cosim.codec.json_codec import codec_for
from cosim.record.reader import Recording
from tests.viewer_toys import record_skip

ROOT = Path(__file__).resolve().parents[1]
LAYOUT = ROOT / "tools" / "foxglove" / "layout.json"
REFERENCE = ROOT / "scenarios" / "skip.yaml"


@pytest.fixture(scope="module")
def layout():
    return json.loads(LAYOUT.read_text())


def leaves(node) -> list[str]:
    if isinstance(node, str):
        return [node]
    assert node["direction"] in ("row", "column") and 0 < node.get("splitPercentage", 50) < 100
    return leaves(node["first"]) + leaves(node["second"])


def message_paths(layout) -> list[str]:
    return [p["value"] for cfg in layout["configById"].values() for p in cfg.get("paths", [])]


def test_every_panel_in_the_tree_is_configured_and_every_config_is_shown(layout):
    """The mosaic tree's leaves are exactly the configById keys, each 'Type!id'."""
    assert sorted(leaves(layout["layout"])) == sorted(layout["configById"])
    kinds = {key.split("!")[0] for key in layout["configById"]}
    assert {"3D", "Plot", "StateTransitions", "RosOut"} <= kinds


def test_the_3d_panel_follows_the_stone_and_shows_the_scene_topics(layout):
    """The 3D panel follows frame 'stone' and shows the stone, its trail and velocity, and the water."""
    three_d = layout["configById"]["3D!stone"]
    assert three_d["followTf"] == "stone" and three_d["followMode"].startswith("follow")
    scene_topics = {"/scene/stone", "/scene/stone/trail", "/scene/stone/velocity", "/scene/pond"}
    assert set(three_d["topics"]) == scene_topics


def test_plots_show_height_speed_and_attack_angle_and_the_stage(layout):
    """Plots of /stone/state.position[2], .speed and .attack_angle_deg; State Transitions on the stage."""
    paths = message_paths(layout)
    assert {"/stone/state.position[2]", "/stone/state.speed", "/stone/state.attack_angle_deg"} <= set(paths)
    transitions = [p["value"] for p in layout["configById"]["StateTransitions!stage"]["paths"]]
    assert "/stages/stage.stage" in transitions
    fields = {"/stone/state": codec_for(BodyState).schema()["properties"],
              "/stages/stage": codec_for(Stage).schema()["properties"]}
    for path in paths:
        topic, field = re.match(r"^(/[\w/]+)\.(\w+)", path).groups()
        assert field in fields[topic], path


def test_a_recording_has_every_channel_the_layout_names(layout, tmp_path):
    """A run with the reference component names has every topic the layout's panels read."""
    rec = Recording(record_skip(tmp_path / "skip.mcap").recording)
    wanted = set(layout["configById"]["3D!stone"]["topics"])
    wanted |= {re.match(r"^(/[\w/]+)\.", p).group(1) for p in message_paths(layout)}
    wanted.add(layout["configById"]["RosOut!log"]["topicToRender"])
    assert wanted <= set(rec.channels), wanted - set(rec.channels)


@pytest.mark.skipif(not REFERENCE.exists(), reason="no reference scene")
def test_the_layout_uses_the_reference_scene_names(layout):
    """The reference skip names its body 'stone', its water 'pond' and its stage monitor 'stages'."""
    components = yaml.safe_load(REFERENCE.read_text())["components"]
    assert components["stone"]["type"] == "RigidBody"
    assert components["pond"]["type"] == "WaterSurface"
    assert components["stages"]["type"] == "StageMonitor"
