"""``cosim render``: a 3D animation of the stone over the shaded water surface, from a recording.
A recording of water alone (a wave pulse, a drop's ripples) is drawn as the whole surface, its
heights exaggerated (:class:`WaterRenderer`).

Frames are taken every ``speed / fps`` seconds of simulation time; each shows the body as recorded
at or just before the frame time (a disk or a sphere, true size, turned by its quaternion), its path
so far, and the latest water field (cropped to the view, decimated to at most 64 x 64 vertices,
coloured as in the viewer channels and hill-shaded, translucent), the stone's shadow on the water
and a dashed drop line from its lowest point to the water with the gap written beside it, so that
its height above the water reads in the picture. Views: ``follow`` (a window of ``span`` metres
that moves with the stone, true proportions, reaching up or down to the water) and ``fixed`` (the
whole run, heights exaggerated to fit, the stone also marked by a dot); ``span`` lies between the
stone's diameter (the stone fills the frame's width) and the width at which it is a pixel across.
Output: GIF (Pillow, :data:`GIF_MIN_FPS` to :data:`GIF_MAX_FPS` frames a second), MP4 (ffmpeg from
``imageio-ffmpeg`` or the PATH), or a single PNG frame at ``at``. The file appears only when complete.

Frames are projected with numpy and painted with Pillow (:mod:`components.analysis.raster`), not
with matplotlib's 3D axes, which rebuild every polygon and tick each frame: about ten times faster.
"""

from __future__ import annotations

import math
import os
import shutil
import subprocess
import sys
import warnings
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from decimal import Decimal
from pathlib import Path

import numpy as np
from matplotlib.colors import to_rgb
from PIL import Image, ImageDraw
from scipy.spatial import ConvexHull, QhullError
from tqdm import tqdm

from components.analysis.data import (
    BodyTrack,
    body_step,
    body_water_topic,
    ground_planes,
    iter_fields,
    linked_components,
    load_body,
    own,
    rest_level,
    scene_publishes,
    stage_changes,
    stage_times,
    topics_of,
    warn_ended_early,
    water_rest_level,
)
from components.analysis.raster import Box, Camera, font, paint_polygons, to_uint8, water_mask
from components.analysis.style import STAGE_LABELS, STONE_RGB, TRAIL_COLOR, stage_color
from components.messages import BodyState, Shape, SkipRecord, Stage, StageId, WaterContact, WaterField
from components.visuals import SURFACE_SIDE, water_colors
from cosim.errors import RecordingError
from cosim.record.output import new_temporary, output_folder, refuse_read_only
from cosim.record.reader import Recording
from cosim.record.recorder import component_of
from cosim.timebase import NS_PER_S, step_decimals
from cosim.view.items import decimation

FORMATS = (".gif", ".mp4", ".png")
# [frames/s] a GIF stores each frame's delay in whole centiseconds, and players show any delay under
# 2 cs for 10 cs: 20 ms is the shortest frame that plays at its speed
GIF_MAX_FPS = 50
# [frames/s] ... in 16 bits: 65535 cs (655.35 s) is the longest frame (--fps 0.001 failed in Pillow)
GIF_MIN_FPS = 100 / 65535
ASPECT = 9 / 16  # frame height / width
DISK_SEGMENTS = 36  # polygon sides of a drawn disk
LIGHT_AZIMUTH_DEG, LIGHT_ALTITUDE_DEG = 315.0, 50.0  # [deg] light from the north-west, 50 deg up
LIGHT_DIRECTION = np.array([  # unit vector towards the light (the same light shades water and stone)
    math.cos(math.radians(LIGHT_ALTITUDE_DEG)) * math.sin(math.radians(LIGHT_AZIMUTH_DEG)),
    math.cos(math.radians(LIGHT_ALTITUDE_DEG)) * math.cos(math.radians(LIGHT_AZIMUTH_DEG)),
    math.sin(math.radians(LIGHT_ALTITUDE_DEG))])
SHADE_STRENGTH = 0.5  # how much slopes darken or brighten the water (0: flat colours)
WATER_SHADE_EXAGGERATION = 30.0  # hill-shading slopes are exaggerated this much (shading only)
FIXED_MIN_ZRATIO = 0.25  # fixed view: the box is at least this tall relative to its length
FOLLOW_HEIGHT = 0.3  # follow view: height of the box relative to its length
WATER_OPACITY = 0.72  # what is under the water (the stone's lower side, its path) shows through
STONE_AMBIENT = 0.55  # brightness of the stone's faces turned away from the light
SHADOW_RGBA = (0, 0, 0, 70)  # the stone's shadow straight under it on the water
BACKGROUND = (255, 255, 255)
REST_COLOR = tuple(water_colors(np.zeros(1))[0])
MARKER_COLOR = (0.95, 0.45, 0.05)  # fixed view: the dot marking the stone, which is small there
GROUND_FILL = (222, 208, 182)  # a solid ground's plane: sand
GROUND_EDGE = (170, 150, 120)
WATER_MIN_SWING = 1e-3  # [m] water alone: the box reaches at least this far above and below rest


class RenderError(Exception):
    """Bad render request (format, encoder, times): reported in one line, exit code 2."""


class RenderWarning(UserWarning):
    """The render goes on, but its frames will not show what was asked (said on one line)."""


@dataclass
class RenderOptions:
    fps: float = 30.0
    width: int = 800
    speed: float = 1.0
    view: str = "follow"
    span: float = 1.0
    start: float | None = None
    stop: float | None = None
    at: float | None = None
    body: str | None = None
    water: str | None = None
    progress: bool = True
    elevation: float = 22.0  # camera elevation [deg]
    azimuth: float = -62.0  # camera azimuth [deg]


@dataclass
class RenderResult:
    path: Path
    frames: int
    width: int
    height: int
    start: float  # [s] the first frame's time
    stop: float  # [s] the last frame's time
    decimals: int = 3  # to write the frames' times with (:func:`time_decimals`)


def time_decimals(rec: Recording) -> int:
    """The decimals [of a second] a frame's time is written with: as many as a time on the recording's
    step needs (:func:`cosim.timebase.step_decimals`), at least 3 (milliseconds). At three, a frame at
    the hit that began at 0.0745 s (0.5 ms steps) said t = 0.074 s."""
    return max(3, step_decimals(rec.dt_ns))


# --- geometry -------------------------------------------------------------------------------------

def rotation_matrix(q: np.ndarray) -> np.ndarray:
    """Body -> world rotation of a unit quaternion (w, x, y, z)."""
    w, x, y, z = np.asarray(q, dtype=float) / np.linalg.norm(q)
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ])


def body_polygons(body: BodyTrack, position: np.ndarray, orientation: np.ndarray) -> list[np.ndarray]:
    """World-frame polygons of the body surface (disk: two faces and the rim; sphere: quads)."""
    rot = rotation_matrix(orientation)
    r = body.radius
    if body.shape == Shape.DISK:
        a = np.linspace(0, 2 * math.pi, DISK_SEGMENTS, endpoint=False)
        h = 0.5 * max(body.thickness, 1e-4)
        ring = np.column_stack([r * np.cos(a), r * np.sin(a), np.zeros_like(a)])
        lift = np.array([0.0, 0.0, h])
        top, bottom = ring + lift, ring - lift
        # triangles only: polygons of mixed sizes make matplotlib pad them with uninitialised memory
        polys = []
        for i in range(DISK_SEGMENTS):
            j = i - 1
            polys += [np.array([lift, top[j], top[i]]), np.array([-lift, bottom[i], bottom[j]]),
                      np.array([bottom[j], bottom[i], top[i]]), np.array([bottom[j], top[i], top[j]])]
    else:
        lat = np.linspace(-math.pi / 2, math.pi / 2, 10)
        lon = np.linspace(0, 2 * math.pi, 19)
        pts = r * np.stack([np.cos(lat)[:, None] * np.cos(lon), np.cos(lat)[:, None] * np.sin(lon),
                            np.sin(lat)[:, None] * np.ones_like(lon)], axis=-1)
        polys = [np.array([pts[i, j], pts[i, j + 1], pts[i + 1, j + 1], pts[i + 1, j]])
                 for i in range(len(lat) - 1) for j in range(len(lon) - 1)]
    return [p @ rot.T + position for p in polys]


def spin_mark(body: BodyTrack, position: np.ndarray, orientation: np.ndarray) -> np.ndarray:
    """A radius drawn on the body (top face of a disk) so its spin shows: (2, 3) world points."""
    lift = 0.5 * body.thickness * 1.05 if body.shape == Shape.DISK else 0.0
    pts = np.array([[0.0, 0.0, lift], [body.radius, 0.0, lift]])
    return pts @ rotation_matrix(orientation).T + position


def crop_field(field: WaterField, x: tuple[float, float], y: tuple[float, float],
               max_side: int = SURFACE_SIDE) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """(X, Y, Z) of the field's cells within the x and y ranges (plus one cell), decimated to at
    most ``max_side`` per side; None when fewer than 2 x 2 cells are inside."""
    ny, nx = field.height.shape
    xs = field.origin_x + field.cell * np.arange(nx)
    ys = field.origin_y + field.cell * np.arange(ny)
    ci = np.nonzero((xs >= x[0] - field.cell) & (xs <= x[1] + field.cell))[0]
    rj = np.nonzero((ys >= y[0] - field.cell) & (ys <= y[1] + field.cell))[0]
    if len(ci) < 2 or len(rj) < 2:
        return None
    ci = ci[decimation(len(ci), max_side)]
    rj = rj[decimation(len(rj), max_side)]
    gx, gy = np.meshgrid(xs[ci], ys[rj])
    return gx, gy, field.height[np.ix_(rj, ci)]


def hill_shade(gx: np.ndarray, gy: np.ndarray, gz: np.ndarray) -> np.ndarray:
    """Brightness factors (ny, nx) of a surface lit from the north-west: 1 where it is level, lower on
    slopes facing away from the light, higher facing it. Slopes are exaggerated
    :data:`WATER_SHADE_EXAGGERATION` times so millimetre waves show; the scale is absolute (a still
    surface is evenly lit), unlike a hill shade normalised per image."""
    if min(gz.shape) < 2:
        return np.ones(gz.shape)
    dzdy, dzdx = np.gradient(gz * WATER_SHADE_EXAGGERATION, gy[:, 0], gx[0, :])
    normal = np.stack([-dzdx, -dzdy, np.ones_like(gz)], axis=-1)
    normal /= np.linalg.norm(normal, axis=-1, keepdims=True)
    az, alt = np.radians(LIGHT_AZIMUTH_DEG), np.radians(LIGHT_ALTITUDE_DEG)
    light = np.array([np.cos(alt) * np.sin(az), np.cos(alt) * np.cos(az), np.sin(alt)])
    lit = np.clip(normal @ light, 0.0, 1.0) / np.sin(alt)
    return 1.0 + SHADE_STRENGTH * (lit - 1.0)


# --- frames ---------------------------------------------------------------------------------------

class _FieldCursor:
    """The latest water field at or before each (increasing) time, read from the recording lazily."""

    def __init__(self, rec: Recording, topic: str | None):
        self._it: Iterator[tuple[float, WaterField]] = iter_fields(rec, topic) if topic else iter(())
        self._next = next(self._it, None)
        self.current: WaterField | None = None
        self.time: float | None = None  # when the current field was recorded [s]
        self.mean = 0.0

    def at(self, t: float) -> WaterField | None:
        while self._next is not None and self._next[0] <= t + 1e-12:
            self.time, self.current = self._next
            self.mean = float(np.mean(self.current.height))
            self._next = next(self._it, None)
        return self.current


@dataclass
class _View:
    """The ranges [m] a frame shows (its :class:`Box` adds the drawn proportions)."""

    x: tuple[float, float]
    y: tuple[float, float]
    z: tuple[float, float]

    @property
    def box(self) -> tuple[float, float, float]:
        return (self.x[1] - self.x[0], self.y[1] - self.y[0], self.z[1] - self.z[0])


@dataclass
class Surface:
    """The water drawn in one frame: vertices gx, gy, gz (ny, nx) [m] and their colours (ny, nx, 3)
    in [0, 1]."""

    gx: np.ndarray
    gy: np.ndarray
    gz: np.ndarray
    rgb: np.ndarray
    at_rest_beyond: bool = False  # the pond outside the recorded field's window drawn as a plane at rest

    def height_at(self, points: np.ndarray) -> np.ndarray:
        """The surface height [m] at the nearest vertex under each point (N, >=2) [m]: (N,)."""
        xs, ys = self.gx[0, :], self.gy[:, 0]
        j = np.clip(np.searchsorted(xs, points[:, 0]), 1, len(xs) - 1)
        j -= (points[:, 0] - xs[j - 1]) < (xs[j] - points[:, 0])
        i = np.clip(np.searchsorted(ys, points[:, 1]), 1, len(ys) - 1)
        i -= (points[:, 1] - ys[i - 1]) < (ys[i] - points[:, 1])
        return self.gz[i, j]


def height_above_water(polygons: np.ndarray, surface: Surface | None, rest: float) -> float:
    """The gap [m] between the body's lowest point (``polygons`` (N, k, 3) [m]) and the water under
    it: > 0 above the surface, < 0 when that point is under water (the rest level ``rest`` [m]
    without a recorded surface)."""
    points = polygons.reshape(-1, 3)
    lowest = points[int(np.argmin(points[:, 2]))]
    water = surface.height_at(lowest[None])[0] if surface is not None else rest
    return float(lowest[2] - water)


def height_caption(gap: float, beside: bool = False) -> str:
    """``3.2 cm above the water`` / ``1.1 cm into the water`` for a gap [m]; ``beside`` the pond
    (no water under the point): ``4.1 cm below the water's level, beside the pond``."""
    if beside:
        where = "above" if gap >= 0 else "below"
        return f"{abs(gap) * 100:.1f} cm {where} the water's level, beside the pond"
    where = "above" if gap >= 0 else "into"
    return f"{abs(gap) * 100:.1f} cm {where} the water"  # abs: never "-0.0"


def beside_the_pond(polygons: np.ndarray, extent: tuple[float, float, float, float] | None) -> bool:
    """Whether the body's lowest point (``polygons`` (N, k, 3) [m]) lies outside the water's grid
    ``extent`` (x0, x1, y0, y1) [m], over no water (False when the extent is not known)."""
    if extent is None:
        return False
    points = polygons.reshape(-1, 3)
    x, y = points[int(np.argmin(points[:, 2])), :2]
    return not (extent[0] <= x <= extent[1] and extent[2] <= y <= extent[3])


class _Frames:
    """What every frame shares: its size in pixels, the text size and header band, and the pieces
    painted the same way with or without a body (the box's floor and x scale, the water)."""

    def __init__(self, options: RenderOptions, rest: float, title: str):
        self.options = options
        self.rest = rest
        self.title = title
        # of the times written in the header: milliseconds, unless told the recording's (time_decimals)
        self.decimals = 3
        width = frame_width(options)
        height = max(2, round(width * ASPECT) // 2 * 2)
        self.size = (width, height)
        self.text_px = max(9, round(width / 70))
        self.top = round(2.2 * self.text_px)  # the header line's band [px]
        # (x0, x1, y0, y1) [m] of the water's grid, where known: the plane drawn for it at rest (no
        # field recorded there yet) stops at its edges, not at the view's
        self.extent: tuple[float, float, float, float] | None = None

    def draw(self, t: float, field: WaterField | None, field_mean: float = 0.0,
             field_time: float | None = None) -> np.ndarray:
        """The frame at time ``t`` [s] as an (H, W, 3) uint8 array; ``field``, the water drawn, was
        recorded at ``field_time`` [s] (None: at ``t``)."""
        raise NotImplementedError

    def _canvas(self, view: _View, aspect: tuple[float, float, float]) -> tuple[Box, Camera, Image.Image]:
        """The box of ``view`` drawn in the proportions ``aspect``, the camera on it and a blank frame
        with the box's floor and x scale already painted."""
        box = Box(view.x, view.y, view.z, aspect)
        cam = Camera(box, self.size, self.options.elevation, self.options.azimuth, top=self.top)
        image = Image.new("RGB", self.size, BACKGROUND)
        self._draw_floor(ImageDraw.Draw(image), cam, box)
        return box, cam, image

    def _header(self, draw: ImageDraw.ImageDraw, text: str, color: tuple[int, ...]) -> None:
        """``text`` across the top; its notes in parentheses (what is drawn older than the frame) that
        would run past the frame's edge go to the frame's foot, at its left, clear of the picture's
        band below the header (a thinned recording's two notes ran past the edge). The header itself
        stays one line, cut at the edge of a small frame."""
        face = font(self.text_px)
        room = self.size[0] - 1.2 * self.text_px
        head, *notes = text.split("  (")
        line, rest = head, []
        for note in notes:
            if not rest and draw.textlength(f"{line}  ({note}", font=face) <= room:
                line = f"{line}  ({note}"
            else:
                rest.append(f"({note}")
        draw.text((0.6 * self.text_px, 0.5 * self.text_px), line, fill=color, font=face)
        if rest:
            draw.text((0.6 * self.text_px, self.size[1] - 1.5 * self.text_px), "  ".join(rest), fill=color,
                      font=face)

    def _surface(self, field: WaterField | None, field_mean: float, view: _View) -> Surface | None:
        """The water to draw, cropped to the view; None when the view is wholly above or below it."""
        grid = crop_field(field, view.x, view.y) if field is not None else None
        if grid is None:
            if not view.z[0] <= self.rest <= view.z[1]:
                return None
            x, y = view.x, view.y
            if self.extent is not None:  # (a plane past the pond's edge stood for water that is not there)
                x = (max(x[0], self.extent[0]), min(x[1], self.extent[1]))
                y = (max(y[0], self.extent[2]), min(y[1], self.extent[3]))
                if not (x[0] < x[1] and y[0] < y[1]):
                    return None
            gx, gy = np.meshgrid(np.linspace(*x, 2), np.linspace(*y, 2))
            return Surface(gx, gy, np.full(gx.shape, self.rest), np.broadcast_to(REST_COLOR[:3], (*gx.shape, 3)))
        gx, gy, gz = grid
        if gz.max() < view.z[0] or gz.min() > view.z[1]:
            return None
        colors = water_colors(gz.ravel() - field_mean).reshape(*gz.shape, 4)[..., :3]
        return self._at_rest_around(Surface(gx, gy, gz, np.clip(colors * hill_shade(gx, gy, gz)[..., None], 0.0, 1.0)),
                                    view)

    def _at_rest_around(self, surface: Surface, view: _View) -> Surface:
        """``surface`` with the pond beyond it, within the view, as a plane at the rest level: a
        recorded field that covers part of the pond (``field_window``) was drawn alone, and the
        fixed view of the reference skip showed its first two skips over nothing. One row or column
        of vertices at rest is added at each side the pond reaches past the field."""
        if self.extent is None:
            return surface
        x = (max(view.x[0], self.extent[0]), min(view.x[1], self.extent[1]))
        y = (max(view.y[0], self.extent[2]), min(view.y[1], self.extent[3]))
        xs, ys = surface.gx[0, :], surface.gy[:, 0]
        step = min(abs(xs[1] - xs[0]), abs(ys[1] - ys[0]))  # (past it, the field's own edge is the pond's)
        before_x, after_x = x[0] < xs[0] - step, x[1] > xs[-1] + step
        before_y, after_y = y[0] < ys[0] - step, y[1] > ys[-1] + step
        if not (before_x or after_x or before_y or after_y):
            return surface
        xs = np.concatenate([[x[0]] if before_x else [], xs, [x[1]] if after_x else []])
        ys = np.concatenate([[y[0]] if before_y else [], ys, [y[1]] if after_y else []])
        inner = (slice(int(before_y), len(ys) - int(after_y)), slice(int(before_x), len(xs) - int(after_x)))
        gz = np.full((len(ys), len(xs)), self.rest)
        gz[inner] = surface.gz
        rgb = np.empty((len(ys), len(xs), 3))
        rgb[...] = REST_COLOR[:3]
        rgb[inner] = surface.rgb
        gx, gy = np.meshgrid(xs, ys)
        return Surface(gx, gy, gz, rgb, at_rest_beyond=True)

    def _paint_water(self, image: Image.Image, cam: Camera, surface: Surface) -> Image.Image:
        """The surface's cells as quads, back to front, laid over ``image`` at :data:`WATER_OPACITY`
        (what is under the water shows through)."""
        pts = np.stack([surface.gx, surface.gy, surface.gz], axis=-1)
        screen, depth = cam.project(pts)
        quads = np.stack([screen[:-1, :-1], screen[:-1, 1:], screen[1:, 1:], screen[1:, :-1]], axis=2)
        quad_depth = 0.25 * (depth[:-1, :-1] + depth[:-1, 1:] + depth[1:, 1:] + depth[1:, :-1])
        colors = to_uint8(surface.rgb[:-1, :-1]).reshape(-1, 3)
        layer = image.copy()
        paint_polygons(ImageDraw.Draw(layer), quads.reshape(-1, 4, 2), quad_depth.ravel(), colors)
        # the surface's outline is the projected border of its grid (millimetre waves never fold it)
        border = np.concatenate([screen[0, :], screen[1:, -1], screen[-1, -2::-1], screen[-2:0:-1, 0]])
        return Image.composite(layer, image, water_mask(image.size, border, WATER_OPACITY))

    def _draw_floor(self, draw: ImageDraw.ImageDraw, cam: Camera, box: Box) -> None:
        """The box's floor outline and back edges in light grey, with x ticks along its front edge."""
        (x0, x1), (y0, y1), (z0, z1) = box.x, box.y, box.z
        front = y0 if cam.eye[1] < 0 else y1
        back = y1 if front == y0 else y0
        grey = (190, 190, 190)
        floor = cam.project(np.array([[x0, y0, z0], [x1, y0, z0], [x1, y1, z0], [x0, y1, z0], [x0, y0, z0]]))[0]
        draw.line(floor.ravel().tolist(), fill=grey, width=1)
        for x in (x0, x1):
            edge = cam.project(np.array([[x, back, z0], [x, back, z1]]))[0]
            draw.line(edge.ravel().tolist(), fill=grey, width=1)
        step = nice_step((x1 - x0) / 5) if x1 > x0 else math.inf  # (a box of no width: no ticks)
        small = font(max(8, round(0.85 * self.text_px)))
        right = -math.inf  # where the last tick's number ends [px]: the axis name goes after it
        for x in np.arange(math.ceil(x0 / step) * step, x1 + 1e-9, step) if math.isfinite(step) else ():
            (px, py), _ = cam.project(np.array([x, front, z0]))
            draw.line((px, py, px, py + 4), fill=(120, 120, 120), width=1)
            label = f"{x:.{max(0, -math.floor(math.log10(step)))}f}"
            draw.text((px, py + 5), label, fill=(90, 90, 90), font=small, anchor="ma")
            right = draw.textbbox((px, py + 5), label, font=small, anchor="ma")[2]
        (px, py), _ = cam.project(np.array([x1, front, z0]))
        at = max(px + 0.5 * self.text_px, right + 0.5 * self.text_px)
        draw.text((at, py + 5), "x [m]", fill=(90, 90, 90), font=small, anchor="la")


class FrameRenderer(_Frames):
    """Draws frames of one body (and water) with :mod:`components.analysis.raster`; :meth:`draw`
    returns RGB pixels. Drawn in this order, so that the stone's height above the water reads at a
    glance: the box's floor and x scale, whatever of the stone and its path is under water, the
    water (translucent), the stone's shadow on it and a drop line from the stone's lowest point to
    the water with the gap written beside it, then the rest of the stone and its path."""

    def __init__(self, body: BodyTrack, options: RenderOptions, rest: float, title: str,
                 stages: tuple[np.ndarray, np.ndarray] | None = None, has_water: bool = True,
                 depths: tuple[np.ndarray, np.ndarray] | None = None, step: float = 0.0,
                 body_step: float = 0.0, grounds: list | None = None):
        super().__init__(options, rest, title)
        self.body = body
        self.grounds = grounds or []  # (normal, point) of the solid grounds the body meets
        self.body_step = max(body_step, step)  # [s] between the body's states in a whole recording
        # the body's coupler's reports, (times [s], depth of the lowest point under the surface [m]):
        # the gap at a frame's time, where the drawn surface (a field recorded a few times a second)
        # may be up to its interval old; ``step`` [s]: how old a report may be and still be that time's
        self.depths = depths
        self.step = step
        self.has_water = has_water  # without water (a bounce on a floor) no surface is drawn nor measured to
        self.stages = stages  # (times, stage ids)
        pos = body.position
        self._zmax = float(np.max(pos[:, 2]))
        self._zmin = float(np.min(pos[:, 2]))
        self.fixed = self._fixed_view() if options.view == "fixed" else None
        self.caption = ""  # the last frame's height caption (what the picture says of the gap)

    def _fixed_view(self) -> _View:
        pos, r = self.body.position, self.body.radius
        x0, x1 = float(np.min(pos[:, 0])), float(np.max(pos[:, 0]))
        length = max(x1 - x0, 20 * r)
        pad = 0.05 * length + 2 * r
        yc = 0.5 * (float(np.min(pos[:, 1])) + float(np.max(pos[:, 1])))
        yhalf = max(0.2 * length, 0.5 * float(np.ptp(pos[:, 1])) + pad)
        z0 = min(self._zmin, self.rest) - 2 * r
        z1 = max(self._zmax, self.rest) + 2 * r
        return _View((x0 - pad, x1 + pad), (yc - yhalf, yc + yhalf), (z0, z1))

    def _follow_view(self, centre: np.ndarray) -> _View:
        """A span x 0.6 span x 0.3 span box around the stone: the water level a third of the way up
        while the stone is near it, shifted with the stone when it flies higher or sinks deeper. With
        water, the box is made taller when the stone is farther from the rest level than it holds, so
        that the surface stays in view (a stone on a pond's bed is drawn under its water)."""
        span = self.options.span
        height, margin = FOLLOW_HEIGHT * span, 0.05 * span
        z0 = min(self.rest - height / 3, centre[2] - margin)
        z0 = max(z0, centre[2] + margin - height)
        z1 = z0 + height
        if self.has_water:
            z0, z1 = min(z0, self.rest - margin), max(z1, self.rest + margin)
        return _View((centre[0] - span / 2, centre[0] + span / 2),
                     (centre[1] - 0.3 * span, centre[1] + 0.3 * span), (z0, z1))

    def stage_at(self, t: float) -> int:
        if self.stages is None or not len(self.stages[0]):
            return -1
        # before the monitor's first message (the end of its first step) the stone is in that stage
        i = max(0, int(np.searchsorted(self.stages[0], t, side="right")) - 1)
        return int(self.stages[1][i])

    def view_at(self, t: float) -> _View:
        """The box the frame at time ``t`` [s] shows: the whole run's, or the window on the stone."""
        return self.fixed if self.fixed is not None else self._follow_view(self.body.position[self.body.index_at(t)])

    def draw(self, t: float, field: WaterField | None, field_mean: float = 0.0,
             field_time: float | None = None) -> np.ndarray:
        """The frame at time ``t`` [s] as an (H, W, 3) uint8 array."""
        body = self.body
        i = body.index_at(t)
        pos, quat = body.position[i], body.orientation[i]
        view = self.view_at(t)
        aspect = view.box
        if self.fixed is not None:  # heights exaggerated so the flight shows over a long run
            aspect = (aspect[0], aspect[1], max(aspect[2], FIXED_MIN_ZRATIO * aspect[0]))
        box, cam, image = self._canvas(view, aspect)

        surface = self._surface(field, field_mean, view) if self.has_water else None
        polys = np.array(body_polygons(body, pos, quat))
        centres = polys.mean(axis=1)
        under = (surface.height_at(centres) > centres[:, 2]) if surface is not None else np.zeros(len(polys), bool)
        trail = body.position[: i + 1]
        trail_under = surface.height_at(trail) > trail[:, 2] if surface is not None else np.zeros(len(trail), bool)
        trail_inside = box.contains(trail)

        draw = ImageDraw.Draw(image)
        self._draw_grounds(draw, cam, box)
        self._draw_stone(draw, cam, polys, under, pos)
        self._draw_trail(draw, cam, trail, trail_inside & trail_under)
        gap = self._reported_gap(t)
        if gap is None:
            gap = height_above_water(polys, surface, self.rest)
        if surface is not None:
            image = self._paint_water(image, cam, surface)
        draw = ImageDraw.Draw(image, "RGBA")
        if self.has_water and gap > 0 and box.z[0] <= pos[2] <= box.z[1]:
            self._draw_shadow(draw, cam, polys, surface)
        self._draw_trail(draw, cam, trail, trail_inside & ~trail_under)
        self._draw_stone(draw, cam, polys, ~under, pos)
        mark = spin_mark(body, pos, quat)
        draw.line(cam.project(mark)[0].ravel().tolist(), fill=(50, 50, 50), width=max(1, self.text_px // 8))
        if self.fixed is not None:
            (cx, cy), _ = cam.project(pos)
            rad = max(3, self.text_px // 2)
            draw.ellipse((cx - rad, cy - rad, cx + rad, cy + rad), fill=tuple(to_uint8(MARKER_COLOR).tolist()),
                         outline=(50, 50, 50))
        if self.has_water:
            # beside the pond the gap is to the water's level (the surface drawn ends at the pond's
            # edge): "into the water" was said of a stone that had come down beside it
            self.caption = height_caption(gap, beside_the_pond(polys, self.extent))
            self._draw_drop_line(draw, cam, polys, gap)
        else:
            self.caption = f"at z = {round((gap + self.rest) * 100, 1) + 0.0:.1f} cm"  # (+ 0.0: no "-0.0")

        stage = self.stage_at(t)
        label = STAGE_LABELS.get(stage, "") if stage >= 0 else ""  # type: ignore[call-overload]
        state_age = self._state_age(t, float(body.t[i]), self.decimals)
        header = (f"{self.title}   t = {t:.{self.decimals}f} s   {label}   {self._where(pos)}, "
                  f"speed {body.speed[i]:.2f} m/s, lowest point {self.caption}{state_age}"
                  f"{self._field_age(t, field_time, self.decimals)}")
        if surface is not None and surface.at_rest_beyond:
            header += "  (water beyond the recorded window drawn at rest)"
        if aspect[2] > view.box[2] * (1.0 + 1e-9):
            # the fixed view stretches heights so that the flight shows over a long run: said, as the
            # water's own frames say it (a 20 deg tilt stretched 3.5x is drawn at about 52 deg)
            header += f"  (heights x {aspect[2] / view.box[2]:.1f})"
        color = tuple(to_uint8(to_rgb(stage_color(stage) if stage >= 0 else "0.2")).tolist())
        self.header = header  # (the last frame's, as its caption)
        self._header(draw, header, color)
        return np.asarray(image)

    def _draw_grounds(self, draw: ImageDraw.ImageDraw, cam: Camera, box: Box) -> None:
        """Each solid ground the body meets, its plane within the box (a plane has no edge), in sand:
        drawn before the stone, which therefore shows in front of it."""
        (x0, x1), (y0, y1) = box.x, box.y
        for (nx, ny, nz), (px, py, pz) in self.grounds:
            if abs(nz) < 1e-6:  # a wall: seen edge on from above
                continue
            corners = np.array([[x, y, pz - (nx * (x - px) + ny * (y - py)) / nz]
                                for x, y in ((x0, y0), (x1, y0), (x1, y1), (x0, y1))])
            # cut to the box's height too: a steep ramp over the box's floor reaches far above and
            # below it, and was drawn across the header and past the frame
            corners = _clip_z(corners, *box.z)
            if len(corners) < 3:
                continue
            outline = cam.project(corners)[0]
            draw.polygon(outline.ravel().tolist(), fill=GROUND_FILL, outline=GROUND_EDGE)

    def _where(self, pos: np.ndarray) -> str:
        """Where the body is: its x for a throw along x (as the summary gives its touchdowns), else
        x and y (a throw along y said "x = 0.50 m" at every frame)."""
        v0 = self.body.velocity[0]
        along_x = abs(float(v0[1])) <= 1e-9 * max(abs(float(v0[0])), 1e-300)
        return f"x = {pos[0]:.2f} m" if along_x else f"at ({pos[0]:.2f}, {pos[1]:.2f}) m"

    def _reported_gap(self, t: float) -> float | None:
        """The gap [m] between the lowest point and the water at ``t`` [s] as the body's coupler
        reported it that step (minus its depth), or None without a report of that time (no coupler
        channel; the coupler quiet, far above the water)."""
        if self.depths is None or not len(self.depths[0]):
            return None
        times, depths = self.depths
        k = int(np.searchsorted(times, t + 1e-12)) - 1
        if k < 0 or t - times[k] > self.step * (1 + 1e-9) or not np.isfinite(depths[k]):
            return None
        return -float(depths[k])

    def _state_age(self, t: float, state_time: float, decimals: int = 3) -> str:
        """``  (stone as at t = 0.100 s)`` when the body's state drawn is more than the body's step
        older than the frame's time ``t`` [s] (a recording thinned with --record-every): its place,
        speed and gap are then that state's, while the stage is the frame's (stage changes are all
        kept). Its time to ``decimals`` decimals."""
        if t - state_time <= self.body_step * (1 + 1e-9):
            return ""
        return f"  (stone as at t = {state_time:.{decimals}f} s)"

    @staticmethod
    def _field_age(t: float, field_time: float | None, decimals: int = 3) -> str:
        """``  (water drawn as at t = 1.700 s)`` when the drawn surface is a field recorded before the
        frame's time ``t`` [s] (fields come a few times a second), else nothing. Its time to
        ``decimals`` decimals."""
        if field_time is None or t - field_time <= 1e-9:
            return ""
        return f"  (water drawn as at t = {field_time:.{decimals}f} s)"

    # --- the pieces of a frame ----------------------------------------------------------------------

    def _draw_stone(self, draw: ImageDraw.ImageDraw, cam: Camera, polys: np.ndarray, which: np.ndarray,
                    centre: np.ndarray) -> None:
        """The body's polygons selected by ``which``: those facing the camera (a convex body needs no
        sorting then), lit from :data:`LIGHT_DIRECTION`."""
        polys = polys[which]
        if not len(polys):
            return
        normals = np.cross(polys[:, 1] - polys[:, 0], polys[:, 2] - polys[:, 0])
        outward = np.sign(np.einsum("ij,ij->i", normals, polys.mean(axis=1) - centre))
        drawn = cam.drawn_normals(normals * np.where(outward == 0, 1.0, outward)[:, None])
        front = drawn @ cam.eye > 0
        lit = np.clip(drawn[front] @ LIGHT_DIRECTION, 0.0, 1.0)
        shade = STONE_AMBIENT + (1 - STONE_AMBIENT) * lit
        colors = to_uint8(np.array(to_rgb(STONE_RGB))[None] * shade[:, None])
        screen, depth = cam.project(polys[front])
        paint_polygons(draw, screen, depth.mean(axis=1), colors, colors)

    def _draw_trail(self, draw: ImageDraw.ImageDraw, cam: Camera, trail: np.ndarray, keep: np.ndarray) -> None:
        """The path so far where ``keep`` holds, as runs of connected points."""
        if not keep.any():
            return
        screen, _ = cam.project(trail)
        color = tuple(to_uint8(to_rgb(TRAIL_COLOR)).tolist())
        width = max(1, self.text_px // 10)
        edges = np.flatnonzero(np.diff(np.concatenate([[0], keep.astype(np.int8), [0]])))
        for start, stop in zip(edges[::2], edges[1::2], strict=True):
            if stop - start >= 2:
                draw.line(screen[start:stop].ravel().tolist(), fill=color, width=width)

    def _draw_shadow(self, draw: ImageDraw.ImageDraw, cam: Camera, polys: np.ndarray,
                     surface: Surface | None) -> None:
        """The body's outline dropped straight down onto the water, darkening it."""
        points = polys.reshape(-1, 3).copy()
        points[:, 2] = surface.height_at(points) if surface is not None else self.rest
        screen, _ = cam.project(points)
        try:
            hull = ConvexHull(screen)
        except QhullError:  # a degenerate outline (seen edge-on): no shadow to speak of
            return
        draw.polygon(screen[hull.vertices].ravel().tolist(), fill=SHADOW_RGBA)

    def _draw_drop_line(self, draw: ImageDraw.ImageDraw, cam: Camera, polys: np.ndarray, gap: float) -> None:
        """A dashed line from the body's lowest point to the water straight under it, the gap
        written beside it."""
        points = polys.reshape(-1, 3)
        lowest = points[int(np.argmin(points[:, 2]))]
        water = lowest - [0.0, 0.0, gap]
        (x0, y0), (x1, y1) = cam.project(np.array([lowest, water]))[0]
        length = math.hypot(x1 - x0, y1 - y0)
        color = (40, 40, 40)
        dash = max(2.0, self.text_px / 3)
        # (dashes beyond the frame are not drawn: a gap of kilometres would be millions of them)
        shown = min(length, 2.0 * math.hypot(*self.size))
        for k in range(int(shown // (2 * dash)) + 1):
            a, b = 2 * k * dash / max(length, 1e-9), min(1.0, (2 * k + 1) * dash / max(length, 1e-9))
            if a >= 1.0:
                break
            draw.line((x0 + a * (x1 - x0), y0 + a * (y1 - y0), x0 + b * (x1 - x0), y0 + b * (y1 - y0)),
                      fill=color, width=1)
        draw.line((x1 - dash, y1, x1 + dash, y1), fill=color, width=1)  # where it meets the water
        text_font = font(self.text_px)
        anchor = (max(x0, x1) + self.text_px, 0.5 * (y0 + y1))
        left, top, right, bottom = draw.textbbox(anchor, self.caption, font=text_font, anchor="lm")
        draw.rectangle((left - 2, top - 1, right + 2, bottom + 1), fill=(255, 255, 255, 170))
        draw.text(anchor, self.caption, fill=color, font=text_font, anchor="lm")


class WaterRenderer(_Frames):
    """Draws frames of the water alone (a recording without a body: a wave pulse, a drop's ripples):
    the whole surface in a fixed box, its heights exaggerated so that waves of millimetres show
    (the header says how much), coloured and hill-shaded as with a body, with the highest crest and
    the lowest trough of the frame written in the header."""

    def __init__(self, first: WaterField, swing: float, options: RenderOptions, rest: float, title: str):
        """``first``: the first field (its grid sets the box); ``swing`` [m]: the largest |height -
        rest| over the frames to draw (sets the box's height)."""
        super().__init__(options, rest, title)
        ny, nx = first.height.shape
        half = 0.5 * first.cell
        x = (first.origin_x - half, first.origin_x + (nx - 0.5) * first.cell)
        y = (first.origin_y - half, first.origin_y + (ny - 0.5) * first.cell)
        reach = 1.2 * max(swing, WATER_MIN_SWING)
        self.view = _View(x, y, (rest - reach, rest + reach))
        length = x[1] - x[0]
        self.aspect = (length, y[1] - y[0], max(2 * reach, FIXED_MIN_ZRATIO * length))
        self.exaggeration = self.aspect[2] / (2 * reach)

    def draw(self, t: float, field: WaterField | None, field_mean: float = 0.0,
             field_time: float | None = None) -> np.ndarray:
        """The frame at time ``t`` [s] as an (H, W, 3) uint8 array."""
        view = self.view
        _, cam, image = self._canvas(view, self.aspect)
        surface = self._surface(field, field_mean, view)
        if surface is not None:
            image = self._paint_water(image, cam, surface)
        waves = ""
        if field is not None and field.height.size:
            crest, trough = float(field.height.max()) - self.rest, float(field.height.min()) - self.rest
            waves = f"   crest {crest * 1000:+.2f} mm, trough {trough * 1000:+.2f} mm"
        header = f"{self.title}   t = {t:.{self.decimals}f} s{waves}   (heights x {self.exaggeration:.0f})"
        self._header(ImageDraw.Draw(image), header, (50, 50, 50))
        return np.asarray(image)


def nice_step(raw: float) -> float:
    """A tick step of 1, 2 or 5 times a power of ten, at least ``raw`` (> 0)."""
    power = 10.0 ** math.floor(math.log10(raw))
    return next(m * power for m in (1, 2, 5, 10) if m * power >= raw)


# --- writers --------------------------------------------------------------------------------------

def _ffmpeg() -> str | None:
    try:
        import imageio_ffmpeg
    except ImportError:
        return shutil.which("ffmpeg")
    return imageio_ffmpeg.get_ffmpeg_exe()


class _Writer:
    def __init__(self, path: Path, fps: float, size: tuple[int, int]):
        self.path = path
        refuse_read_only(path)  # (before a frame is drawn; it was replaced by the move at the end)
        # a new file of a unique name (NAME.<8 hex digits>.tmp): a fixed one (anim.gif.part) was written
        # over and removed, whatever it held (a recording so named, the one rendered, was lost)
        self.part = new_temporary(path)
        self.fps = fps
        self.size = size

    def add(self, rgb: np.ndarray) -> None:
        raise NotImplementedError

    def finish(self) -> None:
        os.replace(self.part, self.path)

    def abort(self) -> None:
        self.part.unlink(missing_ok=True)


class _GifWriter(_Writer):
    def __init__(self, path: Path, fps: float, size: tuple[int, int]):
        super().__init__(path, fps, size)
        self.frames: list[Image.Image] = []

    def add(self, rgb: np.ndarray) -> None:
        self.frames.append(Image.fromarray(rgb).quantize(colors=256, method=Image.Quantize.FASTOCTREE))

    def finish(self) -> None:
        first, *rest = self.frames
        first.save(self.part, format="GIF", save_all=True, append_images=rest,
                   duration=gif_delays(len(self.frames), self.fps), loop=0)
        super().finish()


def gif_delays(frames: int, fps: float) -> list[int]:
    """Each of ``frames`` frames' delay [ms] at ``fps`` frames a second, in the whole centiseconds a GIF
    stores: frame k ends at (k + 1) / fps rounded to 10 ms, so the rounding never adds up (the GIF
    plays as long as the frames last, to 5 ms) and no delay is under 20 ms while fps <=
    :data:`GIF_MAX_FPS`."""
    # floor(x + 0.5), not round(): Python rounds halves to even, which would alternate up and down
    ends = [10 * math.floor((k + 1) * 100 / fps + 0.5) for k in range(frames)]
    return np.diff(ends, prepend=0).tolist()


class _PngWriter(_Writer):
    def add(self, rgb: np.ndarray) -> None:
        Image.fromarray(rgb).save(self.part, format="PNG", optimize=True)


class _Mp4Writer(_Writer):
    def __init__(self, path: Path, fps: float, size: tuple[int, int], exe: str):
        super().__init__(path, fps, size)
        w, h = size
        try:
            self.proc = subprocess.Popen(
                [exe, "-y", "-loglevel", "error", "-f", "rawvideo", "-pix_fmt", "rgb24", "-s", f"{w}x{h}",
                 "-r", f"{fps:g}", "-i", "-", "-an", "-c:v", "libx264", "-pix_fmt", "yuv420p", "-f", "mp4",
                 str(self.part)], stdin=subprocess.PIPE, stderr=subprocess.PIPE)
        except BaseException:  # (no writer to abort yet: its temporary file goes here)
            self.part.unlink(missing_ok=True)
            raise

    def add(self, rgb: np.ndarray) -> None:
        assert self.proc.stdin is not None
        self.proc.stdin.write(rgb.tobytes())

    def finish(self) -> None:
        _, err = self.proc.communicate()
        if self.proc.returncode:
            detail = err.decode(errors="replace").strip()
            raise RenderError(f"ffmpeg failed ({self.proc.returncode}): {detail}")
        super().finish()

    def abort(self) -> None:
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait()
        super().abort()


def _writer(path: Path, fps: float, size: tuple[int, int]) -> _Writer:
    suffix = path.suffix.lower()
    if suffix == ".gif":
        return _GifWriter(path, fps, size)
    if suffix == ".png":
        return _PngWriter(path, fps, size)
    exe = _ffmpeg()
    if exe is None:
        raise RenderError("no video encoder for .mp4: pip install imageio-ffmpeg (the project's [video] extra: "
                          "pip install -e '.[video]' in its folder) or put ffmpeg on the PATH; .gif and .png need "
                          "neither")
    return _Mp4Writer(path, fps, size, exe)


# --- the command ----------------------------------------------------------------------------------

MAX_FRAMES = 100_000  # an hour of video at 30 frames a second is more than any run needs


def frame_times(t0: float, t1: float, fps: float, speed: float) -> np.ndarray:
    """Frame times [s] from t0 to t1 (inclusive when on the grid), ``speed / fps`` apart; a
    :class:`RenderError` when they would be more than :data:`MAX_FRAMES`."""
    step = speed / fps
    n = math.floor((t1 - t0) / step + 1e-9) + 1
    if n == 1 and t1 - t0 > 1e-9:  # a span shorter than a frame: the video would be its first frame alone
        raise RenderError(f"--speed {speed:g} at --fps {fps:g} puts {step:g} s of the run between frames, more than "
                          f"the {t1 - t0:g} s to draw: one frame; lower --speed (at most {(t1 - t0) * fps / 2:.3g} "
                          "for three frames) or make a PNG")
    if n > MAX_FRAMES:
        raise RenderError(f"{n:.3g} frames ({t1 - t0:g} s of the run at --speed {speed:g} and --fps {fps:g}), more "
                          f"than {MAX_FRAMES}: raise --speed, lower --fps or shorten --from/--to")
    return t0 + step * np.arange(max(n, 1))


SPLASH_DELAY = 0.025  # [s] after a first hit that never becomes a skip: the splash is forming
FIELD_SNAP = 0.05  # [s] the default frame moves on to a recorded water field at most this far after its moment


def _default_at(rec: Recording, body: BodyTrack, linked: set[str] | None) -> float:
    """Just as the stone leaves the water after its first skip; without a skip, a moment after the
    first hit; without a hit, mid-run (``linked``: the body's own channels, see linked_components)."""
    for topic in own(topics_of(rec, SkipRecord), linked):
        for _, skip in rec.messages(topic, SkipRecord)[:1]:
            return float(skip.touchdown_time + skip.contact_time)
    for topic in own(topics_of(rec, Stage), linked):
        for stamp, stage in rec.messages(topic, Stage):
            if stage.stage is StageId.HIT:
                return min(float(body.t[-1]), stamp / NS_PER_S + SPLASH_DELAY)
    return float(0.5 * (body.t[0] + body.t[-1]))


def render(recording: str | Path, output: str | Path, options: RenderOptions | None = None) -> RenderResult:
    """Render a recording to ``output`` (.gif, .mp4 or .png); see the module docstring."""
    options = options or RenderOptions()
    output = Path(output)
    _check_request(output, options)
    rec = Recording(recording)
    if options.body is None and not topics_of(rec, BodyState):
        if not topics_of(rec, WaterField):
            raise RecordingError(f"{rec.path}: no BodyState or WaterField channel, nothing to show "
                                 f"(channels: {', '.join(sorted(rec.channels))})")
        return _render_water(rec, output, options)
    body = load_body(rec, options.body)
    warn_ended_early(rec, "the frames")  # frames of what there is, said to end where the run did
    _check_span(options, body)
    linked = linked_components(rec, body.name)  # with several bodies, the channels that are this one's
    fields = topics_of(rec, WaterField)
    if options.water is not None and options.water not in fields:
        raise RecordingError(f"{rec.path}: no WaterField channel {options.water!r} "
                             f"(WaterField channels: {', '.join(fields) or 'none'})")
    water = options.water or body_water_topic(rec, body.name, fields)

    def default_at() -> float:
        at = _default_at(rec, body, linked)
        if water is not None:  # at a water field close to it, so the surface drawn is the one then
            stamps = [stamp / NS_PER_S for _, stamp, _ in rec.raw([water])]
            # the first at or after the moment, never one before it: that showed the stone still in
            # the water, where --at's help promises it leaving (the ricochet's frame fell 4 ms before
            # its take-off); with none soon after, the moment itself, the water drawn as last recorded
            after = min((t for t in stamps if t >= at), default=math.inf)
            at = after if after - at <= FIELD_SNAP else at
        return at

    # a restart's recording begins at its checkpoint, a step before the body's first state
    begin = min(float(body.t[0]), rec.restart_ns / NS_PER_S) if rec.restart_ns else float(body.t[0])
    times = _frame_times(output, options, begin, float(body.t[-1]), default_at, "recorded")
    stage_topics = own(topics_of(rec, Stage), linked)  # this body's monitor
    stages = None
    if stage_topics:
        pairs = stage_changes(rec, stage_topics[0])
        stages = (stage_times(pairs), np.array([int(m.stage) for _, m in pairs]))
    has_water = bool(fields or topics_of(rec, WaterContact))
    if has_water and not fields:  # the scene's water recorded no surface (field_rate 0, as the sweeps' scenes)
        warnings.warn(f"{rec.path}: the recording holds no water surface (its water's field_rate was 0, or "
                      "--record left its field out): the water is drawn flat at its rest level, without the "
                      "waves the run made", RenderWarning, stacklevel=2)
    # (a scene that cannot be read is not said to have water: a ground bounce's was)
    if not has_water and scene_publishes(rec, (WaterField, WaterContact), unknown=False):
        # left out by --record: the frames show no water at all, where the scene had some
        warnings.warn(f"{rec.path}: the scene has water, but the recording holds none of its channels (a "
                      "--record that left them out): no water is drawn", RenderWarning, stacklevel=2)
    contacts = own(topics_of(rec, WaterContact), linked)  # this body's coupler's reports
    depths = None
    if contacts:
        # only while it touches the water: there the field drawn is furthest from the water then, and
        # a dry report's depth may be a stand-in (a coupler with no body yet says -1e9 m)
        pairs = rec.messages(contacts[0], WaterContact)
        depths = (np.array([stamp for stamp, _ in pairs], dtype=np.int64) / NS_PER_S,
                  np.array([m.depth if m.wetted else np.nan for _, m in pairs], dtype=float))
    renderer = FrameRenderer(body, options, rest_level(rec, body.name), f"{rec.metadata.get('scene', '')}: {body.name}",
                             stages, has_water, depths, rec.dt_ns / NS_PER_S, body_step(rec, body.name),
                             ground_planes(rec, body.name))
    renderer.extent = _water_extent(rec, water)
    renderer.decimals = time_decimals(rec)
    if options.water is not None and has_water:
        _warn_if_never_in_view(rec, options.water, renderer, times, body_water_topic(rec, body.name, fields))
    return _write_frames(renderer, _FieldCursor(rec, water), times, output, options)


def _warn_if_never_in_view(rec: Recording, water: str, renderer: FrameRenderer, times: np.ndarray,
                           meets: str | None) -> None:
    """A :class:`RenderWarning` when the water chosen (``--water``) lies outside the view of every
    frame at ``times``: each would show a flat plane at the rest level, not that water (``cosim render
    float_sphere.mcap --body pine --water /granite_pond/field`` did so without a word). ``meets``:
    the field of the water the body meets, suggested instead."""
    field = next((f for _, f in iter_fields(rec, water)), None)
    if field is None:
        return
    for t in times:
        view = renderer.view_at(float(t))
        if crop_field(field, view.x, view.y) is not None:
            return
    ny, nx = field.height.shape
    x0, y0 = field.origin_x - field.cell / 2, field.origin_y - field.cell / 2
    x1, y1 = x0 + nx * field.cell, y0 + ny * field.cell
    instead = (f"; leave --water out to draw {meets}, the water {renderer.body.name} meets"
               if meets is not None and meets != water else "")
    warnings.warn(f"--water {water}: no frame of {renderer.body.name} has that water (x {x0:.3g} .. {x1:.3g} m, "
                  f"y {y0:.3g} .. {y1:.3g} m) in view; the frames show a flat surface at z = {renderer.rest:g} m "
                  f"instead{instead}", RenderWarning, stacklevel=3)


def _check_request(output: Path, options: RenderOptions) -> None:
    """A :class:`RenderError` when ``output`` cannot be written as asked: a folder, an unknown
    format, options that do not apply to it, or more frames a second than a GIF plays."""
    suffix = output.suffix.lower()
    if output.is_dir():
        raise RenderError(f"{output}: is a folder; render writes one file: give -o a name ending "
                          f"{', '.join(FORMATS)}")
    if suffix not in FORMATS:
        raise RenderError(f"{output}: unknown format {output.suffix or '(none)'!r} (choose one of "
                          f"{', '.join(FORMATS)})")
    if suffix == ".png" and (options.start is not None or options.stop is not None):
        raise RenderError(f"{output}: --from and --to pick an animation's time range; a PNG is one frame: "
                          "give its time with --at")
    if suffix != ".png" and options.at is not None:
        raise RenderError(f"{output}: --at is a PNG's frame time; an animation runs from --from to --to")
    if suffix == ".gif" and options.fps > GIF_MAX_FPS:
        raise RenderError(f"{output}: --fps must be at most {GIF_MAX_FPS} for a GIF (its frame delays are "
                          f"whole hundredths of a second, at least 2), got {options.fps:g}: use --fps "
                          f"{GIF_MAX_FPS} or write an .mp4")
    if suffix == ".gif" and not options.fps >= GIF_MIN_FPS:
        raise RenderError(f"{output}: --fps must be at least {_rounded(GIF_MIN_FPS, up=True)} for a GIF (a frame's "
                          f"delay is at most 65535 hundredths of a second, 655.35 s), got {options.fps:g}")


def frame_width(options: RenderOptions) -> int:
    """The frames' width [px]: ``options.width`` made even (video encoders need even sizes)."""
    return int(options.width) // 2 * 2


# a pixel of the follow view spans at least this fraction of the stone's largest coordinate: finer,
# the view's edges and the stone's points differ by round-off alone (--span 1e-300 m made a box of
# width 0 around a stone 1 m from the origin)
SPAN_RESOLUTION = 1e-12


def _rounded(value: float, up: bool) -> str:
    """``value`` to 3 significant digits, rounded up (or down), as :func:`format` ``g`` writes it: a
    bound said so that the number shown is itself within it."""
    text = f"{value:.3g}"
    if not math.isfinite(value) or (float(text) >= value if up else float(text) <= value):
        return text
    digits = Decimal(text)  # rounded the other way: one in its last digit further
    unit = Decimal(1).scaleb(digits.adjusted() - 2)
    return f"{float(digits + unit if up else digits - unit):g}"


def _check_span(options: RenderOptions, body: BodyTrack) -> None:
    """The follow view's width ``options.span`` lies between the narrowest and the widest that show
    the stone: RenderError otherwise. At most so wide that the stone is a pixel across (``--span
    1e6`` wrote a picture with nothing in it); at least the stone's diameter, where it fills the
    frame's width, and so wide that a pixel spans :data:`SPAN_RESOLUTION` of the stone's coordinates
    (``--span 1e-300``: an internal math domain error)."""
    if options.view != "follow":
        return
    span, width, radius = options.span, frame_width(options), body.radius
    reach = float(np.max(np.abs(body.position))) if body.position.size else 0.0  # [m] the farthest coordinate
    finest = SPAN_RESOLUTION * width * reach  # [m] the narrowest span its coordinates resolve
    stone = radius > 0.0 and math.isfinite(radius)
    widest = 2.0 * radius * width if stone else math.inf  # [m] the stone one pixel wide
    if stone and finest > widest:
        raise RenderError(f"--span {span:g} m: the stone ({2 * radius:g} m across, its coordinates as large as "
                          f"{reach:g} m) is too small for a follow view: a window it is a pixel of would be finer "
                          f"than its coordinates resolve; use --view fixed")
    if span > widest:
        raise RenderError(f"--span {span:g} m: the stone ({2 * radius:g} m across) would be narrower than a pixel "
                          f"of the {int(options.width)} px frame; give at most {_rounded(widest, up=False)} m "
                          f"(or --view fixed)")
    if stone and span < 2.0 * radius and 2.0 * radius >= finest:
        raise RenderError(f"--span {span:g} m: narrower than the stone ({2 * radius:g} m across), which would more "
                          f"than fill the frame; give at least {_rounded(2.0 * radius, up=True)} m")
    if span < finest:
        raise RenderError(f"--span {span:g} m: a pixel of the {int(options.width)} px frame would be "
                          f"{span / width:.3g} m, finer than the stone's coordinates (as large as {reach:g} m) "
                          f"resolve; give at least {_rounded(finest, up=True)} m")


def _frame_times(output: Path, options: RenderOptions, begin: float, end: float, default_at: Callable[[], float],
                 what: str) -> np.ndarray:
    """The frames' times [s]: one, at ``options.at`` (else ``default_at()``) for a PNG; from
    ``--from`` to ``--to`` (else ``begin`` to ``end``) otherwise; RenderError outside ``begin`` ..
    ``end`` (the ``what`` recording's span)."""
    if output.suffix.lower() == ".png":
        # the default moment may fall after a short run's end: then its last frame; a chosen one is checked
        times = np.array([min(default_at(), end) if options.at is None else options.at])
    else:
        t0 = begin if options.start is None else options.start
        t1 = end if options.stop is None else options.stop
        for flag, t in (("--from", options.start), ("--to", options.stop)):
            if t is not None and not begin <= t <= end + 1e-9:  # named before the order of the two
                raise RenderError(f"{flag} {t:g} s is outside the {what} {begin:g} .. {end:g} s")
        if not t1 >= t0:
            raise RenderError(f"--to ({t1:g} s) must not be before --from ({t0:g} s)")
        times = frame_times(t0, t1, options.fps, options.speed)
    if times[0] < begin or times[-1] > end + 1e-9:
        asked = (f"frame time {times[0]:g} s is" if len(times) == 1
                 else f"frame times {times[0]:g} .. {times[-1]:g} s are")
        raise RenderError(f"{asked} outside the {what} {begin:g} .. {end:g} s")
    return times


def _water_extent(rec: Recording, water: str | None) -> tuple[float, float, float, float] | None:
    """(x0, x1, y0, y1) [m] of the grid of the water publishing ``water`` (a field topic), from the
    recorded scene; None when it cannot be told (no such water, a scene that cannot be read)."""
    if water is None:
        return None
    try:
        p = rec.scene().components[component_of(water)].params
        half = 0.5 * float(p.cell)
        return (float(p.origin_x) - half, float(p.origin_x) + (int(p.nx) - 0.5) * float(p.cell),
                float(p.origin_y) - half, float(p.origin_y) + (int(p.ny) - 0.5) * float(p.cell))
    except Exception:  # an old or damaged scene, a water without a grid: the view's plane, as before
        return None


def _render_water(rec: Recording, output: Path, options: RenderOptions) -> RenderResult:
    """:func:`render` of a recording that holds water but no body (:class:`WaterRenderer`): frames
    over the fields' times; a PNG by default mid-run."""
    fields = topics_of(rec, WaterField)
    if options.water is not None and options.water not in fields:
        raise RecordingError(f"{rec.path}: no WaterField channel {options.water!r} "
                             f"(WaterField channels: {', '.join(fields)})")
    water = options.water or fields[0]
    rest = water_rest_level(rec, water)  # the level of the water shown, not of the first by name
    first, stamps, swings = None, [], []  # the first field; each field's time [s] and largest |height - rest| [m]
    for t, field in iter_fields(rec, water):
        first = first if first is not None else field
        stamps.append(t)
        swings.append(float(np.max(np.abs(field.height - rest))))
    begin, end = stamps[0], stamps[-1]
    # mid-run, at the field recorded then
    times = _frame_times(output, options, begin, end, lambda: max(t for t in stamps if t <= 0.5 * (begin + end)),
                         "recorded water's")
    # the box holds the highest wave of the fields drawn: from the one current at the first frame on
    shown = max(t for t in stamps if t <= times[0] + 1e-9), times[-1] + 1e-9
    swing = max(w for t, w in zip(stamps, swings, strict=True) if shown[0] <= t <= shown[1])
    renderer = WaterRenderer(first, swing, options, rest, f"{rec.metadata.get('scene', '')}: {water.strip('/')}")
    renderer.decimals = time_decimals(rec)
    return _write_frames(renderer, _FieldCursor(rec, water), times, output, options)


def _write_frames(renderer: _Frames, cursor: _FieldCursor, times: np.ndarray, output: Path,
                  options: RenderOptions) -> RenderResult:
    """Draw the frames at ``times`` and write them to ``output``, which appears only when complete; a
    failed write (the disk full, a folder that cannot be made) is an OSError naming ``output``, not
    the private file it was written to, and leaves nothing behind."""
    try:
        with output_folder(output.parent):
            writer = _writer(output, options.fps, renderer.size)
            try:
                # (no bar into a log or a pipe: its redraws are noise there, as a run's would be)
                shown = options.progress and sys.stderr.isatty()
                for t in tqdm(times, desc=f"render {output.name}", unit="frame", disable=not shown,
                              file=sys.stderr, leave=False, dynamic_ncols=True):
                    field = cursor.at(float(t))
                    writer.add(renderer.draw(float(t), field, cursor.mean, cursor.time))
                writer.finish()
            except BaseException:
                writer.abort()
                raise
    except OSError as exc:
        raise OSError(exc.errno, exc.strerror or str(exc), str(output)) from None
    return RenderResult(output, len(times), *renderer.size, float(times[0]), float(times[-1]), renderer.decimals)


def stone_color() -> tuple[float, float, float]:
    """The stone's RGB colour in [0, 1] (for tests finding the drawn stone)."""
    return tuple(to_rgb(STONE_RGB))  # type: ignore[return-value]


def _clip_z(polygon: np.ndarray, z_lo: float, z_hi: float) -> np.ndarray:
    """The part of the convex ``polygon`` (N, 3) [m] between the heights ``z_lo`` and ``z_hi``: its
    corners in order, (M, 3), M < 3 when nothing of it is left (Sutherland-Hodgman, one plane at a
    time)."""
    for level, keep_below in ((z_lo, False), (z_hi, True)):
        kept = []
        for k in range(len(polygon)):
            a, b = polygon[k], polygon[(k + 1) % len(polygon)]
            a_in = a[2] <= level if keep_below else a[2] >= level
            b_in = b[2] <= level if keep_below else b[2] >= level
            if a_in:
                kept.append(a)
            if a_in != b_in:  # the edge crosses the level: where
                kept.append(a + (b - a) * ((level - a[2]) / (b[2] - a[2])))
        polygon = np.array(kept).reshape(-1, 3)
        if len(polygon) < 3:
            break
    return polygon
