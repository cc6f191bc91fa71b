"""A small 3D painter for ``cosim render``: an orthographic camera and depth-sorted polygons drawn
with Pillow.

Why not matplotlib's 3D axes: they rebuild every polygon's path, colour and tick label each frame
(about 0.25 s a frame at 800 x 450 for a 64 x 64 surface); projecting with numpy and filling the
polygons with Pillow takes a tenth of that, and leaves the look (a translucent water surface, the
stone's shadow on it) in our hands.

Conventions: world points are (N, 3) [m]; screen points are (N, 2) pixels, x to the right and y
down; depth grows towards the camera, so drawing in increasing depth paints back to front.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from PIL import Image, ImageDraw, ImageFont

FIT_MARGIN = 0.06  # [fraction of the frame] kept free around the view box


@dataclass(frozen=True)
class Box:
    """The world box a frame shows: x, y, z ranges [m] and the proportions it is drawn with
    (``aspect``: drawn lengths of its three sides, e.g. the true lengths, or a taller z)."""

    x: tuple[float, float]
    y: tuple[float, float]
    z: tuple[float, float]
    aspect: tuple[float, float, float]

    @property
    def lo(self) -> np.ndarray:
        return np.array([self.x[0], self.y[0], self.z[0]])

    @property
    def hi(self) -> np.ndarray:
        return np.array([self.x[1], self.y[1], self.z[1]])

    def contains(self, points: np.ndarray) -> np.ndarray:
        """Which points (N, 3) lie inside the box: (N,) bool."""
        return np.all((points >= self.lo) & (points <= self.hi), axis=1)

    def corners(self) -> np.ndarray:
        """The box's 8 corners (8, 3) [m]."""
        return np.array([[x, y, z] for x in self.x for y in self.y for z in self.z])


class Camera:
    """Orthographic projection of a :class:`Box` into a frame of ``size`` = (width, height) px,
    looking from ``azimuth_deg`` / ``elevation_deg`` (matplotlib's angles: azimuth about +z from
    +x, elevation above the x-y plane), the box fitted into the frame below ``top`` pixels."""

    def __init__(self, box: Box, size: tuple[int, int], elevation_deg: float, azimuth_deg: float, top: int = 0):
        e, a = math.radians(elevation_deg), math.radians(azimuth_deg)
        self.eye = np.array([math.cos(e) * math.cos(a), math.cos(e) * math.sin(a), math.sin(e)])
        right = np.array([-math.sin(a), math.cos(a), 0.0])
        up = np.cross(self.eye, right)
        self._basis = np.column_stack([right, up, self.eye])  # world (scaled) -> (u, v, depth)
        span = box.hi - box.lo
        drawn = np.asarray(box.aspect, dtype=float)
        self._scale = drawn / np.max(drawn) / np.where(span > 0, span, 1.0)  # world m -> drawn units
        self._centre = 0.5 * (box.lo + box.hi)
        uv = self._uvd(box.corners())[:, :2]
        width, height = size
        room_w, room_h = width * (1 - 2 * FIT_MARGIN), (height - top) * (1 - 2 * FIT_MARGIN)
        extent = np.ptp(uv, axis=0)
        self.pixels_per_unit = float(min(room_w / max(extent[0], 1e-12), room_h / max(extent[1], 1e-12)))
        mid = 0.5 * (uv.min(axis=0) + uv.max(axis=0))
        self._offset = np.array([width / 2, top + (height - top) / 2]) - self.pixels_per_unit * mid * [1, -1]

    def _uvd(self, points: np.ndarray) -> np.ndarray:
        return ((np.asarray(points, dtype=float) - self._centre) * self._scale) @ self._basis

    def project(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Screen points (..., 2) [px] and depths (...) of world points (..., 3) [m]."""
        uvd = self._uvd(points)
        screen = self._offset + self.pixels_per_unit * uvd[..., :2] * [1, -1]
        return screen, uvd[..., 2]

    def drawn_normals(self, normals: np.ndarray) -> np.ndarray:
        """Unit normals (N, 3) of world polygons in the drawn proportions (a stretched axis
        flattens slopes along it), in which :attr:`eye` points towards the camera."""
        drawn = normals / np.where(self._scale > 0, self._scale, 1.0)  # normals scale inversely
        return drawn / np.maximum(np.linalg.norm(drawn, axis=-1, keepdims=True), 1e-300)


def paint_polygons(draw: ImageDraw.ImageDraw, screen: np.ndarray, depth: np.ndarray,
                   colors: np.ndarray, outline: np.ndarray | None = None) -> None:
    """Fill polygons back to front: ``screen`` (N, k, 2) [px], ``depth`` (N,) their mean depth,
    ``colors`` (N, 3) or (N, 4) uint8; ``outline`` (N, 3) uint8 edge colours, or None."""
    if not len(screen):
        return
    order = np.argsort(depth, kind="stable")
    flat = screen[order].reshape(len(order), -1).tolist()
    fills = [tuple(c) for c in colors[order].tolist()]
    if outline is None:
        for points, fill in zip(flat, fills, strict=True):
            draw.polygon(points, fill=fill)
    else:
        edges = [tuple(c) for c in outline[order].tolist()]
        for points, fill, edge in zip(flat, fills, edges, strict=True):
            draw.polygon(points, fill=fill, outline=edge)


def water_mask(size: tuple[int, int], outline: np.ndarray, alpha: float) -> Image.Image:
    """A mode-L mask of opacity ``alpha`` inside the polygon ``outline`` (N, 2) [px], 0 outside."""
    mask = Image.new("L", size, 0)
    level = round(255 * alpha)
    ImageDraw.Draw(mask).polygon(outline.ravel().tolist(), fill=level, outline=level)
    return mask


def to_uint8(rgb: np.ndarray) -> np.ndarray:
    """Colours in [0, 1] (..., 3 or 4) as uint8."""
    return np.clip(np.asarray(rgb) * 255 + 0.5, 0, 255).astype(np.uint8)


@lru_cache(maxsize=8)
def font(size: int) -> ImageFont.ImageFont | ImageFont.FreeTypeFont:
    """DejaVu Sans (matplotlib ships it) at ``size`` px, else Pillow's own font."""
    try:
        from matplotlib import font_manager

        return ImageFont.truetype(font_manager.findfont("DejaVu Sans"), size)
    except (ImportError, OSError, ValueError):
        return ImageFont.load_default()
