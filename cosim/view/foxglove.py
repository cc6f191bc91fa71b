"""Visual items (:mod:`cosim.view.items`) as Foxglove messages: ``foxglove.SceneUpdate``,
``foxglove.FrameTransforms`` and ``foxglove.Log`` protobufs, from the ``foxglove-schemas-protobuf``
package (the ``[viz]`` extra), with their schemas as MCAP wants them (:func:`schema_data`).

Per frame, the entities of one topic go into one SceneUpdate, all transforms of one topic into one
FrameTransforms, and each log line into one Log. Every payload timestamp (SceneEntity.timestamp,
FrameTransform.timestamp, Log.timestamp) equals the frame's time, which the recorder also uses as
log time; the recorder numbers each channel's messages.

Quaternions are (w, x, y, z) in cosim and (x, y, z, w) in Foxglove. Large vertex arrays (a water
surface, a long trail) are written as wire-format bytes built with numpy and spliced into the
serialized message (protobuf fields may come in any order, and a message's bytes are the
concatenation of its fields'), far cheaper than adding thousands of Point3/Color messages one by one
or than parsing and re-serializing them; the tests parse the result back with the protobuf library.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from functools import cache, lru_cache
from typing import Any

import numpy as np
from foxglove_schemas_protobuf.ArrowPrimitive_pb2 import ArrowPrimitive
from foxglove_schemas_protobuf.Color_pb2 import Color
from foxglove_schemas_protobuf.FrameTransforms_pb2 import FrameTransforms
from foxglove_schemas_protobuf.LinePrimitive_pb2 import LinePrimitive
from foxglove_schemas_protobuf.Log_pb2 import Log
from foxglove_schemas_protobuf.Point3_pb2 import Point3
from foxglove_schemas_protobuf.Pose_pb2 import Pose
from foxglove_schemas_protobuf.SceneEntity_pb2 import SceneEntity
from foxglove_schemas_protobuf.SceneUpdate_pb2 import SceneUpdate
from foxglove_schemas_protobuf.TriangleListPrimitive_pb2 import TriangleListPrimitive
from google.protobuf.descriptor import FileDescriptor
from google.protobuf.descriptor_pb2 import FileDescriptorSet
from google.protobuf.message import Message as ProtoMessage
from google.protobuf.timestamp_pb2 import Timestamp

from cosim.record.derive import DerivedMessage
from cosim.timebase import NS_PER_S
from cosim.view import items as v
from cosim.view.lookup import installed_visuals

SCHEMA_ENCODING = "protobuf"
MESSAGE_ENCODING = "protobuf"
LOG_LEVEL = {"debug": Log.DEBUG, "info": Log.INFO, "warning": Log.WARNING, "error": Log.ERROR,
             "fatal": Log.FATAL}

VIEWER_SCHEMAS = ("foxglove.SceneUpdate", "foxglove.FrameTransforms", "foxglove.Log")


@cache
def schema_data(message_class: type[ProtoMessage]) -> bytes:
    """The serialized FileDescriptorSet of a protobuf message class (its MCAP schema data): the
    files it depends on, each once and before the files that import it, then its own file. The same
    bytes as ``mcap_protobuf.schema.build_file_descriptor_set`` gives, built here because importing
    that module imports an MCAP writer (10 ms of a short run's start), which the simulating process
    never uses: its writer process writes the file."""
    files = FileDescriptorSet()
    seen: set[str] = set()

    def add(file: FileDescriptor) -> None:
        for dependency in file.dependencies:
            if dependency.name not in seen:
                seen.add(dependency.name)
                add(dependency)
        file.CopyToProto(files.file.add())

    add(message_class.DESCRIPTOR.file)
    return files.SerializeToString()


def timestamp(time_ns: int) -> Timestamp:
    seconds, nanos = divmod(int(time_ns), NS_PER_S)
    return Timestamp(seconds=seconds, nanos=nanos)


# --- geometry -----------------------------------------------------------------------------------

def _pose(out: Pose, position: Any, orientation: Any = v.IDENTITY) -> None:
    x, y, z = (float(c) for c in position)
    w, qx, qy, qz = (float(c) for c in orientation)
    out.position.x, out.position.y, out.position.z = x, y, z
    out.orientation.x, out.orientation.y, out.orientation.z, out.orientation.w = qx, qy, qz, w


def _color(out: Color, rgba: Sequence[float]) -> None:
    out.r, out.g, out.b, out.a = (float(c) for c in rgba)


def _size(out: Any, size: Any) -> None:
    out.x, out.y, out.z = (float(c) for c in size)


def arrow_orientation(direction: np.ndarray) -> tuple[float, float, float, float]:
    """The unit quaternion (w, x, y, z) turning +x (a Foxglove arrow's axis) onto ``direction``."""
    d = direction / np.linalg.norm(direction)
    w = 1.0 + float(d[0])
    if w < 1e-12:  # pointing along -x: half a turn about z
        return (0.0, 0.0, 0.0, 1.0)
    q = np.array([w, 0.0, -float(d[2]), float(d[1])])  # (1 + x.d, x cross d)
    q /= np.linalg.norm(q)
    return (float(q[0]), float(q[1]), float(q[2]), float(q[3]))


# --- repeated vectors from numpy ----------------------------------------------------------------

def _varint(n: int) -> bytes:
    out = bytearray()
    while True:
        byte, n = n & 0x7F, n >> 7
        if not n:
            out.append(byte)
            return bytes(out)
        out.append(byte | 0x80)


def _double_fields(message_class: type[ProtoMessage], names: Sequence[str]) -> list[int]:
    fields = message_class.DESCRIPTOR.fields_by_name
    numbers = []
    for name in names:
        f = fields[name]
        if f.type != f.TYPE_DOUBLE:  # pragma: no cover - guards a schema change
            raise TypeError(f"{message_class.DESCRIPTOR.full_name}.{name} is not a double")
        numbers.append(f.number)
    return numbers


_POINT_FIELDS = _double_fields(Point3, ("x", "y", "z"))
_COLOR_FIELDS = _double_fields(Color, ("r", "g", "b", "a"))
_INDICES_FIELD = TriangleListPrimitive.DESCRIPTOR.fields_by_name["indices"].number


def repeated_vectors(field_number: int, sub_fields: Sequence[int], values: np.ndarray) -> bytes:
    """Wire-format bytes of a repeated message field (``field_number``) whose messages hold the
    double fields ``sub_fields``, one message per row of ``values`` (N, len(sub_fields))."""
    arr = np.ascontiguousarray(values, dtype="<f8")
    n, k = arr.shape
    if k != len(sub_fields):
        raise ValueError(f"expected {len(sub_fields)} columns, got {k}")
    rec = _vector_template(field_number, tuple(sub_fields), n).copy()
    # each row's doubles seen in place (unaligned, after their tags): copied as doubles, not byte by byte
    doubles = rec.view(_doubles_dtype(rec.shape[1], k)).reshape(n)
    for j in range(k):
        doubles[f"v{j}"] = arr[:, j]
    return rec.tobytes()


@lru_cache(maxsize=16)
def _doubles_dtype(row: int, k: int) -> np.dtype:
    """A record of ``row`` bytes whose fields v0 .. v{k-1} are the ``k`` little-endian doubles of a
    :func:`repeated_vectors` row, each after its one-byte tag at the row's end."""
    first = row - 9 * k + 1
    return np.dtype({"names": [f"v{j}" for j in range(k)], "formats": ["<f8"] * k,
                     "offsets": [first + 9 * j for j in range(k)], "itemsize": row})


@lru_cache(maxsize=16)
def _vector_template(field_number: int, sub_fields: tuple[int, ...], n: int) -> np.ndarray:
    """The bytes of :func:`repeated_vectors` but for the doubles themselves, one row per message:
    the field's tag, the message length and each double's tag (the same every frame)."""
    body = 9 * len(sub_fields)  # per double: a one-byte tag and 8 bytes
    head = _varint(field_number << 3 | 2) + _varint(body)
    rec = np.zeros((n, len(head) + body), dtype=np.uint8)
    rec[:, : len(head)] = np.frombuffer(head, dtype=np.uint8)
    for j, number in enumerate(sub_fields):
        rec[:, len(head) + 9 * j] = number << 3 | 1  # wire type 1: 64-bit
    rec.flags.writeable = False
    return rec


def packed_fixed32(field_number: int, values: np.ndarray) -> bytes:
    """Wire-format bytes of a packed repeated ``fixed32`` field: its tag, its length, and the values'
    little-endian bytes."""
    data = np.ascontiguousarray(values, dtype="<u4").tobytes()
    return _varint(field_number << 3 | 2) + _varint(len(data)) + data


@lru_cache(maxsize=8)
def _triangle_indices(data: bytes) -> bytes:
    """TriangleListPrimitive.indices as wire bytes; cached, because a water surface's triangles are
    the same every frame (keyed by the indices' own bytes)."""
    return packed_fixed32(_INDICES_FIELD, np.frombuffer(data, dtype="<u4"))


def _field(field_number: int, data: bytes) -> bytes:
    """Wire-format bytes of a length-delimited field (a sub-message, given as its bytes)."""
    return _varint(field_number << 3 | 2) + _varint(len(data)) + data


def _vertices(message_class: type[ProtoMessage], name: str, columns: Sequence[int], values: np.ndarray) -> bytes:
    """A repeated Point3 (3 columns) or Color (4 columns) field of ``message_class`` as wire bytes."""
    number = message_class.DESCRIPTOR.fields_by_name[name].number
    return repeated_vectors(number, columns, np.asarray(values, dtype=np.float64).reshape(-1, len(columns)))


_LINES_FIELD = SceneEntity.DESCRIPTOR.fields_by_name["lines"].number
_TRIANGLES_FIELD = SceneEntity.DESCRIPTOR.fields_by_name["triangles"].number
_ENTITIES_FIELD = SceneUpdate.DESCRIPTOR.fields_by_name["entities"].number


# --- items --------------------------------------------------------------------------------------

def _add_primitive(entity: SceneEntity, prim: v.Primitive, spliced: list[bytes]) -> None:
    """Add ``prim`` to ``entity``; a line strip or triangle list goes to ``spliced`` instead, as the
    wire bytes of its field in the entity."""
    if isinstance(prim, v.Sphere):
        out = entity.spheres.add()
        _pose(out.pose, prim.pose.position, prim.pose.orientation)
        _size(out.size, prim.size)
        _color(out.color, prim.color)
    elif isinstance(prim, v.Cylinder):
        out = entity.cylinders.add()
        _pose(out.pose, prim.pose.position, prim.pose.orientation)
        _size(out.size, prim.size)
        out.bottom_scale, out.top_scale = float(prim.bottom_scale), float(prim.top_scale)
        _color(out.color, prim.color)
    elif isinstance(prim, v.Cube):
        out = entity.cubes.add()
        _pose(out.pose, prim.pose.position, prim.pose.orientation)
        _size(out.size, prim.size)
        _color(out.color, prim.color)
    elif isinstance(prim, v.Arrow):
        vec = np.asarray(prim.vector, dtype=np.float64)
        length = float(np.linalg.norm(vec))
        if not length > 0 or not math.isfinite(length):
            return
        head = min(length, prim.head_length if prim.head_length is not None else 0.25 * length)
        arrow: ArrowPrimitive = entity.arrows.add()
        _pose(arrow.pose, prim.start, arrow_orientation(vec))
        arrow.shaft_length, arrow.head_length = length - head, head
        arrow.shaft_diameter, arrow.head_diameter = float(prim.shaft_diameter), float(prim.head_diameter)
        _color(arrow.color, prim.color)
    elif isinstance(prim, v.LineStrip):
        line = LinePrimitive(type=LinePrimitive.LINE_STRIP, thickness=float(prim.thickness))
        _pose(line.pose, (0.0, 0.0, 0.0))
        _color(line.color, prim.color)
        parts = [line.SerializeToString(), _vertices(LinePrimitive, "points", _POINT_FIELDS, prim.points)]
        if prim.colors is not None:
            parts.append(_vertices(LinePrimitive, "colors", _COLOR_FIELDS, prim.colors))
        spliced.append(_field(_LINES_FIELD, b"".join(parts)))
    elif isinstance(prim, v.TriangleList):
        tri = TriangleListPrimitive()
        _pose(tri.pose, (0.0, 0.0, 0.0))
        _color(tri.color, prim.color)
        parts = [tri.SerializeToString(), _vertices(TriangleListPrimitive, "points", _POINT_FIELDS, prim.points)]
        if prim.colors is not None:
            parts.append(_vertices(TriangleListPrimitive, "colors", _COLOR_FIELDS, prim.colors))
        if prim.indices is not None:
            parts.append(_triangle_indices(np.ascontiguousarray(prim.indices, dtype="<u4").tobytes()))
        spliced.append(_field(_TRIANGLES_FIELD, b"".join(parts)))
    else:
        raise TypeError(f"not a visual primitive: {type(prim).__name__}")


def scene_update_bytes(time_ns: int, entities: Sequence[v.Entity]) -> bytes:
    """The wire bytes of one SceneUpdate holding ``entities``, each stamped ``time_ns``, lasting
    until replaced."""
    out = []
    stamp = timestamp(time_ns)
    for item in entities:
        entity = SceneEntity(frame_id=item.frame_id, id=item.id, frame_locked=bool(item.frame_locked))
        entity.timestamp.CopyFrom(stamp)
        spliced: list[bytes] = []
        for prim in item.primitives:
            _add_primitive(entity, prim, spliced)
        out.append(_field(_ENTITIES_FIELD, entity.SerializeToString() + b"".join(spliced)))
    return b"".join(out)


def scene_update(time_ns: int, entities: Sequence[v.Entity]) -> SceneUpdate:
    """One SceneUpdate holding ``entities`` (:func:`scene_update_bytes`, parsed)."""
    return SceneUpdate.FromString(scene_update_bytes(time_ns, entities))


def frame_transforms(time_ns: int, transforms: Sequence[v.Transform]) -> FrameTransforms:
    """One FrameTransforms holding ``transforms``, each stamped ``time_ns``."""
    out = FrameTransforms()
    for item in transforms:
        tf = out.transforms.add()
        tf.timestamp.CopyFrom(timestamp(time_ns))
        tf.parent_frame_id, tf.child_frame_id = item.parent, item.child
        x, y, z = (float(c) for c in item.position)
        w, qx, qy, qz = (float(c) for c in item.orientation)
        tf.translation.x, tf.translation.y, tf.translation.z = x, y, z
        tf.rotation.x, tf.rotation.y, tf.rotation.z, tf.rotation.w = qx, qy, qz, w
    return out


def log(time_ns: int, line: v.LogLine) -> Log:
    return Log(timestamp=timestamp(time_ns), level=LOG_LEVEL[line.level], message=line.text, name=line.name)


def to_wire(time_ns: int, items: Sequence[v.Item]) -> list[tuple[str, type[ProtoMessage], bytes]]:
    """(topic, protobuf message class, wire bytes) for one frame's items (trails must already be
    entities): one FrameTransforms per topic, one SceneUpdate per topic, one Log per line."""
    entities: dict[str, list[v.Entity]] = {}
    transforms: dict[str, list[v.Transform]] = {}
    logs: list[tuple[str, type[ProtoMessage], bytes]] = []
    for item in items:
        if isinstance(item, v.Entity):
            entities.setdefault(item.topic, []).append(item)
        elif isinstance(item, v.Transform):
            transforms.setdefault(item.topic, []).append(item)
        elif isinstance(item, v.LogLine):
            logs.append((item.topic, Log, log(time_ns, item).SerializeToString()))
        else:
            raise TypeError(f"cannot convert {type(item).__name__} (trails become entities in the deriver)")
    return ([(topic, FrameTransforms, frame_transforms(time_ns, tfs).SerializeToString())
             for topic, tfs in transforms.items()]
            + [(topic, SceneUpdate, scene_update_bytes(time_ns, ents)) for topic, ents in entities.items()]
            + logs)


def item_schema(item: v.Item) -> type[ProtoMessage]:
    """The protobuf message class that carries ``item`` on its topic (what :func:`to_wire` makes of
    it): transforms go in FrameTransforms, entities and trails in SceneUpdate, log lines in Log."""
    if isinstance(item, v.Transform):
        return FrameTransforms
    if isinstance(item, (v.Entity, v.Trail)):
        return SceneUpdate
    if isinstance(item, v.LogLine):
        return Log
    raise TypeError(f"not a visual item: {type(item).__name__}")


def to_protobuf(time_ns: int, items: Sequence[v.Item]) -> list[tuple[str, ProtoMessage]]:
    """(topic, protobuf message) pairs for one frame's items: :func:`to_wire`, parsed."""
    return [(topic, cls.FromString(data)) for topic, cls, data in to_wire(time_ns, items)]


class FoxgloveEncoder:
    """Encoder for :class:`cosim.view.items.VisualDeriver`: items -> recorder :class:`DerivedMessage`s."""

    def encode(self, time_ns: int, items: list[v.Item]) -> list[DerivedMessage]:
        return [DerivedMessage(topic, cls.DESCRIPTOR.full_name, SCHEMA_ENCODING, schema_data(cls),
                               MESSAGE_ENCODING, data)
                for topic, cls, data in to_wire(time_ns, items)]


def warm_up() -> None:
    """Load every installed visuals function and encode one frame of every kind of item, so that a
    process about to derive viewer channels (a recording's writer, :func:`cosim.record.derive.preload`)
    pays its first-use costs (the looks' modules, the schemas, the protobuf classes) ahead of the
    run's first frames, not at a short run's end."""
    for ep in installed_visuals().values():
        try:
            ep.load()
        except Exception:  # a broken plugin is said when its port is first derived
            pass
    for cls in (SceneUpdate, FrameTransforms, Log):
        schema_data(cls)
    white = (1.0, 1.0, 1.0, 1.0)
    surface = v.height_field_mesh(np.zeros((2, 2)), 0.0, 0.0, 1.0, colors=lambda z: np.ones((z.size, 4)))
    items: list[v.Item] = [
        v.Transform(v.WORLD, "warm", (0.0, 0.0, 0.0), v.IDENTITY),
        v.Entity("/warm", "body", "warm", (v.Cylinder((1.0, 1.0, 1.0), white), v.Cube((1.0, 1.0, 1.0), white),
                                           v.Sphere((1.0, 1.0, 1.0), white))),
        v.Entity("/warm", "lines", v.WORLD, (v.LineStrip(np.zeros((2, 3)), white, 0.1),
                                             v.Arrow((0.0, 0.0, 0.0), (1.0, 0.0, 0.0), white), surface)),
        v.LogLine(v.LOG_TOPIC, "info", "warm", "warm"),
    ]
    FoxgloveEncoder().encode(0, items)


def visual_deriver(rate: float, reserved_topics: frozenset[str] = frozenset()) -> v.VisualDeriver:
    """A deriver writing Foxglove viewer channels at ``rate`` frames per second."""
    return v.VisualDeriver(rate, FoxgloveEncoder(), reserved_topics=reserved_topics)
