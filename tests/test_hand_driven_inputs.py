"""A component driven by hand (``Component.step``, as a unit test drives one) holds the inputs it is
given to its declared ports: a misspelt port or a message of another type is the caller's error,
named, and the component is left as it was."""

import numpy as np
import pytest

from components.messages import PatchRequest, Wrench
from components.rigid_body import RigidBody, RigidBodyParams
from cosim.errors import SimulationError

MS = 1_000_000  # [ns]


def push() -> Wrench:
    return Wrench(np.array([0.0, 0.0, 1.0]), np.zeros(3))


def stone() -> RigidBody:
    return RigidBody("stone", RigidBodyParams(shape="disk", radius=0.05, thickness=0.01, density=2650.0))


def test_a_misspelt_port_is_named_with_the_ports_there_are():
    body = stone()
    with pytest.raises(SimulationError, match=r"was given input 'wrnch', which is not one of its input ports "
                                              r"\(wrench, .*added_mass"):
        body.step(0, MS, {"wrnch": push()})
    assert body.status == "initialized" and body.step_count == 0  # not stepped, not failed: the caller's error
    body.step(0, MS, {"wrench": push()})  # and it steps when asked right
    assert body.step_count == 1


def test_a_message_of_another_type_is_named_with_the_type_the_port_takes():
    with pytest.raises(SimulationError, match=r"input 'wrench' was given a PatchRequest; the port takes Wrench"):
        stone().step(0, MS, {"wrench": PatchRequest(0.0, 1.0, 0.0, 1.0)})


def test_inputs_that_are_not_a_mapping_are_refused():
    with pytest.raises(SimulationError, match=r"was given inputs as list, not a mapping of input port to message"):
        stone().step(0, MS, [push()])


def test_none_is_an_empty_port():
    body = stone()
    out = body.step(0, MS, {"wrench": None})
    assert out["state"].position[2] < body.params.position[2]  # it falls: nothing pushed it


def test_a_port_left_out_is_an_empty_one_as_the_scheduler_gives_it():
    """Every input the scheduler gives (None for a port connected to nothing); by hand a port left
    out is given None too (the toy counter of the audit failed with KeyError: 'x', and stayed failed)."""
    alone, empty = stone(), stone()
    out = alone.step(0, MS, {})["state"]
    same = empty.step(0, MS, {port: None for port in empty.inputs})["state"]
    assert np.array_equal(out.position, same.position) and np.array_equal(out.velocity, same.velocity)
    assert alone.status == "running"


def test_a_required_port_left_out_is_named():
    from cosim.component import Component, Port

    class Needs(Component):
        inputs = {"body": Port(Wrench, required=True)}

    with pytest.raises(SimulationError, match=r"was not given its required input 'body'"):
        Needs("needs").step(0, MS, {})


@pytest.mark.parametrize(("t_ns", "dt_ns", "said"), [
    (0, 0.001, r"was given dt_ns = 0.001, not a whole number of nanoseconds \(step takes times in ns"),
    (0.5, MS, r"was given t_ns = 0.5, not a whole number of nanoseconds"),
    (0, True, r"was given dt_ns = True, not a whole number"),
    (0, 0, r"failed at t = 0 s: was given t_ns = 0 and dt_ns = 0: a step starts at t_ns >= 0 and lasts dt_ns > 0"),
    (-MS, MS, r"was given t_ns = -1000000 and dt_ns = 1000000: a step starts at t_ns >= 0"),
    (5 * MS, 0.001, r"failed at t = 0.005 s: was given dt_ns = 0.001"),  # said at the step's own time
])
def test_times_in_seconds_are_refused(t_ns, dt_ns, said):
    """step takes integer nanoseconds; a dt in seconds ran a step of a picosecond without a word."""
    body = stone()
    with pytest.raises(SimulationError, match=said):
        body.step(t_ns, dt_ns, {"wrench": push()})
    assert body.status == "initialized" and body.step_count == 0
