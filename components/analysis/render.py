"""``cosim render``: a 3D animation of the stone over the shaded water surface, from a recording.

Frames are taken every ``speed / fps`` seconds of simulation time; each shows the body as recorded
at or just before the frame time (a disk or a sphere, true size, turned by its quaternion), its path
so far, and the latest water field (cropped to the view, decimated to at most 64 x 64 vertices,
coloured as in the viewer channels and hill-shaded). Views: ``follow`` (a window of ``span`` metres
that moves with the stone, true proportions) and ``fixed`` (the whole run, heights exaggerated to
fit, the stone also marked by a dot). Output: GIF (Pillow), MP4 (ffmpeg from ``imageio-ffmpeg`` or
the PATH), or a single PNG frame at ``at``. The file appears only when complete.

Rendering uses matplotlib's Agg canvas directly (no pyplot), one figure reused for every frame.
"""

from __future__ import annotations

import math
import os
import shutil
import subprocess
import sys
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.colors import LightSource, to_rgb
from matplotlib.figure import Figure
from mpl_toolkits.mplot3d.art3d import Poly3DCollection
from PIL import Image
from tqdm import tqdm

from components.analysis.data import BodyTrack, iter_fields, load_body, rest_level, topics_of
from components.analysis.style import STAGE_LABELS, STONE_RGB, TRAIL_COLOR, stage_color
from components.messages import Shape, SkipRecord, Stage, StageId, WaterField
from components.visuals import SURFACE_SIDE, water_colors
from cosim.errors import RecordingError
from cosim.record.reader import Recording
from cosim.timebase import NS_PER_S
from cosim.view.items import decimation

FORMATS = (".gif", ".mp4", ".png")
ASPECT = 9 / 16  # frame height / width
DPI = 100
DISK_SEGMENTS = 36  # polygon sides of a drawn disk
LIGHT_AZIMUTH_DEG, LIGHT_ALTITUDE_DEG = 315.0, 50.0  # [deg] light from the north-west, 50 deg up
LIGHT = LightSource(azdeg=LIGHT_AZIMUTH_DEG, altdeg=LIGHT_ALTITUDE_DEG)
SHADE_STRENGTH = 0.5  # how much slopes darken or brighten the water (0: flat colours)
WATER_SHADE_EXAGGERATION = 30.0  # hill-shading slopes are exaggerated this much (shading only)
FIXED_MIN_ZRATIO = 0.25  # fixed view: the box is at least this tall relative to its length
FOLLOW_HEIGHT = 0.3  # follow view: height of the box relative to its length
BOX_ZOOM = 1.3  # the 3D box fills more of the frame than matplotlib's default
REST_COLOR = tuple(water_colors(np.zeros(1))[0])
MARKER_COLOR = (0.95, 0.45, 0.05)  # fixed view: the dot marking the stone, which is small there


class RenderError(Exception):
    """Bad render request (format, encoder, times): reported in one line, exit code 2."""


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
    start: float
    stop: float


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
        self.mean = 0.0

    def at(self, t: float) -> WaterField | None:
        while self._next is not None and self._next[0] <= t + 1e-12:
            self.current = self._next[1]
            self.mean = float(np.mean(self.current.height))
            self._next = next(self._it, None)
        return self.current


@dataclass
class _View:
    x: tuple[float, float]
    y: tuple[float, float]
    z: tuple[float, float]

    def contains(self, points: np.ndarray) -> np.ndarray:
        """Which points (N, 3) lie inside the view box."""
        lo = np.array([self.x[0], self.y[0], self.z[0]])
        hi = np.array([self.x[1], self.y[1], self.z[1]])
        return np.all((points >= lo) & (points <= hi), axis=1)

    @property
    def box(self) -> tuple[float, float, float]:
        return (self.x[1] - self.x[0], self.y[1] - self.y[0], self.z[1] - self.z[0])


class FrameRenderer:
    """Draws frames of one body (and water) on one reused figure; :meth:`draw` returns RGB pixels."""

    def __init__(self, body: BodyTrack, options: RenderOptions, rest: float, title: str,
                 stages: tuple[np.ndarray, np.ndarray] | None = None):
        self.body = body
        self.options = options
        self.rest = rest
        self.title = title
        self.stages = stages  # (times, stage ids)
        width = int(options.width) // 2 * 2
        height = max(2, round(width * ASPECT) // 2 * 2)
        self.size = (width, height)
        self.fig = Figure(figsize=(width / DPI, height / DPI), dpi=DPI)
        self.canvas = FigureCanvasAgg(self.fig)
        self.ax = self.fig.add_axes((0.0, 0.0, 1.0, 0.93), projection="3d", computed_zorder=False)
        self.ax.view_init(elev=options.elevation, azim=options.azimuth)
        for axis in (self.ax.xaxis, self.ax.yaxis, self.ax.zaxis):
            axis.pane.set_alpha(0.15)
        self.ax.tick_params(labelsize=7)
        self.ax.set_xlabel("x [m]", fontsize=8)
        self.ax.set_ylabel("y [m]", fontsize=8)
        self.ax.set_zlabel("z [m]", fontsize=8)
        self.text = self.fig.text(0.01, 0.985, "", ha="left", va="top", fontsize=9)
        self._artists: list = []
        pos = body.position
        self._zmax = float(np.max(pos[:, 2]))
        self._zmin = float(np.min(pos[:, 2]))
        self.fixed = self._fixed_view() if options.view == "fixed" else None

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
        while the stone is near it, shifted with the stone when it flies higher or sinks deeper."""
        span = self.options.span
        height, margin = FOLLOW_HEIGHT * span, 0.05 * span
        z0 = min(self.rest - height / 3, centre[2] - margin)
        z0 = max(z0, centre[2] + margin - height)
        return _View((centre[0] - span / 2, centre[0] + span / 2),
                     (centre[1] - 0.3 * span, centre[1] + 0.3 * span), (z0, z0 + height))

    def stage_at(self, t: float) -> int:
        if self.stages is None or not len(self.stages[0]):
            return -1
        i = int(np.searchsorted(self.stages[0], t, side="right")) - 1
        return int(self.stages[1][i]) if i >= 0 else -1

    def draw(self, t: float, field: WaterField | None, field_mean: float = 0.0) -> np.ndarray:
        """The frame at time ``t`` [s] as an (H, W, 3) uint8 array."""
        for artist in self._artists:
            artist.remove()
        self._artists = []
        ax, body = self.ax, self.body
        i = body.index_at(t)
        pos, quat = body.position[i], body.orientation[i]
        view = self.fixed if self.fixed is not None else self._follow_view(pos)
        ax.set_xlim(*view.x)
        ax.set_ylim(*view.y)
        ax.set_zlim(*view.z)
        box = view.box
        if self.fixed is not None:
            box = (box[0], box[1], max(box[2], FIXED_MIN_ZRATIO * box[0]))
        ax.set_box_aspect(box, zoom=BOX_ZOOM)

        self._draw_water(field, field_mean, view)
        trail = body.position[: i + 1].copy()
        trail[~view.contains(trail)] = np.nan  # mplot3d does not clip lines to the box
        (line,) = ax.plot(trail[:, 0], trail[:, 1], trail[:, 2], color=TRAIL_COLOR, linewidth=0.9, zorder=2)
        self._artists.append(line)
        stone = Poly3DCollection(body_polygons(body, pos, quat), facecolors=[STONE_RGB],
                                 edgecolors=[STONE_RGB], linewidths=0.3, shade=True, lightsource=LIGHT,
                                 zorder=3)
        ax.add_collection3d(stone)
        self._artists.append(stone)
        mark = spin_mark(body, pos, quat)
        (spin,) = ax.plot(mark[:, 0], mark[:, 1], mark[:, 2], color="0.2", linewidth=1.2, zorder=4)
        self._artists.append(spin)
        if self.fixed is not None:
            dot = ax.scatter([pos[0]], [pos[1]], [pos[2]], s=40, color=[MARKER_COLOR], edgecolors="0.2",
                             depthshade=False, zorder=5)
            self._artists.append(dot)

        stage = self.stage_at(t)
        label = STAGE_LABELS.get(stage, "") if stage >= 0 else ""  # type: ignore[call-overload]
        self.text.set_text(f"{self.title}   t = {t:.3f} s   {label}   x = {pos[0]:.2f} m, "
                           f"z = {pos[2] * 100:.1f} cm, speed {body.speed[i]:.2f} m/s")
        self.text.set_color(stage_color(stage) if stage >= 0 else "0.2")
        self.canvas.draw()
        rgba = np.asarray(self.canvas.buffer_rgba())
        return np.ascontiguousarray(rgba[:, :, :3])

    def _draw_water(self, field: WaterField | None, field_mean: float, view: _View) -> None:
        grid = crop_field(field, view.x, view.y) if field is not None else None
        if grid is not None and (grid[2].max() < view.z[0] or grid[2].min() > view.z[1]):
            return  # the view is wholly above or below the water
        if grid is None:
            if not view.z[0] <= self.rest <= view.z[1]:
                return
            gx, gy = np.meshgrid(np.linspace(*view.x, 2), np.linspace(*view.y, 2))
            gz = np.full(gx.shape, self.rest)
            colors = np.broadcast_to(np.array(REST_COLOR), (*gx.shape, 4))
        else:
            gx, gy, gz = grid
            colors = water_colors(gz.ravel() - field_mean).reshape(*gz.shape, 4)
            shade = hill_shade(gx, gy, gz)
            rgb = np.clip(colors[..., :3] * shade[..., None], 0.0, 1.0)
            colors = np.concatenate([rgb, colors[..., 3:]], axis=-1)
        surface = self.ax.plot_surface(gx, gy, gz, facecolors=colors, rstride=1, cstride=1, linewidth=0,
                                       antialiased=False, shade=False, zorder=1)
        self._artists.append(surface)


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
        self.part = path.with_name(path.name + ".part")
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
                   duration=max(20, round(1000 / self.fps)), loop=0)
        super().finish()


class _PngWriter(_Writer):
    def add(self, rgb: np.ndarray) -> None:
        Image.fromarray(rgb).save(self.part, format="PNG", optimize=True)


class _Mp4Writer(_Writer):
    def __init__(self, path: Path, fps: float, size: tuple[int, int], exe: str):
        super().__init__(path, fps, size)
        w, h = size
        self.proc = subprocess.Popen(
            [exe, "-y", "-loglevel", "error", "-f", "rawvideo", "-pix_fmt", "rgb24", "-s", f"{w}x{h}",
             "-r", f"{fps:g}", "-i", "-", "-an", "-c:v", "libx264", "-pix_fmt", "yuv420p", "-f", "mp4",
             str(self.part)], stdin=subprocess.PIPE, stderr=subprocess.PIPE)

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
        raise RenderError("no video encoder for .mp4: pip install 'cosim[video]' (imageio-ffmpeg) or put "
                          "ffmpeg on the PATH; .gif and .png need neither")
    return _Mp4Writer(path, fps, size, exe)


# --- the command ----------------------------------------------------------------------------------

def frame_times(t0: float, t1: float, fps: float, speed: float) -> np.ndarray:
    """Frame times [s] from t0 to t1 (inclusive when on the grid), ``speed / fps`` apart."""
    step = speed / fps
    n = math.floor((t1 - t0) / step + 1e-9) + 1
    return t0 + step * np.arange(max(n, 1))


SPLASH_DELAY = 0.025  # [s] after a first hit that never becomes a skip: the splash is forming


def _default_at(rec: Recording, body: BodyTrack) -> float:
    """Just as the stone leaves the water after its first skip; without a skip, a moment after the
    first hit; without a hit, mid-run."""
    for topic in topics_of(rec, SkipRecord):
        for _, skip in rec.messages(topic, SkipRecord)[:1]:
            return float(skip.touchdown_time + skip.contact_time)
    for topic in topics_of(rec, Stage):
        for stamp, stage in rec.messages(topic, Stage):
            if stage.stage is StageId.HIT:
                return min(float(body.t[-1]), stamp / NS_PER_S + SPLASH_DELAY)
    return float(0.5 * (body.t[0] + body.t[-1]))


def render(recording: str | Path, output: str | Path, options: RenderOptions | None = None) -> RenderResult:
    """Render a recording to ``output`` (.gif, .mp4 or .png); see the module docstring."""
    options = options or RenderOptions()
    output = Path(output)
    if output.suffix.lower() not in FORMATS:
        raise RenderError(f"{output}: unknown format {output.suffix or '(none)'!r} (choose one of "
                          f"{', '.join(FORMATS)})")
    rec = Recording(recording)
    body = load_body(rec, options.body)
    fields = topics_of(rec, WaterField)
    if options.water is not None and options.water not in fields:
        raise RecordingError(f"{rec.path}: no WaterField channel {options.water!r} "
                             f"(WaterField channels: {', '.join(fields) or 'none'})")
    water = options.water or (fields[0] if fields else None)
    begin, end = float(body.t[0]), float(body.t[-1])
    if output.suffix.lower() == ".png":
        if options.at is None:
            at = _default_at(rec, body)
            if water is not None:  # the first water field from then on, so the surface is current
                stamps = (stamp / NS_PER_S for _, stamp, _ in rec.raw([water]))
                at = next((t for t in stamps if t >= at), at)
        else:
            at = options.at
        times = np.array([min(at, end)])
    else:
        t0 = begin if options.start is None else options.start
        t1 = end if options.stop is None else options.stop
        if not t1 >= t0:
            raise RenderError(f"--to ({t1:g} s) must not be before --from ({t0:g} s)")
        times = frame_times(t0, t1, options.fps, options.speed)
    if times[0] < begin or times[-1] > end + 1e-9:
        raise RenderError(f"frame times {times[0]:g} .. {times[-1]:g} s are outside the recorded "
                          f"{begin:g} .. {end:g} s")
    stage_topics = topics_of(rec, Stage)
    stages = None
    if stage_topics:
        pairs = rec.messages(stage_topics[0], Stage)
        stages = (np.array([s for s, _ in pairs]) / 1e9, np.array([int(m.stage) for _, m in pairs]))
    renderer = FrameRenderer(body, options, rest_level(rec), f"{rec.metadata.get('scene', '')}: {body.name}",
                             stages)
    cursor = _FieldCursor(rec, water)
    output.parent.mkdir(parents=True, exist_ok=True)
    writer = _writer(output, options.fps, renderer.size)
    try:
        for t in tqdm(times, desc=f"render {output.name}", unit="frame", disable=not options.progress,
                      file=sys.stderr, leave=False, dynamic_ncols=True):
            field = cursor.at(float(t))
            writer.add(renderer.draw(float(t), field, cursor.mean))
        writer.finish()
    except BaseException:
        writer.abort()
        raise
    return RenderResult(output, len(times), *renderer.size, float(times[0]), float(times[-1]))


def stone_color() -> tuple[float, float, float]:
    """The stone's RGB colour in [0, 1] (for tests finding the drawn stone)."""
    return tuple(to_rgb(STONE_RGB))  # type: ignore[return-value]
