"""A recording's physics as numpy arrays, for figures and animations.

Channels are found by their schema (``cosim.BodyState``, ``cosim.Stage``, ...), not by name, so any
scene's recording works. Times are seconds of simulation time. Water fields are large: they are
streamed (:func:`iter_fields`), never all held at once.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from components.messages import (
    BodyState,
    GroundContact,
    HeightPatch,
    SkipRecord,
    Stage,
    StageId,
    WaterContact,
    WaterField,
    Wrench,
)
from components.rigid.quaternion import body_axis
from components.stages import STAGE_NAMES
from cosim.codec.json_codec import codec_for
from cosim.errors import RecordingError
from cosim.messages import Message
from cosim.record.reader import Recording
from cosim.record.recorder import component_of
from cosim.timebase import NS_PER_S

DEFAULT_GRAVITY = 9.81  # [m/s^2] the RigidBody's and the StageMonitor's default: where a scene tells none


def _schema(message_type: type[Message]) -> str:
    return codec_for(message_type).schema_name


def topics_of(rec: Recording, message_type: type[Message]) -> list[str]:
    """Channels of a recording carrying ``message_type``, sorted by name."""
    name = _schema(message_type)
    return sorted(t for t, ch in rec.channels.items() if ch.schema_name == name and ch.count)


def _decoded(rec: Recording, topic: str, message_type: type[Message]) -> tuple[np.ndarray, list]:
    pairs = rec.messages(topic, message_type)
    return np.array([t for t, _ in pairs], dtype=np.int64) / NS_PER_S, [m for _, m in pairs]


def stage_changes(rec: Recording, topic: str) -> list[tuple[int, Stage]]:
    """The stage monitor's changes on ``topic``: [(time [ns], Stage)]. A restart's recording begins
    with the stage its monitor was in at the checkpoint it restarted from (restored, so not published
    again), at that checkpoint's time: without it the states before the next change would take that
    change's stage."""
    pairs = rec.messages(topic, Stage)
    if rec.restart_ns and not (pairs and pairs[0][0] <= rec.restart_ns):
        restored = _restored_stage(rec, component_of(topic))
        if restored is not None:
            pairs.insert(0, (rec.restart_ns, restored))
    return pairs


def stage_times(pairs: list[tuple[int, Stage]]) -> np.ndarray:
    """When each stage of :func:`stage_changes`' (time [ns], Stage) pairs began [s]: its message's
    ``since`` (rest: the start of its slow spell, published 0.2 s on; the first stage: 0), not when it
    was known and published; a recording made before the monitor said so, the message's time. Never
    before the change listed ahead of it (a restart's restored stage, dated at the checkpoint, came
    after a rest whose spell began before the checkpoint: the times ran backwards)."""
    times = np.array([m.since if math.isfinite(m.since) else stamp / NS_PER_S for stamp, m in pairs], dtype=float)
    return np.maximum.accumulate(times) if len(times) else times


def _restored_monitor(rec: Recording, monitor: str) -> dict:
    """The stage monitor's state in the checkpoint a restart began at ({} when it is not there, or the
    recording is no restart)."""
    checkpoint = rec.checkpoint_at(rec.restart_ns) if rec.restart_ns else None
    state = ((checkpoint or {}).get("components", {}).get(monitor) or {}).get("state")
    return state if isinstance(state, dict) else {}


def _restored_touchdown(rec: Recording, monitor: str) -> float | None:
    """When the contact a restart began in had touched down [s], from its stage monitor's restored
    state; None when it began in none (or is no restart)."""
    track = _restored_monitor(rec, monitor).get("track") or {}
    touchdown = track.get("touchdown_time")
    return float(touchdown) if track.get("in_contact") and isinstance(touchdown, (int, float)) else None


def _restored_stage(rec: Recording, monitor: str) -> Stage | None:
    """The stage monitor's stage in the checkpoint a restart began at, or None (not there, or not
    one yet)."""
    state = _restored_monitor(rec, monitor)
    if state.get("stage") is None:
        return None
    stage = StageId(int(state["stage"]))
    return Stage(stage, STAGE_NAMES[stage], int(state.get("track", {}).get("skips", 0)),
                 float(state.get("final_x", np.nan)), float(state.get("final_y", np.nan)))


def _stack(msgs: list, name: str, width: int | None = None) -> np.ndarray:
    if not msgs:
        return np.zeros((0, width)) if width else np.zeros(0)
    return np.array([np.asarray(getattr(m, name), dtype=float) for m in msgs], dtype=float)


def attack_along_motion(orientation: np.ndarray, velocity: np.ndarray, tilt_deg: np.ndarray) -> np.ndarray:
    """The attack angle [deg] of each state: the face's angle to the horizontal in the vertical plane
    of the horizontal motion, nose up positive, nose down negative (Clanet et al.'s alpha), from the
    orientations (n, 4) (w, x, y, z) and velocities (n, 3). The recorded ``attack_angle_deg``
    (``tilt_deg``, (n,)) is the face's unsigned tilt from the horizontal, whichever way it leans:
    the same for a stone whose lean stays along its path, not once its lean turns (a free, spinning
    stone). Where the body moves straight up or down (no horizontal motion to measure along), and
    for a sphere (a tilt of 0), the tilt is kept."""
    axis = np.stack(body_axis(orientation.T), axis=1)  # (each of w, x, y, z a column of states)
    axis *= np.where(axis[:, 2] < 0.0, -1.0, 1.0)[:, None]  # a disk's two faces are alike: the one facing up
    horizontal = np.hypot(velocity[:, 0], velocity[:, 1])
    moving = horizontal > 1e-9
    along = np.where(moving, (axis[:, 0] * velocity[:, 0] + axis[:, 1] * velocity[:, 1])
                     / np.where(moving, horizontal, 1.0), 0.0)
    signed = np.degrees(np.arctan2(-along, axis[:, 2]))
    return np.where(moving & (tilt_deg != 0.0), signed, tilt_deg)


@dataclass
class BodyTrack:
    """One body's recorded states: times t (n,) [s], position/velocity (n, 3), orientation (n, 4)
    (w, x, y, z), speed, attack angle along the motion [deg] (:func:`attack_along_motion`), kinetic
    and potential energy [J], and its geometry."""

    topic: str
    t: np.ndarray
    position: np.ndarray
    velocity: np.ndarray
    orientation: np.ndarray
    speed: np.ndarray
    attack_deg: np.ndarray
    kinetic: np.ndarray
    potential: np.ndarray
    shape: int
    radius: float
    thickness: float
    mass: float
    attitude_locked: bool = False  # the attitude was held (lock_attitude or a script) throughout

    @property
    def name(self) -> str:
        return component_of(self.topic)

    def index_at(self, t: float) -> int:
        """Index of the last state at or before ``t`` (the first one before the start)."""
        return max(0, int(np.searchsorted(self.t, t, side="right")) - 1)


@dataclass
class StageTrack:
    """Stage changes: times t (m,) [s], stage ids, labels, skip counts."""

    topic: str
    t: np.ndarray
    stage: np.ndarray
    label: list[str]
    skips: np.ndarray

    def at(self, times: np.ndarray) -> np.ndarray:
        """Stage id in force at each time (-1 before the first change)."""
        idx = np.searchsorted(self.t, np.asarray(times, dtype=float), side="right") - 1
        out = np.full(idx.shape, -1, dtype=int)
        known = idx >= 0
        out[known] = self.stage[idx[known]]
        return out

    def spans(self, end: float) -> list[tuple[float, float, int]]:
        """(start, end, stage) of each stage in turn, the last one lasting to ``end``."""
        bounds = [*self.t.tolist(), max(end, float(self.t[-1]) if len(self.t) else end)]
        return [(bounds[i], bounds[i + 1], int(self.stage[i])) for i in range(len(self.t))]


@dataclass
class ContactTrack:
    """A coupler's WaterContact reports: wetted, submerged fraction, forces (n, 3) [N] per effect,
    depth [m], cumulative dissipated energy [J]."""

    topic: str
    t: np.ndarray
    wetted: np.ndarray
    submerged: np.ndarray
    buoyancy: np.ndarray
    pressure: np.ndarray
    friction: np.ndarray
    wave_drag: np.ndarray
    depth: np.ndarray
    dissipated: np.ndarray


@dataclass
class GroundTrack:
    """A ground's GroundContact reports: in_contact, normal and friction force [N], cumulative
    dissipated energy [J]."""

    topic: str
    t: np.ndarray
    in_contact: np.ndarray
    normal: np.ndarray
    friction: np.ndarray
    dissipated: np.ndarray


@dataclass
class WrenchTrack:
    """A wrench channel: force and torque (n, 3) [N], [N m], world frame."""

    topic: str
    t: np.ndarray
    force: np.ndarray
    torque: np.ndarray


@dataclass
class RunData:
    """Everything the figures need from one recording."""

    path: Path
    scene: str
    body: BodyTrack
    stages: StageTrack | None
    contacts: list[ContactTrack] = field(default_factory=list)
    grounds: list[GroundTrack] = field(default_factory=list)
    wrenches: list[WrenchTrack] = field(default_factory=list)
    skips: list[SkipRecord] = field(default_factory=list)
    field_topics: list[str] = field(default_factory=list)
    rest_level: float = 0.0  # [m] undisturbed level of the water the body meets
    end: float = 0.0
    step: float = 0.0  # the body's step [s] (the scene's dt times its every; 0 when not known)
    cut_off: bool = False  # the recording has no final status: its run was cut off (killed) at ``end``
    # a restart that began in a contact: when that contact's touchdown was [s] (before the recording)
    touchdown_before: float | None = None
    # what the energy budget's total leaves out, in words (a contact's dissipation not recorded, a
    # script's work), for the energy figure to say
    unbooked: list[str] = field(default_factory=list)
    restart: float | None = None  # [s] when a restart's run began (None: not a restart)
    gravity: float = DEFAULT_GRAVITY  # [m/s^2] the size of the body's gravity (:func:`body_gravity`)


def warn_ended_early(rec: Recording, drawn: str) -> None:
    """Warn that the run of ``rec`` ended before its scene's end, and that what is made of it
    (``drawn``: "the figures", "the frames") ends there: cut off (no final status: the recording is
    incomplete), interrupted or failed (figures of an interrupted run carried no mark of it). The
    warning names the caller of the command's function that calls this."""
    status = rec.status()
    if status is None:
        why = f"the recording is incomplete: its run was cut off (killed?) at t = {(rec.end_ns or 0) / NS_PER_S:g} s"
    elif status.status in ("interrupted", "failed"):
        how = "was interrupted" if status.status == "interrupted" else "failed"
        why = f"its run {how} at t = {status.time:g} s ({status.reason})"
    else:
        return
    warnings.warn(f"{rec.path}: {why}, and {drawn} end there", UserWarning, stacklevel=3)


def scene_publishes(rec: Recording, kinds: tuple[type, ...], unknown: bool = True) -> bool:
    """Whether the recorded scene has a component with an output of one of the message types
    ``kinds``; ``unknown`` when its scene cannot be read."""
    try:
        configs = rec.scene().components.values()
    except Exception:
        return unknown
    return any(port.type in kinds for cfg in configs for port in cfg.cls.outputs.values())


def default_body_topic(rec: Recording, topics: list[str]) -> str:
    """Of several bodies' channels, the one to show by default: the first body, in the scene's
    order, that a stage monitor watches (the thrown stone, not a ball floating beside it), else the
    scene's first body; the first by name when the scene cannot be read."""
    if len(topics) < 2:
        return topics[0]
    try:
        scene = rec.scene()
    except Exception:  # an old or damaged scene: the first by name
        return topics[0]
    watched = {c.source for c in scene.connections if c.target in {component_of(t) for t in topics_of(rec, Stage)}}
    by_order = sorted(topics, key=lambda t: (scene.order.index(component_of(t)) if component_of(t) in scene.order
                                             else len(scene.order), t))
    return next((t for t in by_order if component_of(t) in watched), by_order[0])


def load_body(rec: Recording, body: str | None = None) -> BodyTrack:
    """The states of body ``body`` (a component name; default: :func:`default_body_topic`'s)."""
    topics = topics_of(rec, BodyState)
    if not topics:
        raise RecordingError(f"{rec.path}: no BodyState channel, nothing to show "
                             f"(channels: {', '.join(sorted(rec.channels))})")
    if body is not None:
        wanted = [t for t in topics if component_of(t) == body]
        if not wanted:
            names = ", ".join(component_of(t) for t in topics)
            raise RecordingError(f"{rec.path}: no body named {body!r} (bodies: {names})")
        topics = wanted
    topic = default_body_topic(rec, topics)
    t, msgs = _decoded(rec, topic, BodyState)
    first = msgs[0]
    return BodyTrack(
        topic=topic, t=t, position=_stack(msgs, "position", 3), velocity=_stack(msgs, "velocity", 3),
        orientation=_stack(msgs, "orientation", 4), speed=_stack(msgs, "speed"),
        attack_deg=attack_along_motion(_stack(msgs, "orientation", 4), _stack(msgs, "velocity", 3),
                                       _stack(msgs, "attack_angle_deg")),
        kinetic=_stack(msgs, "kinetic_energy"),
        potential=_stack(msgs, "potential_energy"), shape=int(first.shape), radius=float(first.radius),
        thickness=float(first.thickness), mass=float(first.mass),
        attitude_locked=all(bool(m.attitude_locked) for m in msgs))


def linked_components(rec: Recording, body: str) -> set[str] | None:
    """The components an edge joins to component ``body`` (its monitor and coupler read its state,
    its coupler writes its wrench), from the recorded scene; None when the recording holds one body
    only (then every channel is its) or its scene cannot be read."""
    if len(topics_of(rec, BodyState)) < 2:
        return None
    try:
        connections = rec.scene().connections
    except Exception:  # an old or damaged scene: show every channel, as for a single body
        return None
    return ({c.target for c in connections if c.source == body}
            | {c.source for c in connections if c.target == body})


def body_water_topic(rec: Recording, body: str, fields: list[str]) -> str | None:
    """The WaterField channel of the water that body ``body`` meets (the water feeding the coupler
    its state feeds), else the first of ``fields``; None without any."""
    if len(fields) < 2:
        return fields[0] if fields else None
    try:
        connections = rec.scene().connections
    except Exception:
        return fields[0]
    readers = {c.target for c in connections if c.source == body}
    waters = {c.source for c in connections if c.target in readers}
    return next((f for f in fields if component_of(f) in waters), fields[0])


def own(topics: list[str], linked: set[str] | None) -> list[str]:
    """The channels ``/component/port`` of the linked components (all when ``linked`` is None)."""
    return topics if linked is None else [t for t in topics if component_of(t) in linked]


def load_run(recording: str | Path | Recording, body: str | None = None) -> RunData:
    """Read what the figures need from a recording, a file or one already opened (RecordingError if it
    holds no body): the body's states and, with several bodies, only the monitor, contact and wrench
    channels linked to it."""
    rec = recording if isinstance(recording, Recording) else Recording(recording)
    path = rec.path
    track = load_body(rec, body)
    linked = linked_components(rec, component_of(track.topic))
    stages = None
    touchdown_before = None
    stage_topics = own(topics_of(rec, Stage), linked)
    if stage_topics:
        touchdown_before = _restored_touchdown(rec, component_of(stage_topics[0]))
        pairs = stage_changes(rec, stage_topics[0])
        msgs = [m for _, m in pairs]
        stages = StageTrack(stage_topics[0], stage_times(pairs), np.array([int(m.stage) for m in msgs], dtype=int),
                            [m.label for m in msgs], np.array([m.skips for m in msgs], dtype=int))
    contacts = []
    for topic in own(topics_of(rec, WaterContact), linked):
        t, msgs = _decoded(rec, topic, WaterContact)
        contacts.append(ContactTrack(
            topic, t, np.array([m.wetted for m in msgs], dtype=bool), _stack(msgs, "submerged_fraction"),
            _stack(msgs, "buoyancy", 3), _stack(msgs, "pressure", 3), _stack(msgs, "friction", 3),
            _stack(msgs, "wave_drag", 3), _stack(msgs, "depth"), _stack(msgs, "dissipated_energy")))
    grounds = []
    for topic in own(topics_of(rec, GroundContact), linked):
        t, msgs = _decoded(rec, topic, GroundContact)
        grounds.append(GroundTrack(topic, t, np.array([m.in_contact for m in msgs], dtype=bool),
                                   _stack(msgs, "normal_force"), _stack(msgs, "friction_force"),
                                   _stack(msgs, "dissipated_energy")))
    wrenches = []
    for topic in own(topics_of(rec, Wrench), linked):
        t, msgs = _decoded(rec, topic, Wrench)
        wrenches.append(WrenchTrack(topic, t, _stack(msgs, "force", 3), _stack(msgs, "torque", 3)))
    skips: list[SkipRecord] = []
    for topic in own(topics_of(rec, SkipRecord), linked):
        skips += [m for _, m in rec.messages(topic, SkipRecord)]
    end = (rec.end_ns or 0) / NS_PER_S
    return RunData(Path(path), rec.metadata.get("scene", Path(path).stem), track, stages, contacts, grounds,
                   wrenches, skips, topics_of(rec, WaterField), rest_level(rec, track.name),
                   max(end, float(track.t[-1])), body_step(rec, track.name), rec.status() is None, touchdown_before,
                   unbooked(rec, track.name), rec.restart_ns / NS_PER_S if rec.restart_ns else None,
                   body_gravity(rec, track.name))


def unbooked(rec: Recording, body: str) -> list[str]:
    """What the energy budget of ``body`` cannot count, from the recorded scene: the dissipation of a
    component reporting contacts with it (a water coupler, a ground) whose reports were not recorded
    (a --record that left them out) and whose wrench on the body was not recorded either, and the
    work of a script moving it (scripted_tilt_deg, scripted_velocity), which nothing books. Empty
    when the scene cannot be read."""
    try:
        scene = rec.scene()
    except Exception:  # an old or damaged scene: nothing known to be missing
        return []
    out = []
    readers = {c.target for c in scene.connections if c.source == body}
    for name in sorted(readers):
        cfg = scene.components.get(name)
        ports = [] if cfg is None else [p for p, spec in cfg.cls.outputs.items()
                                       if spec.type in (WaterContact, GroundContact)]
        # without its reports, the energy figure books the work of its recorded wrench on the body
        # instead (plot.energy_terms), which is what it dissipated: the title said it left that out
        missing = any(f"/{name}/{port}" not in rec.channels for port in ports)
        if missing and not _wrench_recorded(rec, scene, name, body):
            out.append(f"{name}'s dissipation (not recorded)")
    params = getattr(scene.components.get(body), "params", None)
    if getattr(params, "scripted_tilt_deg", None) or getattr(params, "scripted_velocity", None):
        out.append("the work of its script")
    return out


def _wrench_recorded(rec: Recording, scene, name: str, body: str) -> bool:
    """Whether component ``name`` of the recorded ``scene`` feeds ``body`` a Wrench whose messages
    were recorded (as :func:`topics_of` finds them)."""
    cfg = scene.components.get(name)
    if cfg is None:
        return False
    for c in scene.connections:
        port = cfg.cls.outputs.get(c.source_port) if c.source == name and c.target == body else None
        channel = rec.channels.get(f"/{name}/{c.source_port}")
        if port is not None and port.type is Wrench and channel is not None and channel.count:
            return True
    return False


def body_gravity(rec: Recording, body: str) -> float:
    """The size [m/s^2] of the gravity component ``body`` falls under, from the recorded scene: its own
    ``gravity`` (a RigidBody's vector), else that of a stage monitor watching it (a scripted body
    tells none; the monitor's must be its body's, checked at the start), else
    :data:`DEFAULT_GRAVITY` (a scene that cannot be read, or that tells none). The unit of a
    contact's peak and of the bounce level in contacts.png (a run on Mars was drawn against 9.81)."""
    try:
        scene = rec.scene()
    except Exception:  # an old or damaged scene: the default both components have
        return DEFAULT_GRAVITY
    own_gravity = _gravity_of(scene.components.get(body))
    if own_gravity is not None:
        return own_gravity
    monitors = [scene.components.get(c.target) for c in scene.connections if c.source == body]
    told = [g for g in (_gravity_of(cfg) for cfg in monitors
                        if cfg is not None and any(port.type is Stage for port in cfg.cls.outputs.values()))
            if g is not None]
    return told[0] if told else DEFAULT_GRAVITY


def _gravity_of(cfg) -> float | None:
    """The size [m/s^2] of a component config's ``gravity`` parameter (a vector or a magnitude), None
    without one."""
    gravity = getattr(getattr(cfg, "params", None), "gravity", None)
    if isinstance(gravity, (int, float)):
        return abs(float(gravity))
    if isinstance(gravity, (tuple, list)) and len(gravity) == 3:
        return float(np.linalg.norm(np.asarray(gravity, dtype=float)))
    return None


def body_step(rec: Recording, body: str) -> float:
    """The step [s] of component ``body`` in the recorded scene: its dt times its every (0 when the
    scene cannot be read)."""
    try:
        scene = rec.scene()
        return scene.dt_ns * scene.components[body].every / NS_PER_S
    except Exception:
        return 0.0


def rest_level(rec: Recording, body: str | None = None) -> float:
    """The undisturbed level [m] of the water body ``body`` meets: the ``rest_level`` of its water's
    patches (the water feeding the coupler that body's state feeds, as :func:`body_water_topic`
    finds it), else of the first water's by name (also without ``body``); without any patch (a
    --record that left them out), what the recorded scene gives that water (:func:`scene_rest_level`)."""
    patches = topics_of(rec, HeightPatch)
    if not patches:
        return scene_rest_level(rec, body=body)
    return _first_rest_level(rec, patches[0] if body is None else body_water_topic(rec, body, patches) or patches[0])


def water_rest_level(rec: Recording, water_topic: str) -> float:
    """The undisturbed level [m] of the water publishing ``water_topic`` (a WaterField channel,
    ``/<water>/field``): the ``rest_level`` of that water's own patches, else the recorded scene's
    (:func:`scene_rest_level`)."""
    water = component_of(water_topic)
    own_patches = [t for t in topics_of(rec, HeightPatch) if component_of(t) == water]
    return _first_rest_level(rec, own_patches[0]) if own_patches else scene_rest_level(rec, water=water)


def scene_rest_level(rec: Recording, water: str | None = None, body: str | None = None) -> float:
    """The ``rest_level`` [m] the recorded scene gives the water component ``water``, or the water
    whose patches reach the coupler ``body``'s state feeds, else the first water in the scene; 0
    when the scene tells none (no water, or a scene that cannot be read). (Without its patches
    recorded the level was taken as 0: a pond resting at 0.5 m was drawn and plotted half a metre low.)"""
    try:
        scene = rec.scene()
    except Exception:  # an old or damaged recording: the level it cannot tell
        return 0.0
    levels = {name: float(cfg.params.rest_level) for name, cfg in scene.components.items()
              if any(port.type is HeightPatch for port in cfg.cls.outputs.values())
              and isinstance(getattr(cfg.params, "rest_level", None), (int, float))}
    if water is None and body is not None:
        couplers = {c.target for c in scene.connections if c.source == body and c.source_port == "state"}
        fed = [c.source for c in scene.connections if c.target in couplers and c.source in levels]
        water = fed[0] if fed else None
    if water in levels:
        return levels[water]
    return next(iter(levels.values()), 0.0)


def ground_planes(rec: Recording, body: str) -> list[tuple[tuple[float, float, float], tuple[float, float, float]]]:
    """(normal, point) of every solid ground plane (a component answering a body with a
    GroundContact) the recorded scene feeds ``body``'s state to; none when the scene cannot be read."""
    from components.contact.geometry import slope_plane

    try:
        scene = rec.scene()
    except Exception:  # an old or damaged recording: no ground it can tell
        return []
    planes = []
    for c in scene.connections:
        cfg = scene.components.get(c.target)
        if c.source != body or c.source_port != "state" or cfg is None:
            continue
        if not any(port.type is GroundContact for port in cfg.cls.outputs.values()):
            continue
        p = cfg.params
        plane = slope_plane(tuple(float(v) for v in p.point), float(p.slope_deg), float(p.downhill_deg))
        planes.append((plane.normal, plane.point))
    return planes


def _first_rest_level(rec: Recording, topic: str) -> float:
    """The ``rest_level`` [m] of the first HeightPatch on ``topic`` (a water's level never changes)."""
    # (decoded through the reader, whose errors name the channel and time: a payload cut short was an
    # internal ProtoError when decoded here)
    for _, patch in rec.iter_messages(topic, HeightPatch):
        return float(patch.rest_level)  # type: ignore[attr-defined]
    return 0.0


def iter_fields(rec: Recording, topic: str) -> Iterator[tuple[float, WaterField]]:
    """(time [s], WaterField) of one channel in time order, decoded one at a time."""
    for stamp, msg in rec.iter_messages(topic, WaterField):  # (a damaged payload: the reader's one line)
        yield stamp / NS_PER_S, msg  # type: ignore[misc]


def contact_spans(flags: np.ndarray, t: np.ndarray) -> list[tuple[int, int]]:
    """(first, last) indices of each run of true ``flags`` (times ``t`` only give the length)."""
    spans = []
    start = None
    for i, f in enumerate(np.asarray(flags, dtype=bool)):
        if f and start is None:
            start = i
        elif not f and start is not None:
            spans.append((start, i - 1))
            start = None
    if start is not None:
        spans.append((start, len(t) - 1))
    return spans
