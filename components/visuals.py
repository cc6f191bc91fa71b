"""What the physics messages look like in a 3D viewer, as plain :mod:`cosim.view.items` items.

Registered by message type through the ``cosim.visuals`` entry points (pyproject.toml), so the
recorder's visual deriver finds them for any component publishing these types, at the scene's
``record.visual_rate``; nothing here knows about Foxglove or MCAP.

- :class:`BodyState` on ``/<body>/state``: the transform world -> ``<body>`` on ``/tf``; the body as
  a disk (cylinder: diameter 2R, height = thickness, a darker stripe on its top face so spin shows) or
  a sphere, frame-locked to the body frame on ``/scene/<body>``; its trajectory as a line strip on
  ``/scene/<body>/trail``; its velocity as an arrow on ``/scene/<body>/velocity``.
- :class:`WaterField` on ``/<water>/field``: the surface as a triangle list over at most
  :data:`SURFACE_SIDE` x :data:`SURFACE_SIDE` vertices (sampled cells, exact heights), shaded blue by
  the height above the mean level (crests lighter, troughs darker), on ``/scene/<water>``.
- :class:`Stage` and :class:`SkipRecord`: a line on ``/log`` for every stage change and every skip
  (the integer stage itself is the physics channel ``/<monitor>/stage``, for State Transitions).
- A SolidGround draws itself (:meth:`components.ground.SolidGround.visuals`, with
  :func:`ground_slab`): its plane as a slab on ``/scene/<ground>`` under the path its body has taken.
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from components.messages import BodyState, Shape, SkipRecord, Stage, StageId, WaterField
from components.rigid import quaternion as quat
from components.stages import CURVE_DRIFT, CURVE_HEADING_DEG
from cosim.timebase import NS_PER_S, exact_seconds
from cosim.view.items import (
    LOG_TOPIC,
    WORLD,
    Arrow,
    Cube,
    Cylinder,
    Entity,
    LogLine,
    Pose,
    Sphere,
    Trail,
    Transform,
    color_ramp,
    every_message,
    height_field_mesh,
)

STONE_COLOR = (0.72, 0.53, 0.36, 1.0)  # sandstone
STRIPE_COLOR = (0.30, 0.24, 0.20, 1.0)
TRAIL_COLOR = (0.95, 0.55, 0.10, 0.9)
TRAIL_THICKNESS = 0.004  # [m]
VELOCITY_COLOR = (0.85, 0.15, 0.15, 1.0)
GROUND_COLOR = (0.56, 0.50, 0.42, 1.0)  # packed earth
GROUND_SLAB = 0.002  # [m] the thickness of the slab a ground plane is drawn as, under the plane
GROUND_MARGIN = 0.05  # [m] a ground is drawn this far (and its body's radius) beyond the path its body took
VELOCITY_SCALE = 0.05  # [s]: the velocity arrow is the distance covered in this time
SURFACE_SIDE = 64  # vertices per side of the drawn water surface (at most)
WAVE_SCALE = 0.004  # [m]: heights this far from the mean level take the end colours
COLOR_LEVELS = 32  # shades per WAVE_SCALE of height
WATER_STOPS = (  # (height above mean / WAVE_SCALE, colour)
    (-1.0, (0.03, 0.16, 0.38, 0.9)),
    (0.0, (0.16, 0.46, 0.76, 0.85)),
    (1.0, (0.88, 0.95, 1.00, 0.95)),
)


@lru_cache(maxsize=64)
def body_shape(shape: Shape, r: float, e: float) -> tuple:
    """The primitives of a body in its own frame: a disk of radius ``r`` and thickness ``e`` [m] with a
    stripe on its top face, or a sphere with a spot (the same objects every frame, so the deriver sees
    at once that they have not changed)."""
    if shape is Shape.DISK:
        return (Cylinder((2 * r, 2 * r, e), STONE_COLOR),
                Cube((r, 0.15 * r, 0.1 * e), STRIPE_COLOR, Pose((0.5 * r, 0.0, 0.5 * e))))
    return (Sphere((2 * r, 2 * r, 2 * r), STONE_COLOR),
            Sphere((0.3 * r,) * 3, STRIPE_COLOR, Pose((0.9 * r, 0.0, 0.0))))


def body_state(component: str, port: str, msg: BodyState) -> list:
    """The body's frame, shape, trail and velocity arrow."""
    frame = component
    r = float(msg.radius)
    shape = body_shape(msg.shape, r, float(msg.thickness) if msg.shape is Shape.DISK else 0.0)
    items: list = [
        Transform(WORLD, frame, msg.position, msg.orientation),
        Entity(f"/scene/{component}", "body", frame, shape, frame_locked=True),
        Trail(f"/scene/{component}/trail", "trail", WORLD, msg.position, TRAIL_COLOR, TRAIL_THICKNESS),
        Entity(f"/scene/{component}/velocity", "velocity", WORLD,
               [Arrow(msg.position, np.asarray(msg.velocity) * VELOCITY_SCALE, VELOCITY_COLOR,
                      shaft_diameter=0.2 * r, head_diameter=0.5 * r)]),
    ]
    return items


def plane_axes(normal: tuple[float, float, float]) -> tuple[tuple, np.ndarray, np.ndarray]:
    """(q, u, w) of a plane of unit ``normal`` (3,): the quaternion (w, x, y, z) turning z onto the
    normal by the least rotation, and the plane's own axes u, w (3,) [-], the images of x and y
    (for a slope, u runs downhill)."""
    nx, ny, nz = (float(c) for c in normal)
    size = math.hypot(nx, ny)  # of z x n, the axis turning z onto n
    q = (1.0, 0.0, 0.0, 0.0) if size < 1e-12 else quat.from_axis_angle((-ny, nx, 0.0), math.atan2(size, nz))
    return q, np.array(quat.rotate(q, (1.0, 0.0, 0.0))), np.array(quat.rotate(q, (0.0, 1.0, 0.0)))


def ground_slab(component: str, normal: tuple[float, float, float], point: tuple[float, float, float],
                axes: tuple, lo: tuple[float, float], hi: tuple[float, float]) -> list:
    """A ground plane through ``point`` [m] of unit ``normal``, drawn over the rectangle ``lo`` .. ``hi``
    [m] of its own ``axes`` (:func:`plane_axes` of the normal, measured from ``point``) as a slab
    GROUND_SLAB thick whose top is the plane."""
    q, u, w = axes
    (a0, b0), (a1, b1) = lo, hi
    centre = (np.asarray(point, dtype=float) + 0.5 * (a0 + a1) * u + 0.5 * (b0 + b1) * w
              - 0.5 * GROUND_SLAB * np.asarray(normal, dtype=float))
    slab = Cube((a1 - a0, b1 - b0, GROUND_SLAB), GROUND_COLOR, Pose(tuple(centre.tolist()), q))
    return [Entity(f"/scene/{component}", "ground", WORLD, (slab,))]


def water_colors(height_above_mean: np.ndarray) -> np.ndarray:
    """Shaded blue by height above the mean level: troughs dark, crests light (N,) -> (N, 4).

    Heights are rounded to :data:`COLOR_LEVELS` steps per :data:`WAVE_SCALE` first: the eye cannot
    tell finer shades apart, and a small palette keeps the recorded surface compressible. Each
    shade is looked up in that palette (:func:`_water_palette`), the colour ramp of the rounded
    height, not ramped anew for every vertex of every frame.
    """
    lo, palette = _water_palette()
    steps = np.round(np.asarray(height_above_mean, dtype=float).ravel() / WAVE_SCALE * COLOR_LEVELS)
    return palette[np.clip(steps, lo, lo + len(palette) - 1).astype(np.intp) - lo]


@lru_cache(maxsize=1)
def _water_palette() -> tuple[int, np.ndarray]:
    """(the lowest shade's step, the colours (n, 4) of steps lo .. lo + n - 1 of 1 / COLOR_LEVELS
    of WAVE_SCALE): every shade between the stops; beyond them the end colours hold."""
    lo = math.floor(WATER_STOPS[0][0] * COLOR_LEVELS)
    hi = math.ceil(WATER_STOPS[-1][0] * COLOR_LEVELS)
    palette = color_ramp(np.arange(lo, hi + 1) / COLOR_LEVELS, WATER_STOPS)
    palette.flags.writeable = False
    return lo, palette


def water_field(component: str, port: str, msg: WaterField) -> list:
    """The water surface, decimated and coloured by height."""
    mean = float(np.mean(msg.height))
    mesh = height_field_mesh(msg.height, msg.origin_x, msg.origin_y, msg.cell, max_side=SURFACE_SIDE,
                             colors=lambda z: water_colors(z - mean))
    return [Entity(f"/scene/{component}", "surface", WORLD, [mesh])]


@every_message
def stage(component: str, port: str, msg: Stage) -> list:
    """One log line per stage change."""
    level = "warning" if msg.stage is StageId.SINK else "info"
    # rest is known only once the slow spell that makes it has lasted (REST_HOLD): its line, at that
    # time, says when it began, as the summary, the plots and `inspect` date it
    began = (f", since t = {_seconds(msg.since, 3)} s" if msg.stage is StageId.REST and not math.isnan(msg.since)
             else "")
    return [LogLine(LOG_TOPIC, level, component,
                    f"{msg.label} (stage {int(msg.stage)}): skips {msg.skips}, {_where(msg.x, msg.y)}{began}")]


def _seconds(t: float, decimals: int) -> str:
    """A time [s] of the run (on its nanosecond grid) with at least ``decimals`` decimals and every
    further one it has (:func:`exact_seconds`), as the summary gives it: a rest since 0.4325 s read
    0.432 s, a touchdown at 0.00075 s (0.25 ms steps) 0.0008 s."""
    if not math.isfinite(t):
        return f"{t:.{decimals}f}"
    whole, _, digits = exact_seconds(round(t * NS_PER_S)).partition(".")
    return f"{whole}.{digits.ljust(decimals, '0')}"


def _where(x: float, y: float) -> str:
    """Where on the pond [m]: (x, y), or x alone when y is not known (a recording from before it was
    kept). x alone said nothing of a throw along y (every stage "x = 0.500 m"). Rounded first, so that
    a y of -1e-18 reads 0.000, not -0.000."""
    x, y = round(x, 3) + 0.0, round(y, 3) + 0.0
    return f"x = {x:.3f} m" if math.isnan(y) else f"at ({x:.3f}, {y:.3f}) m"


@every_message
def skip_record(component: str, port: str, msg: SkipRecord) -> list:
    """One log line per finished skip."""
    return [LogLine(LOG_TOPIC, "info", component,
                    f"skip {msg.index}: touchdown {'at ' if math.isnan(msg.touchdown_y) else ''}"
                    f"{_where(msg.touchdown_x, msg.touchdown_y)}, "
                    f"t = {_seconds(msg.touchdown_time, 4)} s; "
                    f"contact {msg.contact_time * 1e3:.1f} ms, peak {msg.peak_g:.1f} g; "
                    f"take-off {msg.takeoff_angle_deg:.1f} deg; "
                    f"distance {msg.distance:.3f} m; speed {msg.speed_in:.2f} -> {msg.speed_out:.2f} m/s"
                    + (f"; drift {msg.drift:+.3f} m, heading {msg.heading_deg:+.1f} deg"
                       if abs(msg.drift) >= CURVE_DRIFT or abs(msg.heading_deg) >= CURVE_HEADING_DEG else ""))]
