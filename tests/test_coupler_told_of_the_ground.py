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


def _loaded(replace: tuple[str, str] = ("", ""), overrides: tuple[str, ...] = ()):
    from cosim.scenario import loads

    text = (SCENES / "float_sphere.yaml").read_text().replace(*replace)
    return loads(text, "float_sphere.yaml", list(overrides))


@pytest.mark.parametrize(("replace", "overrides", "said"), [
    # a delayed edge, as the body's own impulse edge is: the answer a step late, as if not told
    ((f"  - {TOLD}", "  - {from: bottom.impulse, to: granite_water.ground, delay: 1,\n"
                     "     initial: {linear: [0, 0, 0], angular: [0, 0, 0], correction: [0, 0, 0]}}"), (),
     "components.granite_water: bottom.impulse -(delay)-> granite_water.ground is delayed: its 'ground' takes the "
     "answer to the state it meets in the same step; connect it without delay"),
    # the coupler every 2 steps: two answers summed onto one state
    (("", ""), ("components.granite_water.every=2",),
     "components.granite_water: it steps every 2 base steps and bottom every 1: its 'ground' would take several "
     "answers at once; set components.granite_water.every to 1"),
])
def test_a_ground_told_otherwise_than_directly_at_the_couplers_rate_is_refused(replace, overrides, said):
    with pytest.raises(ScenarioError) as refused:
        _loaded(replace, overrides)
    assert said in refused.value.problems


def test_a_coupler_told_of_one_of_two_grounds_is_refused_and_one_told_of_none_is_said():
    """Two grounds under the granite ball, the coupler told of one: it met the body with half the answer.
    Told of none: loaded, with a notice naming the connection to make."""
    second = ("  bottom:\n", "  wall:\n    type: SolidGround\n    point: [2.4, 0.0, 0.0]\n    slope_deg: 60\n"
              "    downhill_deg: 180\n  bottom:\n")
    text = (SCENES / "float_sphere.yaml").read_text().replace(*second) + (
        "  - granite.state -> wall.body\n  - {from: wall.impulse, to: granite.impulse, delay: 1,\n"
        "     initial: {linear: [0, 0, 0], angular: [0, 0, 0], correction: [0, 0, 0]}}\n")
    from cosim.scenario import loads

    with pytest.raises(ScenarioError) as refused:
        loads(text, "float_sphere.yaml")
    assert ("components.granite_water: its 'ground' comes from bottom, but what answers granite on 'impulse' from "
            "bottom, wall: it must be told of every one of those, and of no other") in refused.value.problems
    untold = "\n".join(line for line in (SCENES / "float_sphere.yaml").read_text().splitlines() if TOLD not in line)
    scene = loads(untold, "float_sphere.yaml")
    assert ("components.granite_water: granite is answered on 'impulse' by bottom, which it is not told of: connect "
            "bottom.impulse -> granite_water.ground (it meets the state before that answer)") in scene.notices


def test_the_books_close_when_a_body_carrying_water_strikes_the_bed():
    """A disk (R 3 cm, e 8 mm, 2650 kg/m^3, tilted 10 deg) thrown at 10 m/s, 60 deg down, into a 3 cm pond
    with every effect on, the added mass too, its coupler told of the bed: what the body loses (3.04 J)
    is what the water's book and the bed's say to 0.01 J. (The added mass's step settled on the state
    the next answer had left: 0.75 J short.)"""
    import yaml

    from cosim.scenario import loads

    data = yaml.safe_load((SCENES / "float_sphere.yaml").read_text())
    for name in [n for n in data["components"] if n.startswith("pine")]:
        del data["components"][name]
    data["connections"] = [c for c in data["connections"] if "pine" not in str(c)]
    data["components"]["granite"].update(shape="disk", radius=0.03, thickness=0.008, position=[2.0, 0.0, 0.05],
                                         velocity=[5.0, 0.0, -8.66], tilt_deg=10.0)
    data["components"]["granite_pond"]["depth"] = 0.03
    data["components"]["bottom"]["point"] = [0.0, 0.0, -0.03]
    data["components"]["granite_water"]["effects"] = ["displacement", "buoyancy", "pressure", "friction",
                                                      "added_mass"]
    data["connections"].append({"from": "granite_water.added_mass", "to": "granite.added_mass", "delay": 1,
                                "initial": {"axial": 0, "radial": 0, "axial_inertia": 0, "diameter_inertia": 0}})
    data.update(until=0.3, dt=0.0005)
    watch = Channels("granite.state", "granite_water.contact", "bottom.contact")
    assert Simulation(loads(yaml.safe_dump(data), "disk.yaml"), observers=[watch]).run().status == "ok"
    body = [m.kinetic_energy + m.potential_energy for m in watch.messages("granite.state")]
    water = watch.messages("granite_water.contact")[-1].dissipated_energy
    bed = watch.messages("bottom.contact")[-1].dissipated_energy
    assert body[0] - body[-1] == pytest.approx(3.04, abs=0.01)
    assert abs(water + bed - (body[0] - body[-1])) < 0.01
