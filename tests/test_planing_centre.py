"""Where the planing pressure acts on a disk's face does not depend on how the face's tiling lies.

A spinning stone's face turns under the water at every contact, so its tiling (16 x 16 squares) lies
at every angle against the waterline. The planing load's centre decides the torque, and with the
spin the torque decides the attitude (precession), so a centre that moved with the tiling would turn
the stone by the tiling, not by the water. Here the disk of the reference skip (R = 5 cm, e = 15 mm,
8 deg of attack) planes over still water at 10 m/s; its face is turned about its own axis by 0 to
45 deg, and the pressure's centre, from the coupler's wrench, is held against the same load law
summed exactly over the wetted segment (a 1500 x 1500 sampling of the face): within 0.5 mm along the
flow and across it, once the trailing edge is 1 mm under (0.31 and 0.08 mm at 1 mm, 0.06 and 0.01 mm
at 8 mm). With each square's load at its centroid, weighted by its centroid's place, and each
clipped square wetted as a whole square about its centroid, it was off by up to 2.8 mm along the
flow and 2.3 mm across at 1 mm (0.8 and 0.1 mm at 8 mm), and the throw of scenarios/skip.yaml turned
by 45 deg about its axis took off its second skip at 7.6 deg instead of 13.1
(tests/test_throw_symmetry.py)."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from components.coupler import WaterCoupler, WaterCouplerParams
from components.coupler.fixtures import axis_angle, body, disk_at_depth, pitched, still_water
from components.coupler.geometry import quat_to_matrix
from components.coupler.kernel import SPRAY_ROOT_POWER
from components.rigid import quaternion

R = 0.05  # [m]
E = 0.015  # [m]
ATTACK = math.radians(8.0)
VELOCITY = (10.0, 0.0, -1.0)  # [m/s]
G = 9.81


def turned(phase: float) -> np.ndarray:
    """The pitched disk's orientation with its face first turned by ``phase`` [rad] about its axis."""
    return np.array(quaternion.mul(tuple(pitched(ATTACK)), tuple(axis_angle((0.0, 0.0, 1.0), phase))))


def lower_face_points(n: int = 1500) -> np.ndarray:
    """A fine sampling of the lower face in the body frame, (M, 3) [m]."""
    g = (np.arange(n) + 0.5) / n * 2 * R - R
    x, y = np.meshgrid(g, g)
    inside = x * x + y * y <= R * R
    return np.column_stack([x[inside], y[inside], np.full(int(inside.sum()), -0.5 * E)])


POINTS = lower_face_points()


def exact_centre(q: np.ndarray, depth: float) -> tuple[np.ndarray, float]:
    """The load's centre (horizontal, relative to the disk's centre) [m] and the lowest point's
    height below the centre: the planing pressure even over the wetted face but for the spray
    root's weight (1 - f) + f (p + 1) xi^p, xi from the trailing edge (0) to the waterline (1)."""
    world = POINTS @ quat_to_matrix(q).T
    low = world[:, 2].min()
    wet = world[:, 2] <= low + depth
    xi = (world[wet, 2] - low) / depth
    vx, vy, vz = VELOCITY
    f = (vx * vx + vy * vy) / (vx * vx + vy * vy + vz * vz + 2 * G * R)
    w = (1 - f) + f * (SPRAY_ROOT_POWER + 1) * xi ** SPRAY_ROOT_POWER
    return (w[:, None] * world[wet, :2]).sum(0) / w.sum(), low


def model_centre(q: np.ndarray, depth: float, low: float) -> np.ndarray:
    """The pressure's centre (horizontal, relative to the centre) [m] from the coupler's wrench: the
    point r (at the face's height there) with r x F = T."""
    b = body(position=(0.0, 0.0, -depth - low), orientation=q, velocity=VELOCITY, radius=R, thickness=E)
    c = WaterCoupler("c", WaterCouplerParams(effects=["pressure"]))
    out = c.step(0, 1000, {"body": b, "water": still_water(0.01)})
    force, torque = out["wrench"].force, out["wrench"].torque
    # r = (x, y, z(x, y)) on the lower face's plane through its centre: n . r = -E/2
    n = quat_to_matrix(q)[:, 2]
    # torque = r x F is linear in (x, y) once z is the plane's: solve the horizontal pair
    a = np.zeros((3, 2))
    for k, unit in enumerate(np.eye(3)[:2]):
        slope = -unit @ n / n[2]
        a[:, k] = np.cross(unit + slope * np.array([0.0, 0.0, 1.0]), force)
    offset = np.cross(np.array([0.0, 0.0, -0.5 * E / n[2]]), force)
    solution, *_ = np.linalg.lstsq(a, torque - offset, rcond=None)
    return solution


@pytest.mark.parametrize("depth", [0.001, 0.002, 0.004, 0.008])
def test_the_planing_centre_does_not_turn_with_the_tiling(depth):
    along, across = [], []
    for phase_deg in (0.0, 7.5, 15.0, 22.5, 30.0, 37.5, 45.0):
        q = turned(math.radians(phase_deg))
        exact, low = exact_centre(q, depth)
        model = model_centre(q, depth, low)
        along.append(model[0] - exact[0])
        across.append(model[1] - exact[1])
    assert np.abs(along).max() < 5e-4, f"along the flow, mm: {np.round(1e3 * np.array(along), 2)}"
    assert np.abs(across).max() < 5e-4, f"across the flow, mm: {np.round(1e3 * np.array(across), 2)}"


@pytest.mark.parametrize(("x", "sx", "sy"), [(0.3, 0.8, 0.6), (0.9, -0.28, 0.96), (0.1, 1.0, 0.0)])
def test_a_whole_square_wholly_under_sums_its_pieces_in_closed_form(x, sx, sy):
    """The closed form of the spray root's weight over a whole square's pieces (kernel._grid_moments)
    is the sum over the pieces one by one (kernel._pieces_weight): mean weight and where it acts. (A
    whole square wholly under lies within the wetted area's extent, so none of its pieces' places is
    clipped to 0 or 1, which the closed form does not do.)"""
    from components.coupler.geometry import FACE_SUBDIVISION, disk_elements
    from components.coupler.kernel import _binomial, _grid_moments, _pieces_weight

    el = disk_elements(R, E)
    k = int(np.flatnonzero(el.whole)[0])
    side, span, forward, p = el.t1[k, 0], 0.03, 0.9, SPRAY_ROOT_POWER
    a, b = sx / span, sy / span
    looped = _pieces_weight(el.sub, k, 1.0, 1e-3, 1e-3, x, a, b, 0.0, 0.0, 5e-4, forward)
    pitch = side / FACE_SUBDIVISION
    even, odd_u, odd_v = np.zeros(p + 1), np.zeros(p + 1), np.zeros(p + 1)
    _grid_moments(pitch * a, pitch * b, even, odd_u, odd_v)
    c = np.array([_binomial(p, j) * x ** (p - j) for j in range(p + 1)])
    mean_w = (1 - forward) + forward * (p + 1) * (c @ even)
    lever = forward * (p + 1) * pitch / mean_w
    closed = (mean_w, lever * (c @ odd_u), lever * (c @ odd_v))
    np.testing.assert_allclose(closed, looped, rtol=1e-9, atol=1e-15)


def _load_centre(orientation: np.ndarray, z: float = 0.002) -> tuple[float, float, float]:
    """(x, y) [mm] of the planing load's centre and its force [N] on a 6 mm disk moving at (3, 0, -1)
    m/s whose centre is ``z`` [m] over still water of 5 mm columns (the pressure alone)."""
    b = body(position=(0.0, 0.0, z), orientation=orientation, velocity=(3.0, 0.0, -1.0), thickness=0.006)
    out = WaterCoupler("c", WaterCouplerParams(effects=["pressure"])).step(
        0, 100_000, {"body": b, "water": still_water(cell=0.005, half_width=0.2)})
    f, t = out["wrench"].force, out["wrench"].torque
    return -t[1] / f[2] * 1e3, t[0] / f[2] * 1e3, float(f[2])


def test_the_planing_load_moves_smoothly_as_a_level_disk_tilts():
    """A level face meets the water along the flow; a tilted one along its lean (from its lowest point
    to its centre). The load's centre jumped between the two at the smallest tilt: 26 mm ahead of
    the centre level, 26 mm behind it pitched 1e-7 rad nose down, 26 mm to the side rolled 1e-6 rad
    (and a flat throw bounced or sank on a 1e-5 deg difference of its tilt). Now the same to 1e-3 mm
    within a microradian of level, and it moves by less than 10 mm a 0.1 deg step of pitch from 6 deg
    nose down to 6 deg nose up, the lowest point 1 mm under (8.9 mm where the face's wetted part
    shrinks from the whole face to a segment as it tilts, 52 mm at level before)."""
    level = _load_centre(pitched(0.0))
    assert level[0] == pytest.approx(25.9, abs=0.1) and abs(level[1]) < 1e-9
    for near in (pitched(-1e-7), pitched(1e-7), axis_angle((1.0, 0.0, 0.0), -1e-6), axis_angle((1.0, 0.0, 0.0), 1e-6)):
        x, y, force = _load_centre(near)
        assert (x, y) == pytest.approx(level[:2], abs=1e-3)
        assert force == pytest.approx(level[2], rel=1e-5)
    centres = []
    for deg in np.arange(-6.0, 6.05, 0.1):
        attack = math.radians(deg)
        centres.append(_load_centre(pitched(attack), disk_at_depth(0.001, abs(attack))[2])[0])
    assert max(abs(b - a) for a, b in itertools.pairwise(centres)) < 10.0
    assert centres[0] > 25.0 and centres[-1] < -25.0  # nose down: the load ahead; nose up: behind
