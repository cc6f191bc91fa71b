"""The water's surface for a checkpoint, without its columns at rest.

A pond at rest is zeros: its heights h and vertical velocities v are both 0 wherever no wave has
come, and a tiled pond sets a tile that has come back to rest to zeros again
(:mod:`components.water.tiles`). A checkpoint of the whole grid is therefore mostly zeros: the
reference skip's 1400 x 350 columns are 7.8 MB of heights and velocities, of which a quarter moves on
average. :func:`pack` keeps the blocks of ``tile`` x ``tile`` columns that hold anything but zeros,
in both arrays, and :func:`unpack` puts them back: the same arrays bit for bit, a negative zero
included (a block counts as at rest only when every bit of it is zero), so a run continued from the
checkpoint is the run that made it.
"""

from __future__ import annotations

from typing import Any

import numpy as np

BLOCK = 32  # [columns] a block's side on a pond stepped whole (a tiled one packs by its own tiles)


def _blocks(mask: np.ndarray, ny: int, nx: int, tile: int) -> list[tuple[slice, slice]]:
    """(rows, columns) of each block ``mask`` marks, in row-major order; the last row and column of
    blocks are cut to the grid."""
    return [(slice(j * tile, min((j + 1) * tile, ny)), slice(i * tile, min((i + 1) * tile, nx)))
            for j, i in np.argwhere(mask)]


def pack(h: np.ndarray, v: np.ndarray, tile: int = BLOCK) -> dict[str, Any]:
    """The (ny, nx) float64 arrays ``h`` [m] and ``v`` [m/s] as plain data: the grid's shape, the
    block side, a (ceil(ny / tile), ceil(nx / tile)) uint8 mask of the blocks that hold a non-zero
    bit in either array, and each array's marked blocks, one after the other (row-major within a
    block, blocks in row-major order), as a 1-D float64 array."""
    if h.shape != v.shape or h.ndim != 2 or h.dtype != np.float64 or v.dtype != np.float64:
        raise ValueError(f"pack takes two float64 grids of one shape, got {h.dtype} {h.shape} and {v.dtype} {v.shape}")
    ny, nx = h.shape
    moving = (np.ascontiguousarray(h).view(np.uint64) != 0) | (np.ascontiguousarray(v).view(np.uint64) != 0)
    rows, cols = np.arange(0, ny, tile), np.arange(0, nx, tile)
    mask = np.zeros((len(rows), len(cols)), dtype=np.uint8)
    if moving.size:
        mask[:] = np.logical_or.reduceat(np.logical_or.reduceat(moving, rows, axis=0), cols, axis=1)
    blocks = _blocks(mask, ny, nx, tile)
    return {"shape": [ny, nx], "tile": tile, "mask": mask,
            "h": np.concatenate([h[b].ravel() for b in blocks]) if blocks else np.zeros(0),
            "v": np.concatenate([v[b].ravel() for b in blocks]) if blocks else np.zeros(0)}


def unpack(packed: dict[str, Any], h: np.ndarray, v: np.ndarray) -> None:
    """Write a :func:`pack` result into the grids ``h`` and ``v`` (zeros outside its blocks); a
    ValueError naming what does not fit when it is not a packing of grids of their shape."""
    ny, nx = (int(n) for n in packed["shape"])
    if (ny, nx) != h.shape or h.shape != v.shape:
        raise ValueError(f"the checkpoint's water surface has shape {(ny, nx)}, the grid is {h.shape}")
    tile = int(packed["tile"])
    mask = np.asarray(packed["mask"])
    if tile < 1 or mask.shape != (-(-ny // tile), -(-nx // tile)):
        raise ValueError(f"packed surface: a mask of shape {mask.shape} does not tile {(ny, nx)} by {tile}")
    blocks = _blocks(mask, ny, nx, tile)
    shapes = [(rows.stop - rows.start, cols.stop - cols.start) for rows, cols in blocks]
    hs, vs = np.asarray(packed["h"], dtype=np.float64), np.asarray(packed["v"], dtype=np.float64)
    size = sum(a * b for a, b in shapes)
    if hs.shape != (size,) or vs.shape != (size,):
        raise ValueError(f"packed surface: {hs.size} heights and {vs.size} velocities for {size} columns")
    h[:] = 0.0
    v[:] = 0.0
    at = 0
    for block, shape in zip(blocks, shapes, strict=True):
        n = shape[0] * shape[1]
        h[block] = hs[at:at + n].reshape(shape)
        v[block] = vs[at:at + n].reshape(shape)
        at += n
