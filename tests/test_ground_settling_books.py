"""A disk that rocks on its rim and then settles onto its face: its books close through the settle.

While it rocks, each rim step lifts the disk only as far as its impulse's energy pays, so it comes onto
its face sunk into the plane. Lying on its face it is lifted out; that lift gives back the potential
energy the rim steps booked as dissipated, and is booked so (it was taken for the integrator's own fall
beyond a Verlet step: the disk gained 0.46 mJ in one response and kinetic + potential + dissipated rose
by as much, the energy books of ground_bounce's tilted disk by 1.9e-5 J)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from components.rigid import quaternion as quat
from cosim.scenario import load, loads
from cosim.scheduler import Simulation
from tests.toys import Channels

SCENES = Path(__file__).resolve().parent.parent / "scenarios"
RADIUS, THICKNESS = 0.05, 0.006  # [m]

_DROP = """
name: settle
dt: 0.0005
until: 0.3
on_unstable: error
components:
  b: {type: RigidBody, shape: disk, radius: 0.05, thickness: 0.006, density: 2700, integrator: {integrator},
      position: [0, 0, 0.1], tilt_deg: 70, tilt_axis: [1, 0, 0]}
  g: {type: SolidGround, restitution: 0.3, mu_static: 0.5, mu_kinetic: 0.4}
connections:
  - b.state -> g.body
  - {from: g.impulse, to: b.impulse, delay: 1, initial: {linear: [0,0,0], angular: [0,0,0], correction: [0,0,0]}}
"""


def _books(states, contacts) -> np.ndarray:
    """Kinetic + potential energy of each state after the first, plus the ground's dissipation booked
    by then [J]."""
    return np.array([states[k].kinetic_energy + states[k].potential_energy + contacts[k - 1].dissipated_energy
                     for k in range(1, len(states))])


def _lowest(state) -> float:
    """The height [m] of the disk's lowest point."""
    az = abs(quat.body_axis(tuple(state.orientation))[2])
    return state.position[2] - 0.5 * THICKNESS * az - RADIUS * math.sqrt(max(0.0, 1.0 - az * az))


@pytest.mark.parametrize("integrator", ["verlet", "rk4"])
def test_a_disk_settling_from_its_rim_onto_its_face_keeps_its_books_and_rests_on_the_plane(integrator):
    """Dropped from 10 cm tilted 70 deg: it bounces, rocks on its rims and settles on its face. Under
    gravity alone the energy the ground books as dissipated is exactly what the disk lost, to round-off,
    at every step; and it ends lying on the plane (its lowest point one step's fall in), not sunk by its
    rocking."""
    watch = Channels("b.state", "g.contact")
    result = Simulation(loads(_DROP.replace("{integrator}", integrator), source="settle"), observers=[watch]).run()
    assert result.status == "ok"
    states = [m for _, m in watch.seen["b.state"]]
    contacts = [m for _, m in watch.seen["g.contact"]]
    books = _books(states, contacts)
    assert np.max(np.abs(books - books[0])) < 1e-12
    sunk = [-_lowest(s) for s in states]
    assert max(sunk) > 1e-4  # it did sink on its rims (the case this is about)
    assert abs(_lowest(states[-1])) <= 0.5 * 9.81 * 0.0005**2 * (1 + 1e-6)


def test_ground_bounces_tilted_disk_keeps_its_books():
    """scenarios/ground_bounce.yaml's tilted disk settles the same way (at 0.529 s): its books hold."""
    watch = Channels("disk_tilted.state", "floor_tilted.contact")
    result = Simulation(load(SCENES / "ground_bounce.yaml", ["until=1.0"]), observers=[watch]).run()
    assert result.status == "ok"
    books = _books([m for _, m in watch.seen["disk_tilted.state"]],
                   [m for _, m in watch.seen["floor_tilted.contact"]])
    assert np.max(np.abs(books - books[0])) < 1e-12
