"""Static friction through the step (components.contact.solver, points 3 and 5): a body held on a slope
does not creep under any integrator, and a body that slides to a stop within a step is held from
there by static friction. Each through the real loader and scheduler: one slate disk lying flat on
one SolidGround ramp (mu_s 0.5, mu_k 0.4), 0.5 ms steps."""

from __future__ import annotations

import math

import numpy as np
import pytest

from components.contact.geometry import slope_plane
from components.contact.solver import Material, resolve_contact
from components.messages import Shape
from components.rigid.dynamics import RigidState
from components.rigid.shapes import MassProperties
from cosim.scenario import loads
from cosim.scheduler import Simulation
from tests.ground_toys import disk_on_plane
from tests.toys import Channels

G = 9.81
RADIUS, THICKNESS, DENSITY = 0.05, 0.006, 2700.0
DT = 0.0005


def disk_on_ramp(slope_deg: float, uphill_speed: float = 0.0, integrator: str = "verlet",
                 until: float = 1.0) -> list:
    """The disk's states [(t [s], BodyState)] and the ground's reports, lying flat on a ramp descending
    towards +x, pushed up it at ``uphill_speed`` [m/s]."""
    p = math.radians(slope_deg)
    text = disk_on_plane(dt=DT, until=until, radius=RADIUS, thickness=THICKNESS, density=DENSITY,
                         mu_static=0.5, mu_kinetic=0.4, slope_deg=slope_deg, integrator=integrator,
                         velocity=(-uphill_speed * math.cos(p), 0.0, uphill_speed * math.sin(p)))
    watch = Channels("disk.state", "ground.contact")
    result = Simulation(loads(text, source="ramp"), observers=[watch]).run(round(until * 1e9))
    assert result.status == "ok", result.reason
    return watch.seen["disk.state"], watch.seen["ground.contact"]


@pytest.mark.parametrize("integrator", ["semi_implicit_euler", "verlet", "rk4"])
def test_a_disk_held_by_static_friction_on_a_slope_does_not_creep_under_any_integrator(integrator):
    """On 20 deg (tan 20 = 0.36 < mu_s) the disk sticks and stays where it was put, its energy books
    closed: under semi-implicit Euler it crept downhill at g sin 20 dt / 2 (1.7 mm in 2 s) while the
    ground reported it sticking, its books falling by 0.36 mJ."""
    states, reports = disk_on_ramp(20.0, integrator=integrator, until=2.0)
    settled = np.array([m.position for _, m in states[10:]])
    assert np.abs(settled - settled[0]).max() < 1e-9
    assert not any(r.sliding for _, r in reports[10:])
    books = [m.kinetic_energy + m.potential_energy + r.dissipated_energy
             for (_, m), (_, r) in zip(states[10:], reports[10:], strict=True)]
    assert max(books) - min(books) < 1e-12


@pytest.mark.parametrize("speed", [0.5, 0.503, 1.0])
def test_a_disk_pushed_up_a_slope_it_can_rest_on_stops_and_stays(speed):
    """On 24 deg, tan 24 = 0.445 between mu_k and mu_s, the disk slides up, stops and is held by static
    friction, whatever the speed it was pushed with: where its stop fell within a step so that the
    step ended moving down, mu_k decided, and it slid back down for ever at g (sin 24 - mu_k cos 24)
    (0.38 m/s after 1 s at 0.5 m/s, 0.35 at 1 m/s; at 0.503 m/s it stopped)."""
    states, reports = disk_on_ramp(24.0, speed)
    p = math.radians(24.0)
    stop = speed / (G * (math.sin(p) + 0.4 * math.cos(p)))  # [s] decelerated by gravity and mu_k
    later = [(t, m, r) for (t, m), (_, r) in zip(states, reports, strict=True) if t > stop + 0.01]
    assert later and not any(r.sliding for _, _, r in later)
    up = (-math.cos(p), 0.0, math.sin(p))
    # along the slope, what a step of gravity adds before the ground answers, and no more
    assert max(abs(float(np.dot(m.velocity, up))) for _, m, _ in later) <= G * math.sin(p) * DT * (1 + 1e-9)
    travelled = [float(np.dot(m.position, up)) for _, m, _ in later]
    assert max(travelled) - min(travelled) < 1e-9
    assert travelled[0] == pytest.approx(speed * stop / 2, rel=0.02)  # v0^2 / 2a up the slope


def test_static_friction_decides_once_the_slip_has_turned_round():
    """resolve_contact: a point that slid at the last response and now slips the other way stopped in
    between; mu_s then decides whether it sticks (it does, under a load between mu_k and mu_s), where
    a slip that goes on the same way is judged by mu_k (it slides)."""
    body = MassProperties(Shape.SPHERE, RADIUS, 0.0, DENSITY * 4.0 / 3.0 * math.pi * RADIUS**3,
                          (0.0, 0.0, 0.0))
    plane = slope_plane((0.0, 0.0, 0.0), 0.0, 0.0)
    # resting on the floor, slipping along +x at 1 mm/s, pressed for one step: the stopping impulse
    # M 1e-3 against mu (M g dt) = 0.4 x 4.9e-3 M (mu_k) or 0.5 x 4.9e-3 M (mu_s)
    slip = 0.0022
    state = RigidState((0.0, 0.0, RADIUS - 0.5 * G * DT * DT), (1.0, 0.0, 0.0, 0.0), (slip, 0.0, -G * DT),
                       (0.0, 0.0, 0.0))
    material = Material(restitution=0.0, mu_static=0.5, mu_kinetic=0.4)
    args = (body, state, plane, material, (0.0, 0.0, -G), DT)
    assert resolve_contact(*args, was_sliding=True, rotate=False, slip_before=(1.0, 0.0, 0.0)).sliding
    assert not resolve_contact(*args, was_sliding=True, rotate=False, slip_before=(-1.0, 0.0, 0.0)).sliding
    assert not resolve_contact(*args, was_sliding=False, rotate=False).sliding
