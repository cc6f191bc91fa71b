"""Several bodies on one pond (WaterSurface ``bodies``): each body's coupler on its own ports, the
water holding every displacement, each body meeting the others' waves; one body alone is today's
result bit for bit."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from components.messages import Wrench
from components.rigid_body import RigidBody
from components.water import WaterSurface
from cosim.component import Component, Port
from cosim.errors import ScenarioError
from cosim.scenario import load, loads
from cosim.scheduler import BaseObserver, Simulation

SCENES = Path(__file__).resolve().parent.parent / "scenarios"


class Track(BaseObserver):
    """Every published state of one body: rows of (t, x, y, z, vx, vy, vz)."""

    def __init__(self, body: str):
        self.body, self.rows = body, []

    def on_exchange(self, time_ns, component, port, msg):
        if component == self.body and port == "state":
            self.rows.append((time_ns * 1e-9, *msg.position, *msg.velocity))

    @property
    def array(self) -> np.ndarray:
        return np.array(self.rows)


def run(scene, body: str) -> tuple[np.ndarray, Simulation]:
    track = Track(body)
    sim = Simulation(scene, observers=[track])
    sim.run()
    return track.array, sim


EXTRA_BODY = """  NAME:
    type: RigidBody
    shape: disk
    radius: 0.05
    thickness: 0.006
    position: [4.0, 0.5, 500.0]
  NAME_water:
    type: WaterCoupler
"""
EXTRA_EDGES = """  - NAME.state -> NAME_water.body
  - pond.patch_NAME -> NAME_water.water
  - {from: NAME_water.wrench, to: NAME.wrench, delay: 1, initial: {force: [0, 0, 0], torque: [0, 0, 0]}}
  - {from: NAME_water.occupied, to: pond.occupied_NAME, delay: 1, initial: {i0: 0, j0: 0, b: []}}
  - {from: NAME_water.request, to: pond.request_NAME, delay: 1,
     initial: {x_min: 1, x_max: 0, y_min: 1, y_max: 0}}
"""


def skip_on_named_ports(extra_body: str = "") -> str:
    """scenarios/held_skip.yaml with its pond's ports named for the stone (``bodies: [stone]``), and
    optionally a second slate ``extra_body`` far above the pond with its own coupler and ports."""
    text = (SCENES / "held_skip.yaml").read_text()
    bodies = "[stone]" if not extra_body else f"[stone, {extra_body}]"
    text = text.replace("    boundary: absorbing\n", f"    boundary: absorbing\n    bodies: {bodies}\n", 1)
    for port in ("occupied", "request"):
        text = text.replace(f"to: pond.{port},", f"to: pond.{port}_stone,")
    text = text.replace("pond.patch -> coupler.water", "pond.patch_stone -> coupler.water")
    if extra_body:
        text = text.replace("  pond:\n", EXTRA_BODY.replace("NAME", extra_body) + "  pond:\n", 1)
        head, record = text.split("\nrecord:\n")
        text = head + "\n" + EXTRA_EDGES.replace("NAME", extra_body) + "\nrecord:\n" + record
    return text


@pytest.fixture(scope="module")
def reference_skip():
    return run(load(SCENES / "held_skip.yaml", ["until=0.7"]), "stone")[0]


@pytest.mark.parametrize("extra", ["", "ball"])
def test_one_body_on_a_shared_pond_is_todays_skip_bit_for_bit(reference_skip, extra):
    """The held skip with its pond's ports named for the stone, alone or beside a second body
    that never reaches the water, follows exactly the track of scenarios/held_skip.yaml."""
    scene = loads(skip_on_named_ports(extra), SCENES / "held_skip.yaml", ["until=0.7"])
    track, sim = run(scene, "stone")
    assert sim.components["stages"].track.skips == 3
    assert np.array_equal(track, reference_skip)


def test_two_stones_keep_the_water_volume_to_round_off():
    """Two stones skipping side by side in a closed basin: the water's volume (bodies' occupied
    height excluded) is what it was, to round-off, while both stones are in the water, and the
    water holds the occupied height of both."""
    scene = load(SCENES / "two_stones.yaml", ["until=0.36", "components.pond.boundary=reflecting"])
    _, sim = run(scene, "left")
    pond = sim.components["pond"]
    # at 0.36 s both are in their second contact
    assert sim.components["left_stages"].track.in_contact and sim.components["right_stages"].track.in_contact
    assert pond.volume() == pytest.approx(pond.initial_volume, rel=1e-12)
    # the water holds both stones' displacement: its total occupied height is the sum of theirs
    assert np.allclose(pond._b, pond._occupants[0].b + pond._occupants[1].b, rtol=0, atol=1e-15)
    assert pond._occupants[0].b.any() and pond._occupants[1].b.any()


def test_a_floating_ball_is_moved_by_the_waves_of_a_passing_stone():
    """The ball of scenarios/stone_and_ball.yaml moves exactly as it would alone until the stone's
    waves can reach it (0.9 m from the first touchdown: no difference before 0.3 s), and differently
    after."""
    with_stone, _ = run(load(SCENES / "stone_and_ball.yaml", ["until=0.8"]), "ball")
    alone, _ = run(load(SCENES / "stone_and_ball.yaml", ["until=0.8", "components.stone.position=[0.3, 0.4, 60.0]"]),
                   "ball")
    early = with_stone[:, 0] < 0.3
    assert np.array_equal(with_stone[early], alone[early])
    late = with_stone[:, 0] > 0.4
    assert np.abs(with_stone[late, 1:4] - alone[late, 1:4]).max() > 1e-6


def test_a_stone_on_anothers_wake_takes_another_track():
    """The second stone of scenarios/wake_skip.yaml, flying 1.2 m behind the first over its wake,
    takes a track that differs from its track alone once it meets the first one's waves."""
    with_first, sim = run(load(SCENES / "wake_skip.yaml", ["until=0.7"]), "second")
    alone, _ = run(load(SCENES / "wake_skip.yaml", ["until=0.7", "components.first.position=[0.3, 0.5, 60.0]"]),
                   "second")
    assert sim.components["second_stages"].track.skips == sim.components["first_stages"].track.skips == 3
    early = with_first[:, 0] < 0.2
    assert np.array_equal(with_first[early], alone[early])
    assert np.abs(with_first[:, 1:4] - alone[:, 1:4]).max() > 1e-5


def test_a_checkpoint_of_a_shared_pond_continues_the_same_run():
    """Restored from a checkpoint at 0.3 s, the two-stone run continues exactly as the run that went
    straight on (each body's own occupied height is part of the water's state)."""
    straight, _ = run(load(SCENES / "two_stones.yaml", ["until=0.5", "components.pond.field_rate=0"]), "left")
    first = Simulation(load(SCENES / "two_stones.yaml", ["until=0.3", "components.pond.field_rate=0"]))
    first.run()
    cp = first.checkpoint()
    track = Track("left")
    again = Simulation(load(SCENES / "two_stones.yaml", ["until=0.5", "components.pond.field_rate=0"]),
                       observers=[track])
    again.restore(cp)
    again.run()
    resumed = track.array
    tail = straight[straight[:, 0] > 0.3 + 1e-9]
    assert np.array_equal(resumed[-len(tail):], tail)


@pytest.mark.parametrize("bodies", [["left", "right", "third"], []])
def test_a_checkpoint_of_a_shared_pond_is_refused_by_a_water_with_other_bodies(bodies):
    """The water of two named bodies restored into one taking three (a restart adding a stone by --set)
    or one unnamed body: one line saying so (three failed on zip()'s own message; one took the
    checkpoint and dropped both bodies' occupied heights without a word)."""
    scene = load(SCENES / "two_stones.yaml", ["until=0.01", "components.pond.field_rate=0"])
    sim = Simulation(scene)
    sim.run()
    saved = sim.components["pond"].get_state()
    params = dataclasses.replace(scene.components["pond"].params, bodies=bodies)
    other = WaterSurface.configure(params, "components.pond", None, [])("pond", params)  # its ports as the scene's
    other.setup()
    with pytest.raises(ValueError, match=f"it holds the occupied heights of 2 bodies on the water, which now "
                                         f"takes {max(len(bodies), 1)}: a restart keeps the bodies the run had"):
        other.set_state(saved)


def test_a_bad_setting_of_a_shared_pond_is_said_once_not_as_its_named_ports():
    """A pond setting refused (a depth of -1) left the pond's class without its named ports, and each
    edge to patch_left, occupied_right... was said to name no port: one line now, the setting's."""
    with pytest.raises(ScenarioError) as refused:
        load(SCENES / "two_stones.yaml", ["components.pond.depth=-1"])
    assert str(refused.value).endswith("components.pond.depth: must be > 0 m (got -1)")
    assert "port" not in str(refused.value)

@pytest.mark.parametrize("bodies, message", [
    ("[stone, stone]", "must not repeat a name"),
    ("[stone, 2nd]", "a name of letters, digits and _"),
])
def test_bad_body_names_are_refused_when_the_scene_loads(bodies, message):
    text = skip_on_named_ports().replace("bodies: [stone]", f"bodies: {bodies}")
    with pytest.raises(ScenarioError, match=message):
        loads(text, SCENES / "skip.yaml")


def test_a_shared_pond_has_no_unnamed_ports():
    """With its bodies named, a pond has no plain 'patch' port: an edge to it names the port and
    the ports the pond has."""
    text = skip_on_named_ports().replace("pond.patch_stone -> coupler.water", "pond.patch -> coupler.water")
    with pytest.raises(ScenarioError, match="patch"):
        loads(text, SCENES / "skip.yaml")


def two_stones_rewired(swap: dict[str, str]) -> ScenarioError:
    """The error refusing scenarios/two_stones.yaml with each text of ``swap`` replaced by its value."""
    text = (SCENES / "two_stones.yaml").read_text()
    for old, new in swap.items():
        assert old in text
        text = text.replace(old, new)
    with pytest.raises(ScenarioError) as refused:
        loads(text, SCENES / "two_stones.yaml")
    return refused.value


@pytest.mark.parametrize("swap, messages", [
    ({"pond.patch_right -> right_water.water": "pond.patch_left -> right_water.water"},
     ["right_water sends 'request_right' but is sent 'patch_left', the answer to another: connect "
      "pond.patch_right -> right_water.water instead"]),
    ({"pond.patch_right -> right_water.water": "pond.patch_left -> right_water.water",
      "pond.patch_left -> left_water.water": "pond.patch_right -> left_water.water"},
     ["left_water sends 'request_left' but is sent 'patch_right'", "right_water sends 'request_right' but is "
                                                                   "sent 'patch_left'"]),
], ids=["one-copied", "both-swapped"])
def test_a_coupler_sent_another_bodys_water_is_refused(swap, messages):
    """Each body's patch must go back to the coupler that asks on the request beside it. Wired to
    another body's (a copied line), the coupler met water that was not where it asked: the stone fell
    through the pond, 6 m under a 0.5 m bed, and the run ended ok."""
    refused = two_stones_rewired(swap)
    for message in messages:
        assert f"components.pond: {message}" in str(refused)


@pytest.mark.parametrize("swap, message", [
    ({"{from: right_water.wrench, to: right.wrench,": "{from: right_water.wrench, to: left.wrench,"},
     "components.right_water: right sends 'body', but 'wrench', the answer to it, feeds left: connect "
     "right_water.wrench -> right"),
    ({"right_water.contact -> right_stages.water": "left_water.contact -> right_stages.water"},
     "components.right_stages: its input 'water' comes from left_water, which is not fed by right, the sender of "
     "its 'body': left_water serves another body"),
    ({"{from: left_water.occupied, to: pond.occupied_left,": "{from: left_water.occupied, to: pond.occupied_right,",
      "{from: right_water.occupied, to: pond.occupied_right,": "{from: right_water.occupied, to: pond.occupied_left,"},
     "components.pond: its input 'occupied_left' comes from right_water, but 'request_left' from left_water: both "
     "must come from the same component (another body's?)"),
    ({"bodies: [left, right]": "bodies: [left, right, ghost]"},
     "components.pond: its output 'patch_ghost' feeds nothing, but body 'ghost' is named in bodies: its coupler "
     "reads the water only through it: connect pond.patch_ghost -> <its coupler>.water, or leave the body out of "
     "bodies"),
    ({"right.state -> right_water.body": "left.state -> right_water.body"},
     "components: left_water and right_water are WaterCouplers fed alike (body from left, water from pond): each "
     "would act on its own, the effect counted twice; keep one"),
], ids=["wrench-to-another-body", "monitor-of-another-body", "occupied-swapped", "body-without-coupler",
        "two-couplers-of-one-body"])
def test_a_scene_wiring_one_bodys_ports_to_anothers_is_refused(swap, message):
    """A coupler pushing another body than the one it reads (that stone flew off at 305 m/s), a
    monitor told one body's state and another's contact (it dated one stone's skips by the other's
    times), a pond told each body's displacement as the other's, a body named on the pond with no
    coupler (it fell 2 m through the bed, its monitor saying 'approach'), two couplers of one body to one
    water (a pine ball floated 2 cm high on double buoyancy): each ran to exit 0; each is refused in one
    line naming the ports."""
    assert message in two_stones_rewired(swap).problems


def wrench_also_to_the_other(source: str, other: str, right_type: str = "RigidBody") -> list[str]:
    """The problems refusing two_stones with ``source``'s coupler's wrench also fed to ``other``'s
    wrench, the right stone of ``right_type``."""
    text = (SCENES / "two_stones.yaml").read_text()
    text = text.replace("  right:\n    type: RigidBody\n", f"  right:\n    type: \"{right_type}\"\n", 1)
    text = text.replace("connections:\n", f"connections:\n  - {{from: {source}_water.wrench, to: {other}.wrench, "
                        "delay: 1, initial: {force: [0, 0, 0], torque: [0, 0, 0]}}\n", 1)
    with pytest.raises(ScenarioError) as refused:
        loads(text, SCENES / "two_stones.yaml")
    return refused.value.problems


def test_a_bodys_wrench_also_fed_to_another_body_is_refused():
    """A coupler's wrench fed to its own body and also to another (an additive port, so no other rule
    refused it): the left stone took both stones' water forces and climbed to 0.50 m instead of
    skipping, the run "ok"."""
    assert wrench_also_to_the_other("right", "left") == [
        "components.right_water: its 'wrench' answers the 'body' that right sends it, but also feeds left.wrench, "
        "which sends it none: left would take what was worked out for right; remove the connection "
        "right_water.wrench -> left.wrench"]


class Slate(RigidBody):
    """A body of a class of its own (as every FMU body is): nothing added."""


def test_a_wrench_also_fed_to_a_body_of_another_class_is_refused():
    """The rule keyed on the receiving component's class: a second body of a subclass of RigidBody (or
    an FMU body, each of a class of its own) took another stone's wrench, the scene "ok"."""
    assert wrench_also_to_the_other("left", "right", right_type="tests.test_shared_pond:Slate") == [
        "components.left_water: its 'wrench' answers the 'body' that left sends it, but also feeds right.wrench, "
        "which sends it none: right would take what was worked out for left; remove the connection "
        "left_water.wrench -> right.wrench"]


def test_an_answer_also_read_by_a_component_that_is_no_body_is_not_refused():
    """A component that reads a coupler's wrench beside the body (a logger: it sends no state to any
    coupler) is no second body."""
    text = (SCENES / "two_stones.yaml").read_text()
    text = text.replace("components:\n", "components:\n  logger: {type: \"tests.test_shared_pond:WrenchLog\"}\n", 1)
    text = text.replace("connections:\n", "connections:\n  - right_water.wrench -> logger.wrench\n", 1)
    loads(text, SCENES / "two_stones.yaml")


class WrenchLog(Component):
    """Reads a wrench, publishes nothing."""

    inputs = {"wrench": Port(Wrench)}
    outputs = {}

    def _step_impl(self, t, dt, inputs):
        return {}


GROUND = ("  - stone.state -> bottom.body\n"
          "  - {from: bottom.impulse, to: stone.impulse, delay: 1, initial: {linear: [0, 0, 0], angular: [0, 0, 0], "
          "correction: [0, 0, 0]}}\n"
          "  - bottom.impulse -> stone_water.ground\n")


@pytest.mark.parametrize("extra, answer, port", [
    (GROUND + "  - {from: bottom.impulse, to: ball.impulse, delay: 1, initial: {linear: [0, 0, 0], "
              "angular: [0, 0, 0], correction: [0, 0, 0]}}\n", "bottom.impulse", "impulse"),
    ("  - {from: stone_water.added_mass, to: ball.added_mass, delay: 1, initial: {axial: 0, radial: 0, "
     "axial_inertia: 0, diameter_inertia: 0}}\n", "stone_water.added_mass", "added_mass"),
], ids=["ground-impulse", "added-mass"])
def test_an_answer_also_fed_to_a_body_it_was_not_worked_out_for_is_refused(extra, answer, port):
    """A ground under the stone whose impulse also reached the floating ball (the stone's bed pushes
    moved the ball 4 cm, and the scene's notice said to tell the ball's coupler of the ground, which
    the scene then refused); the stone's added mass given to the ball as well (the ball has none of
    its own wired, so no other rule refused it)."""
    text = (SCENES / "stone_and_ball.yaml").read_text()
    text = text.replace("components:\n", "components:\n  bottom: {type: SolidGround, point: [0, 0, -0.5]}\n", 1)
    text = text.replace("connections:\n", "connections:\n" + (extra if port == "impulse" else GROUND + extra), 1)
    with pytest.raises(ScenarioError) as refused:
        loads(text, SCENES / "stone_and_ball.yaml")
    source, out = answer.split(".")
    assert refused.value.problems == [
        f"components.{source}: its {out!r} answers the 'body' that stone sends it, but also feeds ball.{port}, "
        f"which sends it none: ball would take what was worked out for stone; remove the connection "
        f"{answer} -> ball.{port}"]


def test_a_coupler_not_asking_a_shared_water_is_told_its_port():
    """A coupler whose request reaches no input, on a water that serves several bodies: the fix said
    names the body's own port (it said only ``<water>.request``, a port such a water does not have)."""
    line = ("  - {from: right_water.request, to: pond.request_right, delay: 1, "
            "initial: {x_min: 1, x_max: 0, y_min: 1, y_max: 0}}\n")
    text = (SCENES / "two_stones.yaml").read_text()
    assert line in text
    with pytest.raises(ScenarioError) as refused:
        loads(text.replace(line, ""), SCENES / "two_stones.yaml")
    [problem] = refused.value.problems
    assert problem.startswith("components.right_water: its output 'request' feeds nothing")
    assert problem.endswith("(an empty window; on a water shared by several bodies, its request_<body> input)")


def test_plots_of_one_body_show_only_its_own_monitor_coupler_and_skips(tmp_path):
    """In a recording of two stones, the figures' data for one stone come from its own monitor,
    coupler and wrench channels (the scene's edges say which), not from the other stone's."""
    from components.analysis.data import load_run
    from cosim.runner import run_scene

    path = tmp_path / "two.mcap"
    run_scene(load(SCENES / "two_stones.yaml", ["until=0.45", "components.pond.field_rate=0"]), path, progress=False)
    for body, other in (("left", "right"), ("right", "left")):
        data = load_run(path, body)
        assert data.stages.topic == f"/{body}_stages/stage"
        assert [c.topic for c in data.contacts] == [f"/{body}_water/contact"]
        assert all(other not in w.topic for w in data.wrenches) and data.wrenches
        assert len(data.skips) == 2
    assert load_run(path, "left").skips[0].touchdown_x != load_run(path, "right").skips[0].touchdown_x
