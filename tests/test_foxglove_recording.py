"""Viewer channels in a recorded run: names, schemas, content against the physics, off the physics path.

The scripted skip (tests/viewer_toys.py)::

    stone --state--> coupler --contact--> stages       pond --field-->   (every 10 ms)
      '----state-------------------------->'

is recorded with viewer channels at 30 frames/s; the checks compare each viewer message with the
physics message recorded on the same log time.
"""

from __future__ import annotations

import math
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from foxglove_schemas_protobuf.FrameTransforms_pb2 import FrameTransforms
from foxglove_schemas_protobuf.Log_pb2 import Log
from foxglove_schemas_protobuf.SceneUpdate_pb2 import SceneUpdate
from mcap.reader import make_reader

from components.messages import BodyState, Stage, WaterField
from components.visuals import SURFACE_SIDE
from cosim.record.reader import Recording
from cosim.view.items import decimation
from tests.viewer_toys import record_skip

ROOT = Path(__file__).resolve().parents[1]
CHECKER = ROOT / "tools" / "mcap_check" / "check.mjs"
VIEWER_CHANNELS = {
    "/tf": "foxglove.FrameTransforms",
    "/scene/stone": "foxglove.SceneUpdate",
    "/scene/stone/trail": "foxglove.SceneUpdate",
    "/scene/stone/velocity": "foxglove.SceneUpdate",
    "/scene/pond": "foxglove.SceneUpdate",
    "/log": "foxglove.Log",
}


@pytest.fixture(scope="module")
def skip_run(tmp_path_factory):
    path = tmp_path_factory.mktemp("viewer") / "skip.mcap"
    record_skip(path)
    return Recording(path)


def viewer(rec: Recording, topic: str, proto):
    return [(stamp, proto.FromString(data)) for _, stamp, data in rec.raw([topic])]


def stamp_ns(ts) -> int:
    return ts.seconds * 1_000_000_000 + ts.nanos


def test_viewer_channels_have_the_exact_foxglove_schema_names(skip_run):
    """Each viewer channel is protobuf under its foxglove.* schema name, beside the physics channels."""
    for topic, schema in VIEWER_CHANNELS.items():
        ch = skip_run.channels[topic]
        assert (ch.schema_name, ch.message_encoding, ch.schema_encoding) == (schema, "protobuf", "protobuf")
    assert skip_run.channels["/stone/state"].schema_name == "cosim.BodyState"
    assert skip_run.channels["/stages/stage"].schema_name == "cosim.Stage"


def test_frames_are_drawn_at_the_visual_rate_of_simulation_time(skip_run):
    """/tf has one message per frame: the first state at or after each k/30 s."""
    states = [t for t, _ in skip_run.messages("/stone/state", BodyState)]
    expected = []
    for k in range(0, 19):
        due = -(-k * 1_000_000_000 // 30)
        expected.append(next(t for t in states if t >= due))
    assert [t for t, _ in viewer(skip_run, "/tf", FrameTransforms)] == expected


def test_tf_poses_equal_the_recorded_state_at_the_same_time(skip_run):
    """Each world -> stone transform holds the recorded position and quaternion at its log time,
    and its payload timestamp equals that log time."""
    states = dict(skip_run.messages("/stone/state", BodyState))
    frames = viewer(skip_run, "/tf", FrameTransforms)
    assert len(frames) > 10
    for stamp, msg in frames:
        (tf,) = msg.transforms
        state = states[stamp]
        assert stamp_ns(tf.timestamp) == stamp
        assert (tf.parent_frame_id, tf.child_frame_id) == ("world", "stone")
        assert [tf.translation.x, tf.translation.y, tf.translation.z] == state.position.tolist()
        assert [tf.rotation.w, tf.rotation.x, tf.rotation.y, tf.rotation.z] == state.orientation.tolist()


def test_the_stone_entity_is_a_frame_locked_disk_of_the_recorded_size(skip_run):
    """/scene/stone holds entity 'body' in frame 'stone', frame-locked, a cylinder 2R x 2R x thickness."""
    (_, first), *_ = viewer(skip_run, "/scene/stone", SceneUpdate)
    _, state = skip_run.messages("/stone/state", BodyState)[0]
    (entity,) = first.entities
    assert (entity.id, entity.frame_id, entity.frame_locked) == ("body", "stone", True)
    cyl = entity.cylinders[0]
    assert [cyl.size.x, cyl.size.y, cyl.size.z] == [2 * state.radius, 2 * state.radius, state.thickness]


def test_trail_and_velocity_follow_the_recorded_states(skip_run):
    """The trail's points, its history's and then its tip's, are the recorded positions at the
    frames so far; the velocity arrow starts at the position of its frame."""
    states = dict(skip_run.messages("/stone/state", BodyState))
    frames = [t for t, _ in viewer(skip_run, "/tf", FrameTransforms)]
    history: list = []
    for i, (stamp, msg) in enumerate(viewer(skip_run, "/scene/stone/trail", SceneUpdate)):
        strips = {e.id: [[p.x, p.y, p.z] for p in e.lines[0].points] for e in msg.entities}
        assert set(strips) in ({"trail-tip"}, {"trail", "trail-tip"})
        assert all(e.frame_id == "world" for e in msg.entities)
        history = strips.get("trail", history)
        points = history[:-1] + strips["trail-tip"] if history else strips["trail-tip"]
        assert points == [states[t].position.tolist() for t in frames[: i + 1]]
        assert stamp == frames[i]
    for stamp, msg in viewer(skip_run, "/scene/stone/velocity", SceneUpdate):
        arrow = msg.entities[0].arrows[0]
        assert [arrow.pose.position.x, arrow.pose.position.y, arrow.pose.position.z] == \
            states[stamp].position.tolist()


def test_surface_vertex_heights_equal_the_water_field(skip_run):
    """Each surface vertex holds the height of the recorded water field's cell at the same time,
    over at most 64 x 64 vertices."""
    fields = dict(skip_run.messages("/pond/field", WaterField))
    frames = viewer(skip_run, "/scene/pond", SceneUpdate)
    assert len(frames) >= 10
    for stamp, msg in frames:
        field = fields[stamp]
        (entity,) = msg.entities
        assert (entity.id, entity.frame_id) == ("surface", "world") and stamp_ns(entity.timestamp) == stamp
        tri = entity.triangles[0]
        rows = decimation(field.height.shape[0], SURFACE_SIDE)
        cols = decimation(field.height.shape[1], SURFACE_SIDE)
        z = np.array([p.z for p in tri.points])
        assert len(z) == len(rows) * len(cols) <= 64 * 64
        assert np.array_equal(z, field.height[np.ix_(rows, cols)].ravel())
        assert len(tri.colors) == len(tri.points)
        assert len(tri.indices) == 6 * (len(rows) - 1) * (len(cols) - 1)


def test_stage_log_matches_the_stage_channel(skip_run):
    """Every message on /stages/stage has one foxglove.Log line at the same time naming the stage."""
    stages = skip_run.messages("/stages/stage", Stage)
    logs = [(t, m) for t, m in viewer(skip_run, "/log", Log) if m.message.split(" ")[0] != "skip"]
    assert len(stages) >= 10 and len(logs) == len(stages)
    for (t_stage, stage), (t_log, log) in zip(stages, logs, strict=True):
        assert t_log == t_stage == stamp_ns(log.timestamp)
        assert log.name == "stages"
        assert log.message.startswith(f"{stage.label} (stage {int(stage.stage)}): skips {stage.skips}")


def test_every_foxglove_payload_timestamp_equals_log_time(skip_run):
    """log_time = publish_time = the timestamp inside every viewer payload; sequences count up."""
    protos = {"foxglove.SceneUpdate": SceneUpdate, "foxglove.FrameTransforms": FrameTransforms,
              "foxglove.Log": Log}
    last: dict[str, int] = {}
    with open(skip_run.path, "rb") as f:
        for schema, channel, msg in make_reader(f).iter_messages(log_time_order=False):
            if schema.name not in protos:
                continue
            assert msg.publish_time == msg.log_time
            assert msg.sequence == last.get(channel.topic, 0) + 1
            last[channel.topic] = msg.sequence
            decoded = protos[schema.name].FromString(msg.data)
            stamps = ([decoded.timestamp] if schema.name == "foxglove.Log" else
                      [e.timestamp for e in getattr(decoded, "entities", [])] +
                      [t.timestamp for t in getattr(decoded, "transforms", [])])
            assert stamps and all(stamp_ns(s) == msg.log_time for s in stamps)


def physics(path: Path) -> dict[str, list[tuple[int, int, bytes]]]:
    out: dict[str, list] = {}
    with open(path, "rb") as f:
        reader = make_reader(f)
        for schema, channel, msg in reader.iter_messages():
            if schema.name.startswith("cosim."):
                out.setdefault(channel.topic, []).append((msg.log_time, msg.sequence, msg.data))
    return out


@pytest.fixture(scope="module")
def plain_run(tmp_path_factory):
    path = tmp_path_factory.mktemp("plain") / "plain.mcap"
    record_skip(path, ["record.visual_rate=0"])
    return Recording(path)


def test_visual_channels_do_not_touch_the_physics(skip_run, plain_run):
    """A run without viewer channels (visual_rate 0) records exactly the same physics channels."""
    assert not any(c.schema_name.startswith("foxglove.") for c in plain_run.channels.values())
    with_views, without = physics(skip_run.path), physics(plain_run.path)
    assert with_views.keys() == without.keys() and "/stone/state" in without
    for topic in without:
        assert with_views[topic] == without[topic], topic


def test_the_visual_rate_changes_only_the_viewer_channels(skip_run, tmp_path):
    """At 60 frames/s the viewer channels get more frames; the physics channels stay identical."""
    fast = tmp_path / "fast.mcap"
    record_skip(fast, ["record.visual_rate=60"])
    assert Recording(fast).channels["/tf"].count > skip_run.channels["/tf"].count
    assert physics(fast) == physics(skip_run.path)


needs_mcap_check = pytest.mark.skipif(
    shutil.which("node") is None or not (CHECKER.parent / "node_modules").exists(),
    reason="node or tools/mcap_check/node_modules missing (npm install in tools/mcap_check)")


@needs_mcap_check
def test_the_independent_typescript_reader_decodes_every_viewer_message(skip_run):
    """@mcap/core under node validates CRCs and decodes every foxglove.* message against its schema,
    with payload timestamps equal to log time."""
    done = subprocess.run(["node", str(CHECKER), str(skip_run.path)], capture_output=True, text=True,
                          timeout=120)
    assert done.returncode == 0, done.stdout + done.stderr
    assert "1 passed, 0 failed" in done.stdout


def test_recorded_viewer_data_stays_modest(skip_run, plain_run):
    """At 30 frames/s with a 64 x 50 surface, the viewer channels add under 1.5 MB per simulated
    second to the file; a static body is sent once (and re-sent only every second)."""
    added = skip_run.path.stat().st_size - plain_run.path.stat().st_size
    assert 0 < added / 0.6 < 1_500_000
    assert skip_run.channels["/scene/stone"].count == 1


@pytest.mark.parametrize("thinned", [False, True])
def test_the_runs_last_state_is_drawn(tmp_path, thinned):
    """The viewer draws the run's end: its last frame is the body's last state, wherever the frame
    rate left it (a held skip leaving a 3 m pond at 0.565 s was drawn at 0.5335 s, 18 cm short and
    above the water it had gone under). So in a full recording (the writer draws the viewer
    channels) and a thinned one (drawn in the simulating process, whose last state is not even
    recorded: the viewer still shows where the run ended)."""
    from cosim.cli import main

    path = tmp_path / "short.mcap"
    thin = ["--record-every", "3"] if thinned else []
    assert main(["run", str(ROOT / "scenarios" / "held_skip.yaml"), "--set", "components.pond.nx=300", "-q",
                 *thin, "-o", str(path)]) == 0
    rec = Recording(path)
    stamp, last = viewer(rec, "/tf", FrameTransforms)[-1]
    (tf,) = last.transforms
    end = rec.status()
    assert stamp == round(end.time * 1e9) == 565_000_000
    recorded_ns, state = rec.messages("/stone/state", BodyState)[-1]
    if not thinned:
        assert recorded_ns == stamp and [tf.translation.x, tf.translation.y, tf.translation.z] == \
            state.position.tolist()
    else:  # (its last state thinned away: the viewer's is a step later)
        assert recorded_ns < stamp and tf.translation.z < state.position[2] < 0.0


def test_each_ground_is_drawn_as_a_slab_under_its_plane_where_its_body_went(tmp_path):
    """scenarios/ramp_slide.yaml: each ramp's last frame is a 2 mm slab whose top face lies in the ramp's
    plane, along the slope over the whole path its disk slid (4.8 m on 35 deg) with 5 cm and the disk's
    radius beyond it, and the two ramps, 0.3 m apart across the slope, are drawn side by side without
    overlapping (grounds were not drawn at all: a disk slid down nothing)."""
    from components.contact.geometry import slope_plane
    from components.visuals import GROUND_SLAB, plane_axes
    from cosim.runner import run_scene
    from cosim.scenario import load

    path = tmp_path / "ramp.mcap"
    run_scene(load(Path(__file__).resolve().parent.parent / "scenarios" / "ramp_slide.yaml"), path, progress=False)
    rec = Recording(path)
    spans = {}
    for ramp, disk, slope, point in (("ramp_20", "disk_holds", 20.0, (0.0, 0.0, 0.0)),
                                     ("ramp_35", "disk_slides", 35.0, (0.0, 0.3, 0.0))):
        (_, last), = viewer(rec, f"/scene/{ramp}", SceneUpdate)[-1:]
        (cube,) = last.entities[0].cubes
        plane = slope_plane(point, slope, 0.0)
        q, u, w = plane_axes(plane.normal)
        pose = cube.pose
        assert (pose.orientation.w, pose.orientation.x, pose.orientation.y, pose.orientation.z) == pytest.approx(q)
        centre = np.array([pose.position.x, pose.position.y, pose.position.z])
        top = centre + 0.5 * GROUND_SLAB * np.array(plane.normal)
        assert plane.height(tuple(top)) == pytest.approx(0.0, abs=1e-12)
        assert cube.size.z == GROUND_SLAB
        path_points = np.array([m.position for _, m in rec.messages(f"/{disk}/state", BodyState)]) - np.array(point)
        a = path_points @ u
        reach = 0.05 + math.hypot(0.05, 0.003)  # the margin and the disk's radius (its bounding sphere's)
        along = float((centre - np.array(point)) @ u)
        assert along - cube.size.x / 2 == pytest.approx(a.min() - reach, abs=0.02)  # (frames, not every step)
        assert along + cube.size.x / 2 == pytest.approx(a.max() + reach, abs=0.02)
        across = float((centre - np.array(point)) @ w)
        spans[ramp] = (point[1] + across - cube.size.y / 2, point[1] + across + cube.size.y / 2)
    assert a.max() - a.min() > 4.5  # the sliding disk's path, all of it under its slab
    assert spans["ramp_20"][1] <= spans["ramp_35"][0] + 1e-9
