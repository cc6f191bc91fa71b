"""Viewer items and the visual deriver: what the exchanged messages look like, at a frame rate.

Visual items are plain data, free of any viewer library: a :class:`Transform` between two frames, an
:class:`Entity` made of primitives (:class:`Sphere`, :class:`Cylinder`, :class:`Cube`,
:class:`Arrow`, :class:`LineStrip`, :class:`TriangleList`), a :class:`LogLine`, and a :class:`Trail`
(one point per frame, which the deriver accumulates into a line strip). :mod:`cosim.view.foxglove` turns
them into Foxglove messages; other viewers could take the same items.

Who says what a message looks like. The deriver asks, once per (component, port):

1. the producing component, when its class overrides :meth:`cosim.component.Component.visuals`;
2. otherwise the *visuals registry*, by message type: a function ``visuals(component, port, msg)``
   registered with :func:`register` or through the ``cosim.visuals`` entry points, whose names are
   the message type's full name (``"components.messages.BodyState" = "components.visuals:body_state"``).

The registry is consulted by the deriver, not by ``Component.visuals``'s default (which simply
returns nothing). That keeps the component contract free of viewer machinery, lets a physics package
describe its messages' looks in one module without touching (or even importing) its component
classes, and works from message types alone, so the same functions serve a recording read back or a
live view where no component instance exists. A component that wants a special look overrides
``visuals`` and wins.

Off the physics path. The deriver is an observer's helper: it only reads messages, is called after
they are published, and its output goes to viewer channels only. Visuals are produced at
``rate`` frames per second of *simulation* time: per (component, port), the first message at or after
each frame time ``k / rate``; the per-exchange cost otherwise is one dict lookup and one integer
compare. A function marked :func:`every_message` (stage changes, skip records) sees every message.
An entity identical to the one last sent on its topic and id is not sent again (a static body, a
still water surface) except every :data:`KEEPALIVE_NS`, so a viewer joining late still gets it.
A visuals function that fails is switched off for that port with a warning and an error log line;
the run goes on.
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from fractions import Fraction
from functools import cache, lru_cache
from typing import Any, Protocol

import numpy as np

from cosim.messages import FieldKind, Message
from cosim.timebase import NS_PER_S
from cosim.view.lookup import draws_itself, installed_visuals, type_key

WORLD = "world"  # the fixed frame every viewer item is ultimately placed in
TF_TOPIC = "/tf"
LOG_TOPIC = "/log"
KEEPALIVE_NS = NS_PER_S  # an unchanged entity is re-sent this often [ns] (late-joining live viewers)
TRAIL_TIP_POINTS = 30  # a trail's points sent each frame before they settle into its history (a second at 30/s)
TRAIL_STEP = 1e-3  # [m] a trail's point closer than this to the last one (along every axis) is left out
MAX_SIDE = 64  # default vertices per side of a decimated height-field surface

RGBA = tuple[float, float, float, float]
Vector = Sequence[float] | np.ndarray
IDENTITY = (1.0, 0.0, 0.0, 0.0)  # quaternion (w, x, y, z)


# --- primitives ---------------------------------------------------------------------------------

@dataclass(frozen=True, eq=False)
class Pose:
    """Placement inside an entity's frame: position [m], unit quaternion (w, x, y, z)."""

    position: Vector = (0.0, 0.0, 0.0)
    orientation: Vector = IDENTITY


ORIGIN = Pose()


@dataclass(frozen=True, eq=False)
class Sphere:
    """An ellipsoid with diameters ``size`` = (x, y, z) [m], centred at the pose."""

    size: Vector
    color: RGBA
    pose: Pose = ORIGIN


@dataclass(frozen=True, eq=False)
class Cylinder:
    """A cylinder along the pose's z axis: ``size`` = (diameter x, diameter y, height) [m], centred at
    the pose; ``top_scale``/``bottom_scale`` shrink the faces (a cone has top_scale 0)."""

    size: Vector
    color: RGBA
    pose: Pose = ORIGIN
    bottom_scale: float = 1.0
    top_scale: float = 1.0


@dataclass(frozen=True, eq=False)
class Cube:
    """A box with edge lengths ``size`` = (x, y, z) [m], centred at the pose."""

    size: Vector
    color: RGBA
    pose: Pose = ORIGIN


@dataclass(frozen=True, eq=False)
class Arrow:
    """An arrow from ``start`` along ``vector`` (its length is the arrow's length) [m]; head length
    defaults to a quarter of the length. A zero vector draws nothing."""

    start: Vector
    vector: Vector
    color: RGBA
    shaft_diameter: float = 0.01
    head_diameter: float = 0.025
    head_length: float | None = None


@dataclass(frozen=True, eq=False)
class LineStrip:
    """Connected line segments through ``points`` (N, 3) [m]; ``thickness`` [m]; one ``color`` or
    per-point ``colors`` (N, 4)."""

    points: np.ndarray
    color: RGBA
    thickness: float = 0.005
    colors: np.ndarray | None = None


@dataclass(frozen=True, eq=False)
class TriangleList:
    """Triangles over ``points`` (N, 3) [m]: vertex triples ``indices`` (M,) (or consecutive triples
    of points when None); one ``color`` or per-vertex ``colors`` (N, 4)."""

    points: np.ndarray
    color: RGBA = (0.5, 0.5, 0.5, 1.0)
    colors: np.ndarray | None = None
    indices: np.ndarray | None = None


Primitive = Sphere | Cylinder | Cube | Arrow | LineStrip | TriangleList


# --- items --------------------------------------------------------------------------------------

@dataclass(frozen=True, eq=False)
class Transform:
    """The pose of frame ``child`` in frame ``parent``: position [m], quaternion (w, x, y, z)."""

    parent: str
    child: str
    position: Vector
    orientation: Vector
    topic: str = TF_TOPIC


@dataclass(frozen=True, eq=False)
class Entity:
    """A named group of primitives in one frame, on a viewer topic; a later entity with the same topic
    and id replaces it. ``frame_locked``: it moves with its frame as new transforms arrive."""

    topic: str
    id: str
    frame_id: str
    primitives: tuple[Primitive, ...] | list[Primitive]
    frame_locked: bool = False


@dataclass(frozen=True, eq=False)
class LogLine:
    """A log line: ``level`` one of debug, info, warning, error, fatal; ``name`` says who logs."""

    topic: str
    level: str
    name: str
    text: str


LOG_LEVELS = ("debug", "info", "warning", "error", "fatal")


@dataclass(frozen=True, eq=False)
class Trail:
    """One more point [m] of a path; the deriver turns the points so far into the line strip of an
    :class:`Entity` (topic, id, frame_id), keeping the latest ``max_points``."""

    topic: str
    id: str
    frame_id: str
    point: Vector
    color: RGBA
    thickness: float = 0.005
    max_points: int = 10_000


Item = Transform | Entity | LogLine | Trail
VisualsFunction = Callable[[str, str, Any], Iterable[Item]]


# --- helpers for visuals functions --------------------------------------------------------------

def decimation(n: int, max_n: int) -> np.ndarray:
    """At most ``max_n`` indices spread evenly over range(n), first and last included."""
    if max_n < 2:
        raise ValueError(f"max_n must be >= 2 (got {max_n})")
    if n <= max_n:
        return np.arange(n)
    picked = np.round(np.linspace(0, n - 1, max_n)).astype(np.int64)  # sorted: only neighbours repeat
    # the same as np.unique(picked), without the import of numpy.ma that np.unique makes (7 ms)
    return picked[np.concatenate(([True], picked[1:] != picked[:-1]))]


def color_ramp(values: np.ndarray, stops: Sequence[tuple[float, RGBA]]) -> np.ndarray:
    """Colours (N, 4) of ``values`` by piecewise-linear interpolation between ``(value, rgba)`` stops
    (sorted by value; values beyond the ends take the end colours)."""
    xs = np.array([s[0] for s in stops], dtype=float)
    rgba = np.array([s[1] for s in stops], dtype=float)
    v = np.asarray(values, dtype=float).ravel()
    return np.stack([np.interp(v, xs, rgba[:, c]) for c in range(4)], axis=1)


def height_field_mesh(height: np.ndarray, origin_x: float, origin_y: float, cell: float, *,
                      max_side: int = MAX_SIDE,
                      colors: Callable[[np.ndarray], np.ndarray] | None = None,
                      color: RGBA = (0.2, 0.45, 0.8, 1.0)) -> TriangleList:
    """A height field ``height[j, i]`` (cell (i, j) centred at origin + (i, j) * cell) as a triangle
    list over at most ``max_side`` x ``max_side`` vertices.

    Decimation samples rows and columns (first and last kept), so every vertex sits at a cell centre
    with that cell's exact height; two triangles per grid quad, indexed. ``colors`` maps the
    vertices' heights (N,) to colours (N, 4).
    """
    height = np.asarray(height)
    if height.ndim != 2 or min(height.shape) < 2:
        raise ValueError(f"height field must be 2D with at least 2 x 2 cells (got shape {height.shape})")
    rows, cols, xy, indices = _mesh_grid(height.shape, max_side, float(origin_x), float(origin_y), float(cell))
    z = height[np.ix_(rows, cols)].astype(np.float64).ravel()
    points = np.empty((len(z), 3))
    points[:, :2] = xy
    points[:, 2] = z
    return TriangleList(points, color=color, colors=None if colors is None else colors(z), indices=indices)


@lru_cache(maxsize=8)
def _mesh_grid(shape: tuple[int, int], max_side: int, origin_x: float, origin_y: float, cell: float
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """What a height field's mesh keeps from frame to frame: the sampled rows and columns, the
    vertices' (x, y) (N, 2) [m] and the triangles' vertex indices (read-only, shared by every frame)."""
    rows = decimation(shape[0], max_side)
    cols = decimation(shape[1], max_side)
    gx, gy = np.meshgrid(origin_x + cols * cell, origin_y + rows * cell)
    xy = np.column_stack([gx.ravel(), gy.ravel()])
    v = np.arange(len(rows) * len(cols), dtype=np.uint32).reshape(len(rows), len(cols))
    a, b, c, d = v[:-1, :-1], v[:-1, 1:], v[1:, :-1], v[1:, 1:]
    indices = np.stack([a, b, d, a, d, c], axis=-1).ravel()  # counter-clockwise seen from above
    for arr in (rows, cols, xy, indices):
        arr.flags.writeable = False
    return rows, cols, xy, indices


# --- the registry -------------------------------------------------------------------------------

_REGISTERED: dict[type, VisualsFunction] = {}


def register(message_type: type[Message], function: VisualsFunction) -> None:
    """Register the visuals of a message type in this process (entry points do it for packages)."""
    _REGISTERED[message_type] = function


def unregister(message_type: type[Message]) -> None:
    _REGISTERED.pop(message_type, None)


def every_message(function: VisualsFunction) -> VisualsFunction:
    """Mark a visuals function to be called for every message rather than at the frame rate (for
    rare, event-like messages whose every occurrence matters, such as stage changes)."""
    function.every_message = True  # type: ignore[attr-defined]
    return function


def visuals_for(message_type: type) -> VisualsFunction | None:
    """The registered visuals function of a message type, or None (entry points load lazily)."""
    found = _REGISTERED.get(message_type)
    if found is not None:
        return found
    ep = installed_visuals().get(type_key(message_type))
    return None if ep is None else ep.load()


# --- the deriver --------------------------------------------------------------------------------

class Encoder(Protocol):
    """Turns the items of one frame into viewer messages (see :class:`cosim.view.foxglove.FoxgloveEncoder`)."""

    def encode(self, time_ns: int, items: list[Item]) -> list[Any]: ...


class VisualsWarning(UserWarning):
    """A visuals function failed and was switched off (the run itself goes on)."""


@dataclass
class _Slot:
    """Visuals of one (component, port): the function, when its next frame is due [ns], and whether it
    has drawn anything yet."""

    function: VisualsFunction
    every_message: bool
    due_ns: int = 0
    drawn: bool = False


_UNRESOLVED = object()


@dataclass
class _Sent:
    entity: Entity
    time_ns: int


@dataclass
class VisualDeriver:
    """A recorder deriver (and live-view helper) producing viewer messages at ``rate`` frames/s.

    ``encoder`` converts items into messages (None: :meth:`__call__` returns the items themselves);
    ``components`` (name -> Component, or :meth:`bind` later) lets components override their looks;
    ``reserved_topics`` (the physics channels) may not be used by viewer items.
    """

    rate: float
    encoder: Encoder | None = None
    components: dict[str, Any] = field(default_factory=dict)
    reserved_topics: frozenset[str] = frozenset()
    lookup: Callable[[type], VisualsFunction | None] = visuals_for

    def __post_init__(self) -> None:
        if not (self.rate > 0 and math.isfinite(self.rate)):
            raise ValueError(f"visual rate must be a positive number of frames/s (got {self.rate!r})")
        fraction = Fraction(self.rate)
        self._num, self._den = fraction.numerator, fraction.denominator
        self._slots: dict[tuple[str, str], Any] = {}
        # each trail's points so far, (n, 3): its settled history and its tip (TRAIL_TIP_POINTS at most)
        self._trails: dict[tuple[str, str], tuple[np.ndarray, np.ndarray]] = {}
        self._sent: dict[tuple[str, str], _Sent] = {}

    def bind(self, components: dict[str, Any]) -> None:
        """Give the deriver the running components (their ``visuals`` overrides take precedence)."""
        self.components = dict(components)
        self._slots.clear()

    def frame_time_ns(self, k: int) -> int:
        """Time of frame ``k`` [ns]: the first integer nanosecond at or after k / rate."""
        return -(-(k * self._den * NS_PER_S) // self._num)

    def next_frame_ns(self, time_ns: int) -> int:
        """Time of the first frame strictly after ``time_ns``."""
        return self.frame_time_ns(time_ns * self._num // (self._den * NS_PER_S) + 1)

    def watches(self, component: str, port: str, message_type: type) -> bool:
        """Whether messages of this port have any visuals (if not, they need not be shown at all)."""
        slot = self._slots.get((component, port), _UNRESOLVED)
        if slot is _UNRESOLVED:
            slot = self._slots[(component, port)] = self._resolve(component, message_type)
        return slot is not None

    def foreseen(self, component: str, port: str, message_type: type) -> list[Item]:
        """The items this port's looks give for a :func:`stand_in` of its message type: the viewer
        topics it is expected to publish on, known before the run (a live view advertises them then).
        [] when the port has no looks or they fail on the stand-in (its topics are then learnt at
        its first message); the frames due, the trails and the entities sent are left untouched."""
        if not self.watches(component, port, message_type):
            return []
        slot = self._slots[(component, port)]
        try:
            items = list(slot.function(component, port, stand_in(message_type)))
        except Exception:  # the stand-in is no real message: the run's own messages will tell
            return []
        return [item for item in items if isinstance(item, (Transform, Entity, LogLine, Trail))
                and item.topic not in self.reserved_topics]

    def due_ns(self, component: str, port: str) -> int:
        """The time [ns] before which messages of this port give no items (0: every message may)."""
        slot = self._slots.get((component, port))
        return 0 if slot is None or slot is _UNRESOLVED or slot.every_message else slot.due_ns

    draws_final = True  # it takes final=True: the run's last message of a port, drawn whatever the frame

    def __call__(self, time_ns: int, component: str, port: str, msg: Message,
                 final: bool = False) -> list[Any] | tuple:
        """The viewer items of ``msg`` (encoded, with an encoder) when a frame is due for its port,
        or ``final`` (the run's last message of the port: the end is drawn); else ()."""
        slot = self._slots.get((component, port), _UNRESOLVED)
        if slot is _UNRESOLVED:
            slot = self._slots[(component, port)] = self._resolve(component, type(msg))
        if slot is None or (time_ns < slot.due_ns and not final):
            return ()
        if not slot.every_message:
            slot.due_ns = self.next_frame_ns(time_ns)
        items = self._items(slot, time_ns, component, port, msg)
        if not items:
            if not slot.drawn:
                # nothing to draw yet (a ground told of no body before the run's first step): its
                # next message is drawn, not the next frame's (the floor appeared a frame late, 33 ms)
                slot.due_ns = time_ns
            return []
        return items if self.encoder is None else self.encoder.encode(time_ns, items)

    # --- internals -------------------------------------------------------------------------------

    def _resolve(self, component: str, message_type: type) -> _Slot | None:
        comp = self.components.get(component)
        if comp is not None and draws_itself(comp):
            method = type(comp).visuals
            return _Slot(lambda _name, port, msg: comp.visuals(port, msg),
                         bool(getattr(method, "every_message", False)))
        try:
            function = self.lookup(message_type)
        except Exception as exc:  # a broken plugin must not stop the run
            self._warn(f"visuals of {type_key(message_type)} cannot be loaded "
                       f"({type(exc).__name__}: {exc}); no viewer channels for /{component}/*")
            return None
        if function is None:
            return None
        return _Slot(function, bool(getattr(function, "every_message", False)))

    def _items(self, slot: _Slot, time_ns: int, component: str, port: str, msg: Message) -> list[Item]:
        try:
            raw = list(slot.function(component, port, msg))
            for item in raw:
                self._check(item)
            slot.drawn = slot.drawn or bool(raw)
        except Exception as exc:
            self._slots[(component, port)] = None
            text = (f"visuals of /{component}/{port} failed at t = {time_ns / NS_PER_S:g} s and are "
                    f"switched off: {type(exc).__name__}: {exc}")
            self._warn(text)
            return [LogLine(LOG_TOPIC, "error", component, text)]
        out: list[Item] = []
        for item in raw:
            for made in self._trail_entities(item) if isinstance(item, Trail) else (item,):
                if isinstance(made, Entity) and not self._changed(made, time_ns):
                    continue
                out.append(made)
        return out

    def _check(self, item: Any) -> None:
        if not isinstance(item, (Transform, Entity, LogLine, Trail)):
            raise TypeError(f"not a visual item: {type(item).__name__}")
        if item.topic in self.reserved_topics:
            raise ValueError(f"viewer topic {item.topic!r} is a physics channel")
        if isinstance(item, LogLine) and item.level not in LOG_LEVELS:
            raise ValueError(f"log level {item.level!r} is not one of {', '.join(LOG_LEVELS)}")

    def _trail_entities(self, trail: Trail) -> tuple[Entity, Entity]:
        """The trail's two line strips: its history (entity ``trail.id``), which changes only when the
        tip has grown TRAIL_TIP_POINTS long and is moved into it, so it is sent about once a second
        (an unchanged entity is only kept alive), and its tip (``trail.id``-tip), the points since,
        sent each frame. Sent whole every frame, one strip of up to 10,000 points was 2.7 GB of a
        700 s run's 2.8. Each message holds its strip whole (not the points since the last), so a
        viewer seeking back draws the path from the latest of each. A point within TRAIL_STEP of the
        last adds nothing: a body at rest sends no new trail."""
        point = np.array(trail.point, dtype=np.float64).reshape(1, -1)
        key = (trail.topic, trail.id)
        history, tip = self._trails.get(key, (None, None))
        if history is None or tip is None or tip.shape[1] != point.shape[1]:
            history, tip = point[:0], point
        elif float(np.max(np.abs(tip[-1] - point[0]))) >= TRAIL_STEP:
            tip = np.concatenate((tip, point))
            if len(tip) > TRAIL_TIP_POINTS:  # the tip settles into the history; the new tip starts at its end
                keep = max(trail.max_points - 1, 0)
                # (the tip begins at the history's last point, which the history holds already)
                history = np.concatenate((history, tip[1:-1] if len(history) else tip[:-1]))
                history = history[len(history) - keep:] if 0 < keep < len(history) else history[:keep]
                tip = tip[-2:]
        self._trails[key] = (history, tip)
        return (Entity(trail.topic, trail.id, trail.frame_id, (LineStrip(history, trail.color, trail.thickness),)),
                Entity(trail.topic, f"{trail.id}-tip", trail.frame_id, (LineStrip(tip, trail.color, trail.thickness),)))

    def _changed(self, entity: Entity, time_ns: int) -> bool:
        key = (entity.topic, entity.id)
        last = self._sent.get(key)
        if last is not None and time_ns - last.time_ns < KEEPALIVE_NS and same(last.entity, entity):
            return False
        self._sent[key] = _Sent(entity, time_ns)
        return True

    @staticmethod
    def _warn(text: str) -> None:
        warnings.warn(text, VisualsWarning, stacklevel=3)


STAND_IN_SIDE = 2  # [elements] along a free dimension of a stand-in's arrays (a height field needs 2 x 2)


def stand_in(message_type: type[Message]) -> Message:
    """A message of ``message_type`` with plain values: numbers 1 (not 0: looks that divide by a size
    or normalise a vector do not fail on it), arrays of ones (:data:`STAND_IN_SIDE` along a free
    dimension), an enum's first member, False, "". Made without calling the class (its checks are
    for real messages): only for asking looks which topics they publish on."""
    msg = object.__new__(message_type)
    for spec in message_type.__cosim_fields__:
        value: Any
        if spec.kind is FieldKind.ARRAY and spec.array is not None:
            shape = tuple(STAND_IN_SIDE if n is None else n for n in spec.array.shape)
            value = np.ones(shape, dtype=spec.array.dtype)
        elif spec.kind is FieldKind.ENUM and spec.enum_type is not None:
            value = next(iter(spec.enum_type))
        else:
            value = {FieldKind.FLOAT: 1.0, FieldKind.INT: 1, FieldKind.BOOL: False, FieldKind.STR: ""}[spec.kind]
        object.__setattr__(msg, spec.name, value)
    return msg


def same(a: Any, b: Any) -> bool:
    """Value equality of visual items (arrays compared element by element)."""
    if a is b:
        return True
    kind = type(a)
    if kind is not type(b):
        return False
    if kind is np.ndarray:
        return a.shape == b.shape and bool(np.array_equal(a, b))
    if kind is tuple or kind is list:
        return len(a) == len(b) and all(map(same, a, b))
    names = _field_names(kind)
    if names is not None:
        return all(same(getattr(a, name), getattr(b, name)) for name in names)
    return bool(a == b)


@cache
def _field_names(kind: type) -> tuple[str, ...] | None:
    """The field names of a dataclass type, or None for any other type."""
    return tuple(f.name for f in dataclasses.fields(kind)) if dataclasses.is_dataclass(kind) else None
