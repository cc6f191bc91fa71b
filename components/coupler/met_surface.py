"""The surface the planing law reads: the water as the body met it.

The pressure law (Rosellini et al. 2005) is written, and its C_L measured, against the undisturbed
surface: the pile-up and the splash the body raises are inside C_L. The ring displacement puts the
body's displaced volume into the height field, which does not see the body, so its waves also run
in under the wetted face; read there, they would wet more of the face and push the water up
against it, lift that C_L already holds (at the magic angle they lowered the critical speed by
about 10%, and by more on finer columns, whose waves are steeper).

So from the step a contact begins until the body is clear of the water again, the surface effects
(pressure, friction, wave drag) read the surface as it was when the body met it: the window it held
then, frozen, and the live surface only for columns that enter the window later. The coupler
requests its window far enough ahead along the motion (``lookahead``) that those are rare. Waves
from elsewhere (an earlier skip, another body) that were there when the body arrived are felt;
those the body makes are felt by its next contact, not by this one. The buoyancy reads the water
where the displaced volume goes, as before.

This is the planing regime: a body moving across the water faster than its own gravity waves. A
floating or slowly moving body is in the waves it radiates, and feels them: the frozen surface is
blended into the live one with :func:`planing_share`.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numba import njit

from components import kernel_cache
from components.messages import BodyState

kernel_cache.install()  # before the cached kernels below: their cache keyed on every kernel source


@njit(cache=True)
def _freeze(i0, j0, height, velocity, mi0, mj0, m_h, m_v, h, v, share, out_h, out_v):
    """h, v (nj, ni) = the live patch at (i0, j0), with the frozen window m_h, m_v at (mi0, mj0)
    over the columns they share; and, when share < 1, out = share * (h, v) + (1 - share) * live.

    Row by row, each row in up to three runs (live, frozen, live) with no test per column, and
    unsigned indices (a signed one that may be negative is wrapped, a select per access that keeps
    a loop from vectorising), so the copies and the blend vectorise."""
    nj, ni = height.shape
    rest = 1.0 - share
    blend = share < 1.0
    ia, ib = max(i0, mi0) - i0, min(i0 + ni, mi0 + m_h.shape[1]) - i0  # the shared columns, patch indices
    ja, jb = max(j0, mj0) - j0, min(j0 + nj, mj0 + m_h.shape[0]) - j0
    ia = max(ia, 0)
    ib = max(min(ib, ni), ia)
    zero, ua, ub, uni = np.uint64(0), np.uint64(ia), np.uint64(ib), np.uint64(ni)
    for j in range(nj):
        live_h, live_v, row_h, row_v = height[j], velocity[j], h[j], v[j]
        if ja <= j < jb and ia < ib:
            met_h = m_h[j + j0 - mj0][ia + i0 - mi0:]  # the frozen row from patch column ia on
            met_v = m_v[j + j0 - mj0][ia + i0 - mi0:]
            for i in range(zero, ua):
                row_h[i] = live_h[i]
                row_v[i] = live_v[i]
            for k in range(zero, ub - ua):
                row_h[ua + k] = met_h[k]
                row_v[ua + k] = met_v[k]
            for i in range(ub, uni):
                row_h[i] = live_h[i]
                row_v[i] = live_v[i]
        else:
            for i in range(zero, uni):
                row_h[i] = live_h[i]
                row_v[i] = live_v[i]
        if blend:
            blend_h, blend_v = out_h[j], out_v[j]
            for i in range(zero, uni):
                blend_h[i] = share * row_h[i] + rest * live_h[i]
                blend_v[i] = share * row_v[i] + rest * live_v[i]


def planing_share(body: BodyState, g: float) -> float:
    """How far ``body`` planes [-]: F^8 / (1 + F^8) of its Froude number F = U / sqrt(2 g R), U its
    horizontal speed: 0 for a floating body, 1 - 1e-3 for a skipping stone at F = 2.4.

    Planing, a body outruns its own gravity waves, and the pressure law with its measured C_L holds
    the water it piles up; floating, it sits in the waves it radiates."""
    vx, vy = float(body.velocity[0]), float(body.velocity[1])
    if g <= 0.0:
        return 1.0
    froude8 = ((vx * vx + vy * vy) / (2.0 * g * float(body.radius))) ** 4
    return froude8 / (1.0 + froude8)


class MetSurface:
    """The water a body met, over the water's grid; held while it is in contact (see the module)."""

    def __init__(self) -> None:
        self.in_contact = False  # the body touched the water and is not yet clear of it
        # (i0, j0, height (nj, ni) [m], velocity (nj, ni) [m/s]) in the water's grid; None: away
        self._met: tuple[int, int, np.ndarray, np.ndarray] | None = None
        self._work: tuple | None = None  # two frozen windows in turn and a blend (_work_arrays)

    def read(self, i0: int, j0: int, height: np.ndarray, velocity: np.ndarray, share: float
             ) -> tuple[np.ndarray, np.ndarray]:
        """The surface [m, m/s] over the patch at (i0, j0) the surface effects read this step:
        the live ``height`` and ``velocity`` while out of contact, else the frozen window (columns
        new to the window live), blended with the live surface by ``share`` (:func:`planing_share`).

        The arrays returned are the surface's own work arrays, valid until the next read."""
        freeze, mi0, mj0, m_h, m_v, h, v, out_h, out_v = self.plan(i0, j0, height, velocity, share)
        if freeze:
            _freeze(i0, j0, height, velocity, mi0, mj0, m_h, m_v, h, v, share, out_h, out_v)
        return out_h, out_v

    def plan(self, i0: int, j0: int, height: np.ndarray, velocity: np.ndarray, share: float) -> tuple:
        """:meth:`read` but for the freeze itself, for a compiled step that makes the surface in its
        own call (:func:`components.coupler.step_kernel.met_ring_step`): (freeze, mi0, mj0, m_h, m_v,
        fr_h, fr_v, met_h, met_v), the arguments of :func:`_freeze` (met_h, met_v its blend, written
        when ``share`` < 1, else fr_h, fr_v themselves) and the arrays the surface effects then read.
        Out of contact freeze is False and met_h, met_v are the live ``height`` and ``velocity``
        (the other arrays are the same two, unused). The state moves on as if the freeze were done,
        so it must follow before the next call."""
        met = self._met
        if not self.in_contact or met is None:
            self._met = (i0, j0, height, velocity)
            return False, i0, j0, height, velocity, height, velocity, height, velocity
        mi0, mj0, m_h, m_v = met
        (h, v), blend = self._work_arrays(height.shape, m_h)
        self._met = (i0, j0, h, v)
        out_h, out_v = blend if share < 1.0 else (h, v)
        return True, mi0, mj0, m_h, m_v, h, v, out_h, out_v

    def _work_arrays(self, shape: tuple[int, int], held: np.ndarray):
        """A pair of (nj, ni) arrays for this step's frozen window that are not ``held`` (the one
        kept from last step, read while the new one is written), and a pair for the blend."""
        work = self._work
        if work is None or work[0][0].shape != shape:
            work = self._work = tuple((np.empty(shape), np.empty(shape)) for _ in range(3))
        frozen = work[0] if work[0][0] is not held else work[1]
        return frozen, work[2]

    def get_state(self) -> dict[str, Any]:
        met = self._met
        return {"in_contact": self.in_contact,
                "met": None if met is None else [met[0], met[1], met[2].copy(), met[3].copy()]}

    def set_state(self, state: dict[str, Any]) -> None:
        self.in_contact = bool(state.get("in_contact", False))
        met = state.get("met")
        self._met = None if met is None else (int(met[0]), int(met[1]), np.array(met[2], dtype=float),
                                              np.array(met[3], dtype=float))
