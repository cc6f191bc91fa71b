"""A coupler told of a solid ground's answer to its body (input ``ground``) meets the water with the
body as the ground leaves it: the force it holds over the body's next step is not the force of a
motion the ground has already turned round."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from components.coupler.component import _answered
from components.messages import Impulse
from components.rigid.dynamics import RigidState, apply_impulse
from cosim.errors import ScenarioError
from cosim.scenario import load
from cosim.scheduler import Simulation
from tests.toys import Channels

SCENES = Path(__file__).resolve().parent.parent / "scenarios"
TOLD = "bottom.impulse -> granite_water.ground"
# the granite ball of float_sphere let go at 20 m/s onto the bed of a pond 2 cm deep, at 2 ms steps
SHALLOW = ["components.granite_pond.depth=0.02", "components.bottom.point=[0, 0, -0.02]",
           "components.granite.position=[2, 0, 0.05]", "components.granite.velocity=[0, 0, -20]",
           "on_unstable=substep", "dt=0.002", "until=1"]


def _struck(text: str) -> tuple[float, float, float]:
    """The energy the water took from the ball [J], its speed as it first leaves the bed and its
    highest centre after it [m/s, m]."""
    from cosim.scenario import loads

    watch = Channels("granite.state", "granite_water.contact")
    sim = Simulation(loads(text, "float_sphere.yaml", SHALLOW), observers=[watch])
    assert sim.run().status == "ok"
    states = watch.messages("granite.state")
    vz = np.array([s.velocity[2] for s in states])
    z = np.array([s.position[2] for s in states])
    first_up = int(np.argmax(vz > 0.0))
    return watch.messages("granite_water.contact")[-1].dissipated_energy, float(vz[first_up]), float(z[first_up:].max())


def test_a_ball_the_bed_bounces_is_not_pushed_on_by_the_water_it_entered():
    """Bounced at e = 0.2 from 20 m/s, the ball leaves at most at 4.0 m/s and rises at most
    0.01 + 4.0^2 / 2g = 0.83 m, and by what the buoyancy can add on its way out of the water, at most
    1000 / 2650 of the 8 cm from the bed until it is clear of the 2 cm pond; the water takes energy
    from it. Not told of the ground, the coupler
    held the 266 N of the ball's entry over the step after the bounce: it left at 5.8 m/s, climbed
    1.7 m and the water's book said -2.6 J."""
    text = (SCENES / "float_sphere.yaml").read_text()
    assert TOLD in text
    taken, leaving, highest = _struck(text)
    assert taken > 0.0 and leaving <= 0.2 * 20.02 and highest < 0.01 + 4.0**2 / (2 * 9.81) + 1000 / 2650 * 0.08
    untold = "\n".join(line for line in text.splitlines() if TOLD not in line)
    taken, leaving, highest = _struck(untold)
    assert taken < 0.0 and leaving > 5.0 and highest > 1.5  # what the scene did before it was told


def test_the_body_is_met_as_the_ground_leaves_it():
    """The state the coupler meets: the body's, with the ground's impulse and correction applied as the
    body applies them at the start of its next step."""
    from components.messages import BodyState, Shape

    body = BodyState(np.array([0.1, 0.2, -0.03]), np.array([0.9, 0.1, 0.3, 0.3]) / np.linalg.norm([0.9, 0.1, 0.3, 0.3]),
                     np.array([1.0, 0.0, -3.0]), np.array([0.0, 5.0, 1.0]), Shape.DISK, 0.03, 0.006, 0.046,
                     np.array([1.0e-5, 1.0e-5, 2.0e-5]), 10.0, 3.2, 0.2, 0.0)
    impulse = Impulse(np.array([0.01, 0.0, 0.2]), np.array([0.0, 1e-4, 0.0]), np.array([0.0, 0.0, 0.002]))
    met = _answered({"body": body, "ground": impulse})["body"]
    want = apply_impulse(0.046, (1.0e-5, 1.0e-5, 2.0e-5),
                         RigidState(tuple(body.position), tuple(body.orientation), tuple(body.velocity),
                                    tuple(body.angular_velocity)),
                         tuple(impulse.linear), tuple(impulse.angular), tuple(impulse.correction))
    assert met.position.tolist() == list(want.position) and met.velocity.tolist() == list(want.velocity)
    assert met.angular_velocity.tolist() == list(want.angular_velocity)
    assert met.speed == pytest.approx(float(np.linalg.norm(want.velocity)), rel=1e-15)
    # nothing to apply, or no ground: the inputs as given
    still = {"body": body, "ground": Impulse(np.zeros(3), np.zeros(3), np.zeros(3))}
    assert _answered(still) is still and _answered({"body": body, "ground": None})["body"] is body
    locked = _answered({"body": body.replace(attitude_locked=True), "ground": impulse})["body"]
    assert locked.angular_velocity.tolist() == body.angular_velocity.tolist()  # a held attitude takes no turn


def test_another_bodys_ground_is_refused():
    """The ground the coupler is told of answers the coupler's own body: wired to another body's, the
    water would meet this body as if that one had been bounced."""
    from cosim.scenario import loads

    load(SCENES / "float_sphere.yaml")  # (as shipped: fine)
    text = (SCENES / "float_sphere.yaml").read_text().replace(TOLD, "bottom.impulse -> pine_water.ground")
    with pytest.raises(ScenarioError) as refused:
        loads(text, "float_sphere.yaml")
    assert any("pine_water" in problem and "ground" in problem for problem in refused.value.problems)


def test_a_body_through_the_bed_and_its_ground_is_told_the_step_is_too_long():
    """A body that went through the bed within one step, a ground there told to its coupler: the stop
    says the step is too long for its speed (it said to add the SolidGround that was there)."""
    watch = Channels("granite_pond.patch")
    sim = Simulation(load(SCENES / "float_sphere.yaml", ["until=0.01"]), observers=[watch])
    sim.run()
    patch = next(p for p in reversed(watch.messages("granite_pond.patch")) if p.height.size)
    coupler = sim.components["granite_water"]
    coupler._check_not_through_the_bed(-0.4, np.array([2.0, 0.0, -0.37]), patch)
    assert coupler.stop_reason == ("the body went through the water's bed at x = 2 m, y = 0 m (its centre at z = -0.37 "
                                   "m, wholly under the bed at z = -0.3 m), and through bottom there, within one step: "
                                   "the step is too long for the body's speed to land it; use a smaller dt (or every)")
