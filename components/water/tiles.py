"""Stepping the explicit wave model by tiles: water at rest costs nothing until a wave reaches it.

The grid is cut into square tiles of ``tile`` x ``tile`` cells (the last row and column of tiles
may be narrower). A tile is *at rest* when every one of its columns has h = 0 and v = 0 exactly.
On a uniform bed with no input, the explicit step of :class:`components.water.models.WaveModel`
maps a cell at rest whose four neighbours are at rest to exactly (0, 0) (the Laplacian of zeros is
0, so v' = (0 + kdt 0) damp = 0 and h' = 0 + dt 0 = 0), so a tile at rest whose four neighbouring
tiles are at rest can be left as it is.

The explicit step carries a vanishing precursor ahead of every wavefront, one column per step
(down to 1e-300 m), and on slow water most of the tiles it reaches hold nothing else. A stepped
tile whose every column moves by at most ``rest`` (|h| [m] and |v| [m/s]) is therefore set to
zeros and rests. The default, 1e-30 m (WaterParams.rest_below), is eleven orders of magnitude
below the round-off of a millimetre wave's heights, and a whole tile of 1 cm columns at that
height holds 1e-31 m^3, beneath the round-off of any pond's volume. With ``rest`` = 0 only exact
zeros rest, and the result is the dense step's, bit for bit.

What makes a tile active, per step from state n to n + 1 (``plan``):

- it or one of its four neighbours holds a non-zero column in state n (the stencil reads the four
  neighbours only, so diagonal tiles never matter);
- or its spare buffer is not all zeros: the step writes state n + 1 into the buffers that hold
  state n - 1 (ping-pong), and a skipped tile must find zeros there. That is exactly "the tile was
  not at rest in state n - 1", so the flags of the previous state decide it;
- a body's displacement or a state set from outside marks the tiles it writes (:meth:`touch`,
  :meth:`reset`).

The step kernel writes the new columns of the tiles it steps and, row by row while the row is in
cache, whether each of them holds anything but zeros. A boundary that rewrites the edge cells
afterwards (absorbing) visits only the tiles that may hold moving water, those stepped and the
eight around each (:meth:`moving`), and has those along the edges scanned again
(:meth:`rescan_edges`).

Only the explicit ``wave`` model on a uniform grid (all wet, one wave speed: a flat bed, or a sloped
one under a set ``wave_speed`` or ``wave_length``) is stepped this way: the implicit ``shallow_water``
model couples whole rows and columns in each solve (a disturbance reaches every cell of its row in one
step), ``airy`` transforms the whole grid, and positional smoothing and a bed whose waves run at its
depth's speed, or that dries, keep the dense path (:func:`tiling_applies` says which).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from components import kernel_cache
from components.water.kernels_numba import wave_uniform_span

kernel_cache.install()  # before the cached kernels below: their cache keyed on every kernel source

REST_BELOW = 1e-30  # [m] a stepped tile moving by no more than this rests (see above)
DEFAULT_TILE = 32  # cells per tile side: 8 KiB of each array per tile, a wake is followed to within 32 cm at 1 cm


def tiling_applies(*, tile: int, model: str, uniform: bool, smoothing: float, backend: str,
                   parallel: bool) -> bool:
    """Whether a water surface with these settings is stepped by tiles (else the dense path).

    Tiles need the explicit model on a uniform grid (exactness rests on the uniform stencil), no
    positional smoothing, and the compiled serial kernels (the numpy kernels are the reference, the
    parallel set splits rows, not tiles).
    """
    return tile > 0 and model == "wave" and uniform and smoothing == 0.0 and backend == "numba" and not parallel


@njit(cache=True)
def _plan(nz, nz_prev, step):  # pragma: no cover - compiled
    # step = nz dilated by its four neighbours, or nz_prev (the spare buffer's tile not all zero)
    nty, ntx = nz.shape
    count = 0
    for tj in range(nty):
        for ti in range(ntx):
            on = nz[tj, ti] or nz_prev[tj, ti]
            if not on and ti > 0:
                on = nz[tj, ti - 1]
            if not on and ti < ntx - 1:
                on = nz[tj, ti + 1]
            if not on and tj > 0:
                on = nz[tj - 1, ti]
            if not on and tj < nty - 1:
                on = nz[tj + 1, ti]
            step[tj, ti] = on
            count += on
    return count


@njit(cache=True)
def _dilate8(step, near):  # pragma: no cover - compiled
    # near = step dilated by its eight neighbours
    nty, ntx = step.shape
    near[:, :] = False
    for tj in range(nty):
        for ti in range(ntx):
            if step[tj, ti]:
                near[max(tj - 1, 0):tj + 2, max(ti - 1, 0):ti + 2] = True


@njit(cache=True)
def _wave_tiles(h, v, h_out, v_out, kdt, dt, damp, step, tile, nz_out, rest):  # pragma: no cover - compiled
    # Rows run outermost, and each run of neighbouring stepped tiles along a row is one span of the
    # dense step's own row kernel (kernels_numba.wave_uniform_span), so the stepped tiles hold the
    # dense step's bits; whether a tile holds a column moving by more than ``rest`` (|h| [m] or
    # |v| [m/s]; 0: anything but zeros) is read back from the row just written (in cache), stopping
    # at the first such column. A stepped tile with none is set to zeros: it rests.
    ny, nx = h.shape
    nty, ntx = step.shape
    for tj in range(nty):
        j0 = tj * tile
        j1 = min(j0 + tile, ny)
        busy = False
        for ti in range(ntx):
            nz_out[tj, ti] = False
            busy = busy or step[tj, ti]
        if not busy:
            continue
        for j in range(j0, j1):
            hc = h[j]
            hs = h[j - 1] if j > 0 else hc
            hn = h[j + 1] if j < ny - 1 else hc
            vc = v[j]
            ho = h_out[j]
            vo = v_out[j]
            ti = 0
            while ti < ntx:
                if not step[tj, ti]:
                    ti += 1
                    continue
                run_end = ti
                while run_end < ntx and step[tj, run_end]:
                    run_end += 1
                wave_uniform_span(hc, hs, hn, vc, ho, vo, ti * tile, min(run_end * tile, nx), kdt, dt, damp)
                for t in range(ti, run_end):
                    if nz_out[tj, t]:
                        continue
                    for i in range(t * tile, min(t * tile + tile, nx)):
                        # written so that a NaN counts as moving, never as at rest
                        if not (abs(ho[i]) <= rest and abs(vo[i]) <= rest):
                            nz_out[tj, t] = True
                            break
                ti = run_end
        if rest > 0.0:
            for ti in range(ntx):
                if step[tj, ti] and not nz_out[tj, ti]:
                    i0 = ti * tile
                    i1 = min(i0 + tile, nx)
                    h_out[j0:j1, i0:i1] = 0.0
                    v_out[j0:j1, i0:i1] = 0.0


@njit(cache=True)
def _any_nonzero(h, v, j0, j1, i0, i1):  # pragma: no cover - compiled
    for j in range(j0, j1):
        for i in range(i0, i1):
            if h[j, i] != 0.0 or v[j, i] != 0.0:
                return True
    return False


@njit(cache=True)
def _scan(h, v, tile, nz):  # pragma: no cover - compiled
    # nz[t] = tile t holds a non-zero column
    ny, nx = h.shape
    nty, ntx = nz.shape
    for tj in range(nty):
        for ti in range(ntx):
            nz[tj, ti] = _any_nonzero(h, v, tj * tile, min(tj * tile + tile, ny), ti * tile,
                                      min(ti * tile + tile, nx))


@njit(cache=True)
def _sums(h, v, tile, step):  # pragma: no cover - compiled
    # Over the tiles marked in ``step`` (those not at rest and their neighbours): sum h, sum v^2 and
    # the sums of squared differences across the east and north faces of their cells. Every face
    # with a non-zero side belongs (as its west or south cell's east or north face) to a marked tile.
    ny, nx = h.shape
    nty, ntx = step.shape
    sh = 0.0
    sv = 0.0
    sdx = 0.0
    sdy = 0.0
    for tj in range(nty):
        for ti in range(ntx):
            if not step[tj, ti]:
                continue
            for j in range(tj * tile, min(tj * tile + tile, ny)):
                for i in range(ti * tile, min(ti * tile + tile, nx)):
                    c = h[j, i]
                    sh += c
                    sv += v[j, i] * v[j, i]
                    if i + 1 < nx:
                        d = h[j, i + 1] - c
                        sdx += d * d
                    if j + 1 < ny:
                        d = h[j + 1, i] - c
                        sdy += d * d
    return sh, sv, sdx, sdy


@njit(cache=True)
def _rescan_edges(h, v, tile, nz, only, band):  # pragma: no cover - compiled
    # After a boundary rewrote the cells within ``band`` of the grid's edges: the flags of the tiles
    # marked in ``only`` that reach into that band. A tile flagged moving is scanned whole (the
    # boundary may have brought it to rest); one flagged at rest held only zeros before the boundary,
    # which changed only the band, so its band cells alone decide.
    ny, nx = h.shape
    nty, ntx = nz.shape
    for tj in range(nty):
        j0 = tj * tile
        j1 = min(j0 + tile, ny)
        edge_row = j0 < band or j1 > ny - band
        for ti in range(ntx):
            i0 = ti * tile
            i1 = min(i0 + tile, nx)
            if not only[tj, ti] or not (edge_row or i0 < band or i1 > nx - band):
                continue
            if nz[tj, ti]:
                nz[tj, ti] = _any_nonzero(h, v, j0, j1, i0, i1)
                continue
            # the band's part of the tile: its rows near the bottom and top edges, then its columns
            # near the left and right edges
            found = (_any_nonzero(h, v, j0, min(j1, band), i0, i1)
                     or _any_nonzero(h, v, max(j0, ny - band), j1, i0, i1)
                     or _any_nonzero(h, v, j0, j1, i0, min(i1, band))
                     or _any_nonzero(h, v, j0, j1, max(i0, nx - band), i1))
            nz[tj, ti] = found


class Tiles:
    """Which tiles of an (ny, nx) grid are at rest, and the tiled wave step.

    ``nz``: (nty, ntx) bool, tile holds a non-zero column in the current state; ``nz_prev`` the
    same for the state before (the one the spare buffers hold); counters of stepped tiles for the
    run's summary.
    """

    def __init__(self, shape: tuple[int, int], tile: int, rest: float = 0.0):
        ny, nx = shape
        self.tile = tile
        self.rest = rest  # a stepped tile whose every column moves by at most this rests (0: only zeros)
        self.shape = shape
        self.nty = -(-ny // tile)
        self.ntx = -(-nx // tile)
        grid = (self.nty, self.ntx)
        self.nz = np.zeros(grid, dtype=np.bool_)
        self.nz_prev = np.zeros(grid, dtype=np.bool_)
        self._nz_next = np.zeros(grid, dtype=np.bool_)
        self._step = np.zeros(grid, dtype=np.bool_)
        self._marked = np.zeros(grid, dtype=np.bool_)
        self._near = np.zeros(grid, dtype=np.bool_)
        self._near_done = False  # _near holds the dilation of the last step's tiles
        self._all_rest = np.zeros(grid, dtype=np.bool_)
        self.steps = 0  # tiled steps taken
        self.stepped = 0  # tiles stepped, summed over those steps
        self.peak = 0  # most tiles stepped in one step
        self.last = 0  # tiles stepped in the last step

    @property
    def count(self) -> int:
        """Number of tiles."""
        return self.nty * self.ntx

    def reset(self, h: np.ndarray, v: np.ndarray) -> None:
        """Flags of a state (h, v) given from outside, whose spare buffers hold zeros."""
        _scan(h, v, self.tile, self.nz)
        self.nz_prev[:] = False

    def touch(self, i0: int, i1: int, j0: int, j1: int) -> None:
        """Cells [j0:j1, i0:i1] were written from outside (a body's displacement): their tiles step."""
        if i0 >= i1 or j0 >= j1:
            return
        t = self.tile
        self.nz[j0 // t:(j1 - 1) // t + 1, i0 // t:(i1 - 1) // t + 1] = True

    def wave_step(self, h: np.ndarray, v: np.ndarray, h_out: np.ndarray, v_out: np.ndarray,
                  kdt: float, dt: float, damp: float) -> None:
        """The uniform wave step (see :meth:`components.water.models.WaveModel.advance`) of the
        tiles not at rest, into (h_out, v_out); the other tiles of h_out, v_out already hold zeros.
        A stepped tile whose every column then moves by at most ``rest`` is set to zeros."""
        n = int(_plan(self.nz, self.nz_prev, self._step))
        _wave_tiles(h, v, h_out, v_out, kdt, dt, damp, self._step, self.tile, self._nz_next, self.rest)
        self._near_done = False
        self.steps += 1
        self.stepped += n
        self.peak = max(self.peak, n)
        self.last = n

    def moving(self) -> tuple[np.ndarray, int]:
        """The tiles that may hold moving water around the last :meth:`wave_step`: those it stepped
        and the eight around each ((nty, ntx) bool), and the tiles' side [cells]. Every other tile
        was at rest before the step and is after it, and so is every tile around it, so a boundary
        condition reading a cell and the cells next to it (an edge cell, its inner neighbour and, at
        a corner, the one diagonally inside) finds only zeros there and leaves zeros."""
        if not self._near_done:
            _dilate8(self._step, self._near)
            self._near_done = True
        return self._near, self.tile

    def rescan_edges(self, h: np.ndarray, v: np.ndarray, band: int) -> None:
        """After a boundary rewrote the cells within ``band`` cells of the edges of (h, v), the new
        state: the flags of the edge tiles that may hold moving water (:meth:`moving`: an edge
        condition may write into a tile beside a stepped one) are read again."""
        _rescan_edges(h, v, self.tile, self._nz_next, self.moving()[0], max(band, 1))

    def finish_step(self) -> None:
        """The new state becomes the current one: its flags too."""
        self.nz_prev, self.nz, self._nz_next = self.nz, self._nz_next, self.nz_prev

    def sums(self, h: np.ndarray, v: np.ndarray) -> tuple[float, float, float, float]:
        """(sum h [m], sum v^2 [m^2/s^2], sum of (h_east - h)^2 and of (h_north - h)^2 over faces
        [m^2]) of the current state (h, v), read from the tiles not at rest and their neighbours
        only: the whole grid's sums up to the order of the additions (round-off)."""
        _plan(self.nz, self._all_rest, self._marked)
        return _sums(h, v, self.tile, self._marked)

    def active_fraction(self) -> float:
        """Fraction of the tiles stepped in the last step (0 before the first)."""
        return self.last / self.count

    def mean_fraction(self) -> float:
        """Mean fraction of the tiles stepped per step (0 before the first)."""
        return self.stepped / (self.steps * self.count) if self.steps else 0.0

    def peak_fraction(self) -> float:
        """Largest fraction of the tiles stepped in one step."""
        return self.peak / self.count

    def get_state(self) -> dict[str, int]:
        return {"steps": self.steps, "stepped": self.stepped, "peak": self.peak, "last": self.last}

    def set_state(self, state: dict[str, int]) -> None:
        for key in ("steps", "stepped", "peak", "last"):
            setattr(self, key, int(state.get(key, 0)))
