"""Visual items as Foxglove protobufs: schema names, timestamps, quaternions, arrows, vertex arrays."""

from __future__ import annotations

import math

import numpy as np
import pytest
from foxglove_schemas_protobuf.Point3_pb2 import Point3
from foxglove_schemas_protobuf.SceneUpdate_pb2 import SceneUpdate
from foxglove_schemas_protobuf.TriangleListPrimitive_pb2 import TriangleListPrimitive
from google.protobuf.descriptor_pb2 import FileDescriptorSet

from cosim.view.foxglove import (
    FoxgloveEncoder,
    arrow_orientation,
    repeated_vectors,
    scene_update,
    schema_data,
    to_protobuf,
)
from cosim.view.items import Arrow, Cube, Cylinder, Entity, LineStrip, LogLine, Sphere, Transform, TriangleList

T = 1_234_567_890_123  # [ns]


def rotate(q_wxyz, v):
    w, x, y, z = q_wxyz
    u = np.array([x, y, z])
    v = np.asarray(v, dtype=float)
    return v + 2 * np.cross(u, np.cross(u, v) + w * v)


def items():
    return [
        Transform("world", "stone", (1.0, 2.0, 3.0), (0.5, 0.5, 0.5, 0.5)),
        Entity("/scene/stone", "body", "stone", [Cylinder((0.1, 0.1, 0.01), (0.5, 0.5, 0.5, 1.0)),
                                                  Cube((0.05, 0.01, 0.001), (0.1, 0.1, 0.1, 1.0))],
               frame_locked=True),
        Entity("/scene/stone", "marker", "world", [Sphere((0.2, 0.2, 0.2), (1, 0, 0, 1))]),
        LogLine("/log", "warning", "monitor", "sink"),
    ]


def test_items_become_the_exact_foxglove_schemas():
    """Transforms, entities and log lines are written as foxglove.FrameTransforms, foxglove.SceneUpdate
    (one per topic per frame) and foxglove.Log, with protobuf FileDescriptorSet schemas."""
    out = FoxgloveEncoder().encode(T, items())
    assert [(m.topic, m.schema_name) for m in out] == [
        ("/tf", "foxglove.FrameTransforms"), ("/scene/stone", "foxglove.SceneUpdate"),
        ("/log", "foxglove.Log")]
    for m in out:
        assert m.schema_encoding == m.message_encoding == "protobuf"
        names = {f"{fd.package}.{mt.name}" for fd in FileDescriptorSet.FromString(m.schema_data).file
                 for mt in fd.message_type}
        assert m.schema_name in names


def test_schemas_are_the_bytes_mcap_protobufs_own_builder_gives():
    """The viewer channels' schemas are built here, without importing an MCAP writer, byte for byte
    as the MCAP protobuf support builds them (recordings stay byte-identical), every file a
    dependency once and before the files that import it."""
    from foxglove_schemas_protobuf.FrameTransforms_pb2 import FrameTransforms
    from foxglove_schemas_protobuf.Log_pb2 import Log
    from mcap_protobuf.schema import build_file_descriptor_set

    for cls in (SceneUpdate, FrameTransforms, Log):
        data = schema_data(cls)
        assert data == build_file_descriptor_set(cls).SerializeToString()
        names = [fd.name for fd in FileDescriptorSet.FromString(data).file]
        assert len(names) == len(set(names)) and names[-1] == cls.DESCRIPTOR.file.name
        for at, fd in enumerate(FileDescriptorSet.FromString(data).file):
            assert set(fd.dependency) <= set(names[:at])


def test_payload_timestamps_equal_the_frame_time():
    """Every entity, transform and log carries the frame's time (which the recorder uses as log time)."""
    converted = dict(to_protobuf(T, items()))
    stamps = [converted["/tf"].transforms[0].timestamp, converted["/log"].timestamp,
              *(e.timestamp for e in converted["/scene/stone"].entities)]
    assert len(stamps) == 4
    for ts in stamps:
        assert ts.seconds * 1_000_000_000 + ts.nanos == T


def test_quaternions_are_reordered_to_x_y_z_w():
    """cosim's (w, x, y, z) becomes Foxglove's x, y, z, w fields; positions pass unchanged."""
    tf = dict(to_protobuf(T, items()))["/tf"].transforms[0]
    assert (tf.parent_frame_id, tf.child_frame_id) == ("world", "stone")
    assert (tf.translation.x, tf.translation.y, tf.translation.z) == (1.0, 2.0, 3.0)
    q = Transform("w", "c", (0, 0, 0), (0.1, 0.2, 0.3, 0.4))
    rot = dict(to_protobuf(T, [q]))["/tf"].transforms[0].rotation
    assert (rot.w, rot.x, rot.y, rot.z) == (0.1, 0.2, 0.3, 0.4)


def test_entities_keep_id_frame_lock_and_primitives():
    """An entity keeps its id, frame, frame lock, and each primitive's size and colour."""
    update = dict(to_protobuf(T, items()))["/scene/stone"]
    body, marker = update.entities
    assert (body.id, body.frame_id, body.frame_locked) == ("body", "stone", True)
    assert (marker.id, marker.frame_id, marker.frame_locked) == ("marker", "world", False)
    cyl = body.cylinders[0]
    assert (cyl.size.x, cyl.size.y, cyl.size.z) == (0.1, 0.1, 0.01) and cyl.color.a == 1.0
    assert len(body.cubes) == 1 and len(marker.spheres) == 1
    assert body.lifetime.seconds == body.lifetime.nanos == 0  # lasts until replaced


@pytest.mark.parametrize("vector", [(1, 0, 0), (0, 2, 0), (0, 0, -3), (-1, 0, 0), (-1, 1e-9, 0), (3, -4, 12)])
def test_arrows_point_along_their_vector_with_its_length(vector):
    """An arrow's pose turns +x onto the vector; shaft plus head is the vector's length."""
    entity = Entity("/a", "a", "world", [Arrow((1, 2, 3), vector, (1, 0, 0, 1))])
    (arrow,) = scene_update(T, [entity]).entities[0].arrows
    o = arrow.pose.orientation
    direction = rotate((o.w, o.x, o.y, o.z), (1, 0, 0))
    v = np.asarray(vector, dtype=float)
    assert np.allclose(direction, v / np.linalg.norm(v), atol=1e-9)
    assert math.isclose(arrow.shaft_length + arrow.head_length, np.linalg.norm(v))
    assert (arrow.pose.position.x, arrow.pose.position.y, arrow.pose.position.z) == (1, 2, 3)
    assert math.isclose(sum(c * c for c in arrow_orientation(v)), 1.0)


def test_a_zero_arrow_draws_nothing():
    """A zero vector (a body at rest) gives no arrow primitive."""
    update = scene_update(T, [Entity("/a", "a", "world", [Arrow((0, 0, 0), (0, 0, 0), (1, 0, 0, 1))])])
    assert len(update.entities[0].arrows) == 0


def test_vertex_arrays_parse_to_the_same_messages_as_protobufs_own_encoding():
    """Points and colours merged from numpy-built wire bytes equal those added one by one."""
    rng = np.random.default_rng(3)
    pts = rng.normal(size=(300, 3))
    pts[0] = 0.0  # zeros and negative zero are kept exactly
    pts[1] = -0.0
    cols = rng.uniform(size=(300, 4))
    fast = TriangleListPrimitive()
    fast.MergeFromString(repeated_vectors(2, [1, 2, 3], pts) + repeated_vectors(4, [1, 2, 3, 4], cols))
    slow = TriangleListPrimitive()
    for x, y, z in pts.tolist():
        slow.points.add(x=x, y=y, z=z)
    for r, g, b, a in cols.tolist():
        slow.colors.add(r=r, g=g, b=b, a=a)
    assert fast == slow
    assert np.array_equal([[p.x, p.y, p.z] for p in fast.points], pts)
    assert math.copysign(1.0, fast.points[1].x) == -1.0
    assert Point3.DESCRIPTOR.fields_by_name["z"].number == 3


def test_triangle_lists_and_line_strips_round_trip():
    """A triangle list keeps points, per-vertex colours and indices; a line strip its points."""
    pts = np.arange(12, dtype=float).reshape(4, 3) / 7
    cols = np.linspace(0, 1, 16).reshape(4, 4)
    idx = np.array([0, 1, 2, 2, 1, 3], dtype=np.uint32)
    entity = Entity("/s", "s", "world", [TriangleList(pts, colors=cols, indices=idx),
                                          LineStrip(pts, (1, 1, 1, 1), 0.01)])
    data = scene_update(T, [entity]).SerializeToString()
    back = SceneUpdate.FromString(data).entities[0]
    tri, line = back.triangles[0], back.lines[0]
    assert np.array_equal([[p.x, p.y, p.z] for p in tri.points], pts)
    assert np.array_equal([[c.r, c.g, c.b, c.a] for c in tri.colors], cols)
    assert list(tri.indices) == idx.tolist()
    assert np.array_equal([[p.x, p.y, p.z] for p in line.points], pts) and line.thickness == 0.01


def test_a_64_by_64_surface_encodes_quickly_and_compactly():
    """A full-size surface message stays under 400 kB (it compresses further in the recording)."""
    from components.messages import WaterField
    from components.visuals import water_field

    h = np.random.default_rng(0).normal(scale=0.003, size=(300, 500))
    (entity,) = water_field("pond", "field", WaterField(0.01, 0.0, 0.0, h, 1.0, 0.0))
    (msg,) = FoxgloveEncoder().encode(T, [entity])
    assert len(msg.data) < 400_000
    assert len(SceneUpdate.FromString(msg.data).entities[0].triangles[0].points) == 64 * 64
