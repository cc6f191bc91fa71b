"""The rigid-body scenes run through the real loader and scheduler: ground_bounce, ramp_slide and
spinning_disk (scenarios/*.yaml)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from cosim.scenario import load
from cosim.scheduler import Simulation
from tests.toys import Channels

SCENES = Path(__file__).resolve().parent.parent / "scenarios"


def run(scene_name: str, until: float, *channels: str):
    scene = load(SCENES / f"{scene_name}.yaml")
    watch = Channels(*channels)
    sim = Simulation(scene, observers=[watch])
    result = sim.run(round(until * 1e9))
    assert result.status == "ok", result.reason
    return sim, watch.seen


@pytest.mark.parametrize("name", ["ground_bounce", "ramp_slide", "spinning_disk"])
def test_scene_loads_with_the_body_ground_loop_wired(name):
    """Each scene validates; every ground feeds its body's impulse port through a delayed edge."""
    scene = load(SCENES / f"{name}.yaml")
    delayed = [c for c in scene.connections if c.target_port == "impulse"]
    assert all(c.delay == 1 for c in delayed)
    grounds = [n for n, c in scene.components.items() if c.type_name == "SolidGround"]
    assert len(delayed) == len(grounds)


@pytest.mark.parametrize("setting", ["components.sphere.every=4", "components.floor_sphere.every=2"])
def test_a_ground_stepping_at_another_rate_than_its_body_is_refused(setting):
    """The ground answers each body state with one impulse, which the body applies once: stepping four
    times a body step it answered one state four times, and the summed impulses threw the ball dropped
    from 0.5 m up to 49 m, 0.107 J become 101 J, the run "ok"."""
    from cosim.errors import ScenarioError

    with pytest.raises(ScenarioError) as err:
        load(SCENES / "ground_bounce.yaml", [setting])
    ground, body = (2, 1) if "floor" in setting else (1, 4)
    assert err.value.problems == [
        f"components.floor_sphere: it steps every {ground} base steps and sphere every {body}, but its 'impulse' "
        f"answers each 'body' sphere sends, which takes it as an event (each one applied once): set "
        f"components.floor_sphere.every to {body}"]


def test_ground_bounce_scene():
    """ground_bounce: the flat disk's first rebound reaches e^2 of the drop, the tilted disk is spun up
    by its rim impact, and every body ends at rest on the floor."""
    sim, seen = run("ground_bounce", 3.0, "disk_flat.state", "disk_tilted.state")
    flat = seen["disk_flat.state"]
    up = next(m for _, m in flat if m.velocity[2] > 0)
    apex = up.position[2] + up.velocity[2] ** 2 / (2 * 9.81) - 0.003
    assert apex == pytest.approx(0.49 * 0.1, rel=1e-6)
    spins = [np.linalg.norm(m.angular_velocity) for _, m in seen["disk_tilted.state"]]
    assert max(spins) > 10.0
    pairs = (("disk_flat", "floor_flat"), ("disk_tilted", "floor_tilted"), ("sphere", "floor_sphere"))
    for body, floor in pairs:
        assert np.linalg.norm(sim.components[body].state.angular_velocity) < 1e-9
        assert sim.components[floor].in_contact


def test_ramp_slide_scene():
    """ramp_slide: on 20 degrees the disk holds (drift < 1e-6 m after settling), on 35 degrees it
    slides at g (sin - mu_k cos) within 1%."""
    _, seen = run("ramp_slide", 1.0, "disk_holds.state", "disk_slides.state")
    held = np.array([m.position for _, m in seen["disk_holds.state"][10:]])
    assert np.abs(held - held[0]).max() < 1e-6
    phi = math.radians(35.0)
    down = np.array([math.cos(phi), 0.0, -math.sin(phi)])
    t = np.array([t for t, _ in seen["disk_slides.state"][10:]])
    d = np.array([m.position @ down for _, m in seen["disk_slides.state"][10:]])
    a = 2 * np.polyfit(t, d, 2)[0]
    assert a == pytest.approx(9.81 * (math.sin(phi) - 0.4 * math.cos(phi)), rel=0.01)


def test_spinning_disk_scene():
    """spinning_disk: the pure spinner keeps its 20 degree attitude; the wobbler keeps its energy to
    1e-12 and its axis precesses (its attack angle changes)."""
    _, seen = run("spinning_disk", 1.0, "spinner.state", "wobbler.state")
    assert all(m.attack_angle_deg == pytest.approx(20.0, abs=1e-9) for _, m in seen["spinner.state"])
    energy = np.array([m.kinetic_energy for _, m in seen["wobbler.state"]])
    assert np.ptp(energy) < 1e-12 * energy[0]
    attack = np.array([m.attack_angle_deg for _, m in seen["wobbler.state"]])
    assert np.ptp(attack) > 1.0


def test_a_torque_free_spin_is_said_as_thrown():
    """The wobbler is thrown with ``spin`` 65 rev/s plus a transverse kick (angular_velocity) that has
    a part along its tilted axis: its spin about the axis is 63.9 rev/s from the start, and torque
    free it stays so. The summary says it was thrown at that, not at the ``spin`` setting (it read
    "spin 63.9 rev/s (thrown at 65)", a loss that never happened); without gravity its potential
    energy is 0 J, not "-0 J"."""
    from components.rigid.quaternion import body_axis

    sim, seen = run("spinning_disk", 0.2, "wobbler.state")
    first = seen["wobbler.state"][0][1]
    spin = float(np.dot(first.angular_velocity, body_axis(first.orientation))) / (2 * math.pi)
    assert spin == pytest.approx(63.91, abs=0.01)
    (line,) = sim.components["wobbler"].summary()
    assert line.endswith(f", spin {spin:.3g} rev/s (thrown at {spin:.3g})") and "potential 0 J" in line
