"""A disk pitching into the water drives both its faces into it: each face's planing load keeps its sum.

The planing law, 1/2 rho C_L |u| (u.n) on each wetted element moving into the water (C_L = 1), summed
over a fine mesh of both faces and the rim, is the force the coupler's pressure effect must give: the
spray root only moves where a face's load acts. With both faces advancing, their loads push opposite
ways; spread and scaled together, the sum of their sizes was kept instead of the force (8.0 N where the
law gives 0.8 N for a disk pitching at 60 rad/s; +0.28 N up where it gives -0.43 N for one pitching
nose down at 10 rad/s)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from components.coupler import WaterCoupler, WaterCouplerParams
from components.coupler.fixtures import axis_angle, body, still_water
from components.coupler.geometry import quat_to_matrix

R, E, RHO = 0.05, 0.006, 1000.0  # [m, m, kg/m^3]


def _law_summed(pos: np.ndarray, q: np.ndarray, v: np.ndarray, w: np.ndarray, n: int = 500, n_rim: int = 1500,
                n_height: int = 40) -> np.ndarray:
    """The planing law's force [N] on the disk at ``pos`` with orientation ``q``, velocity ``v`` and
    angular velocity ``w`` (its spin about the axis left out, as the law leaves it) over still water at
    0: summed over an n x n mesh of each face and an n_rim x n_height mesh of the rim."""
    axes = quat_to_matrix(q)
    axis = axes[:, 2]
    w = w - (w @ axis) * axis
    force = np.zeros(3)

    def push(points: np.ndarray, normals: np.ndarray, areas: float) -> np.ndarray:
        u = v + np.cross(w, points)
        un = (u * normals).sum(axis=1)
        p = np.where((points[:, 2] + pos[2] < 0.0) & (un > 0.0), 0.5 * RHO * np.linalg.norm(u, axis=1) * un, 0.0)
        return -(p[:, None] * normals).sum(axis=0) * areas

    grid = (np.arange(n) + 0.5) / n * 2 * R - R
    x, y = np.meshgrid(grid, grid)
    inside = x * x + y * y <= R * R
    x, y = x[inside], y[inside]
    for side in (1.0, -1.0):
        points = np.stack([x, y, np.full_like(x, side * E / 2)], axis=1) @ axes.T
        force += push(points, np.tile(side * axis, (len(x), 1)), (2 * R / n) ** 2)
    phi, z = np.meshgrid((np.arange(n_rim) + 0.5) / n_rim * 2 * math.pi,
                         (np.arange(n_height) + 0.5) / n_height * E - E / 2)
    normals = np.stack([np.cos(phi), np.sin(phi), 0 * phi], axis=-1).reshape(-1, 3) @ axes.T
    points = np.stack([R * np.cos(phi), R * np.sin(phi), z], axis=-1).reshape(-1, 3) @ axes.T
    return force + push(points, normals, R * (2 * math.pi / n_rim) * (E / n_height))


@pytest.mark.parametrize(("tilt_deg", "depth", "velocity", "pitch_rate"), [
    (10.0, 0.012, (3.0, 0.0, -0.3), 0.0),     # one face advancing: as before
    (10.0, 0.012, (3.0, 0.0, -0.3), 20.0),
    (10.0, 0.012, (3.0, 0.0, -0.3), 40.0),
    (10.0, 0.012, (3.0, 0.0, -0.3), 60.0),    # the faces' loads nearly cancel
    (-10.0, 0.010, (3.0, 0.0, -0.5), -10.0),  # nose down: the vertical force's sign
    (-5.0, 0.010, (3.0, 0.0, -0.5), -10.0),
])
def test_the_pressure_on_a_disk_with_both_faces_advancing_is_the_law_summed(tilt_deg, depth, velocity, pitch_rate):
    q = axis_angle((0.0, -1.0, 0.0), math.radians(tilt_deg))  # positive tilt: the nose (+x edge) up
    axis = quat_to_matrix(q)[:, 2]
    # its lowest point `depth` under the water
    pos = np.array([0.0, 0.0, R * math.sqrt(1.0 - axis[2] ** 2) + 0.5 * E * abs(axis[2]) - depth])
    v, w = np.array(velocity), np.array([0.0, pitch_rate, 0.0])
    stone = body(position=tuple(pos), orientation=q, velocity=tuple(v), angular_velocity=tuple(w), radius=R,
                 thickness=E)
    coupler = WaterCoupler("c", WaterCouplerParams(effects=["pressure"]))
    force = coupler.step(0, 1000, {"body": stone, "water": still_water(0.005, half_width=0.2)})["wrench"].force
    exact = _law_summed(pos, q, v, w)
    assert np.abs(force - exact).max() < 0.04  # [N] of face loads of 3-5 N each; wrong by 0.7-7 N before
