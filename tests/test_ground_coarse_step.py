"""A ground at steps coarser than the scenes': a disk settling onto its face rests (no endless rock
from rim to rim), and a step in which the body falls through half its height is refused at load."""

from __future__ import annotations

import math
import subprocess
from pathlib import Path

import numpy as np
import pytest

from components.contact.solver import Material, face_tolerance
from components.messages import BodyState
from cosim.scenario import ScenarioError, load
from cosim.scheduler import Simulation
from tests.toys import Channels

SCENES = Path(__file__).resolve().parent.parent / "scenarios"
G = 9.81


def _tilt_deg(q: np.ndarray) -> float:
    """The angle [deg] of a body's axis from the vertical, for its orientation q (w, x, y, z)."""
    _, x, y, _ = q
    return math.degrees(2.0 * math.asin(min(1.0, math.hypot(x, y) / math.hypot(*q))))


@pytest.mark.parametrize("dt", [0.0025, 0.005])
def test_a_tilted_disk_dropped_at_coarse_steps_comes_to_rest_flat(dt):
    """ground_bounce's tilted disk at 5 and 10 times the scene's step: after 3 s it lies on its face
    (its rims within one step's rock, 2 g dt^2, of each other), does not turn, and its published speed
    is the one step of gravity the ground answers (g dt), not a rock from rim to rim (before: at
    2.5 ms it rocked for ever at 1 rad/s, reporting 3 g dt)."""
    scene = load(SCENES / "ground_bounce.yaml", [f"dt={dt}"])
    watch = Channels("disk_tilted.state")
    result = Simulation(scene, observers=[watch]).run(round(3.0 * 1e9))
    assert result.status == "ok", result.reason
    last: BodyState = watch.messages("disk_tilted.state")[-1]
    radius, thickness = 0.05, 0.006
    tilt = math.radians(_tilt_deg(last.orientation))
    assert 2.0 * radius * math.sin(tilt) <= 2.0 * G * dt * dt
    assert np.linalg.norm(last.angular_velocity) < 1e-9
    assert math.isclose(last.speed, G * dt, rel_tol=1e-9)
    # its lowest rim point on the floor, less the step's fall
    lowest = last.position[2] - 0.5 * thickness * math.cos(tilt) - radius * math.sin(tilt)
    assert lowest == pytest.approx(-0.5 * G * dt * dt, abs=1e-9)


def test_the_face_tolerance_grows_with_the_step_only_past_the_materials():
    """At the scenes' 0.5 ms the material's 10 um holds (the scenes unchanged to the bit); at 2.5 ms
    one step's rock, 2 g dt^2."""
    material = Material()
    gravity = (0.0, 0.0, -G)
    assert face_tolerance(material, gravity, 0.0005) == material.face_tolerance
    assert face_tolerance(material, gravity, 0.0025) == pytest.approx(2.0 * G * 0.0025**2)


def test_a_step_that_drops_the_body_through_half_its_height_is_refused():
    """dt 50 ms: a resting 6 mm disk would fall 12 mm a step; the scene is refused naming the ground,
    the fall and the largest step (sqrt(e / g) = 24.7 ms for the disk, sqrt(2 R / g) for the ball)."""
    with pytest.raises(ScenarioError) as info:
        load(SCENES / "ground_bounce.yaml", ["dt=0.05"])
    text = str(info.value)
    assert "components.floor_flat: its step 0.05 s lets the body fall 12.3 mm in one step" in text
    assert "at most 0.0247 s" in text
    assert "components.floor_sphere" not in text  # the 4 cm ball falls 12 mm: under its half height
    load(SCENES / "ground_bounce.yaml", ["dt=0.024"])  # under every body's bound


def test_the_command_line_refuses_it_with_exit_2():
    done = subprocess.run(["cosim", "run", str(SCENES / "ground_bounce.yaml"), "--no-record",
                           "--set", "dt=0.05"], capture_output=True, text=True, timeout=120)
    assert done.returncode == 2
    assert "floor_tilted: its step 0.05 s lets the body fall" in done.stderr
    assert "Traceback" not in done.stderr
