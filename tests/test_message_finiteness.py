"""The finiteness guard every output passes (``Message.first_nonfinite``): it names the field holding
NaN or infinity, in a float, a small array or a large one (the float fields first, then the arrays,
each in declaration order), also when an array came as another shape or as a list. The same check
(``Message.first_invalid``) names an enum field holding a number that is none of its members."""

from __future__ import annotations

import math

import numpy as np
import pytest

from components.messages import BodyState, HeightPatch, Shape, Wrench


def _state(**changes) -> BodyState:
    base = dict(position=np.zeros(3), orientation=np.array([1.0, 0.0, 0.0, 0.0]), velocity=np.ones(3),
                angular_velocity=np.zeros(3), shape=Shape.DISK, radius=0.05, thickness=0.01, mass=0.1,
                inertia=np.full(3, 1e-4), attack_angle_deg=20.0, speed=1.7, kinetic_energy=0.15,
                potential_energy=0.0)
    return BodyState(**{**base, **changes})


def _patch(**changes) -> HeightPatch:
    grid = np.zeros((23, 71))
    base = dict(i0=0, j0=0, cell=0.01, origin_x=0.0, origin_y=0.0, rest_level=0.0, height=grid,
                velocity=grid, bottom=grid - 0.3)
    return HeightPatch(**{**base, **changes})


def test_finite_messages_pass():
    assert _state().first_nonfinite() is None
    assert _patch().first_nonfinite() is None
    assert Wrench(np.zeros(3), np.zeros(3)).first_nonfinite() is None


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_a_float_field_is_named(bad):
    assert _state(speed=bad).first_nonfinite() == "speed"


@pytest.mark.parametrize("bad", [math.nan, math.inf])
def test_a_small_array_is_named(bad):
    velocity = np.ones(3)
    velocity[2] = bad
    assert _state(velocity=velocity).first_nonfinite() == "velocity"


def test_a_large_array_is_named():
    height = np.zeros((23, 71))
    height[11, 40] = math.nan
    assert _patch(height=height).first_nonfinite() == "height"


def test_the_float_fields_come_first_then_the_arrays_in_declaration_order():
    torque = np.array([0.0, math.inf, 0.0])
    force = np.array([math.nan, 0.0, 0.0])
    assert Wrench(force, torque).first_nonfinite() == "force"
    assert _state(position=np.array([math.nan, 0.0, 0.0]), speed=math.inf).first_nonfinite() == "speed"


def test_huge_finite_values_whose_sum_overflows_are_finite():
    """The fast path sums every value (a grid's squared); an overflow of that sum is not a non-finite
    field, and a non-finite value among huge ones is still found."""
    assert _state(position=np.array([1e308, 1e308, 1e308]), speed=1e308).first_nonfinite() is None
    huge = np.full((23, 71), 1e200)  # its squares overflow
    assert _patch(height=huge).first_nonfinite() is None
    huge[4, 9] = -math.inf
    assert _patch(height=huge).first_nonfinite() == "height"


def test_a_value_of_another_shape_is_still_checked():
    """A (2, 3) array where a 3-vector was declared, or a list where a grid was, still has its NaN or
    infinity found."""
    odd = np.ones((2, 3))
    odd[1, 1] = math.nan
    assert _state(velocity=odd).first_nonfinite() == "velocity"
    assert _state(velocity=np.ones((2, 3))).first_nonfinite() is None
    grid = [[0.0] * 71 for _ in range(23)]
    assert _patch(height=grid).first_nonfinite() is None
    grid[5][7] = math.inf
    assert _patch(height=grid).first_nonfinite() == "height"


def test_a_large_grid_is_checked_on_the_calling_thread(monkeypatch):
    """A grid too long for a single-threaded dot product (a pond's whole field, 600 x 600) is
    summed by a reduction on this thread, not by the BLAS dot product, whose worker threads, once
    woken, spin for a tenth of a second after each call: a second core kept busy through a run that
    checks a field ten times a second. A water patch's grid (27 x 66) takes the dot product, half
    the time of a reduction there. A NaN is found either way."""
    import cosim.messages as messages

    dotted: list[int] = []
    vdot = messages._vdot

    def spy(a, b):
        if np.asarray(a).size:  # (a patch's empty occupied height is one too)
            dotted.append(np.asarray(a).size)
        return vdot(a, b)

    monkeypatch.setattr(messages, "_vdot", spy)
    field = np.zeros((600, 600))
    patch = _patch(height=field, velocity=field, bottom=field - 0.3)
    assert patch.first_nonfinite() is None
    assert dotted == []
    small = np.zeros((27, 66))
    assert _patch(height=small, velocity=small, bottom=small - 0.3).first_nonfinite() is None
    assert dotted == [27 * 66] * 3
    field[599, 0] = math.nan
    assert patch.first_nonfinite() == "height"


@pytest.mark.parametrize(("shape", "fault"), [
    (7, "7 is not a Shape (0 disk, 1 sphere)"),
    (-1, "-1 is not a Shape (0 disk, 1 sphere)"),
    (0.5, "0.5 is not a Shape (0 disk, 1 sphere)"),
    ("disk", "'disk' is not a Shape (0 disk, 1 sphere)"),
], ids=["seven", "negative", "fraction", "text"])
def test_an_enum_field_holding_no_member_is_named(shape, fault):
    """An enum field holding a number that is none of its type's members (BodyState(shape=7)) is named
    with the members it may hold: both codecs wrote it, and no reader could read the recording back.
    ``first_nonfinite`` still answers for non-finite values alone."""
    assert _state(shape=shape).first_invalid() == ("shape", fault)
    assert _state(shape=shape).first_nonfinite() is None


@pytest.mark.parametrize("shape", [Shape.DISK, Shape.SPHERE, 0, 1, np.int64(1), 1.0, True],
                         ids=["disk", "sphere", "int-0", "int-1", "numpy-int", "whole-float", "bool"])
def test_an_enum_field_holding_a_members_value_passes(shape):
    """A member, or any number equal to a member's value, as the codecs write it (an int, a numpy int,
    a whole float), passes."""
    assert _state(shape=shape).first_invalid() is None


def test_a_nonfinite_value_is_named_before_a_bad_enum():
    """A message with both faults names its non-finite field first, as the finiteness guard did."""
    from cosim.messages import NONFINITE

    assert _state(shape=7, speed=math.nan).first_invalid() == ("speed", NONFINITE)
    assert _state(speed=math.inf).first_invalid() == ("speed", NONFINITE)
    assert _patch(height=np.full((23, 71), math.nan)).first_invalid() == ("height", NONFINITE)


def test_a_component_publishing_a_bad_enum_fails_naming_it():
    """A component's output holding an enum value that is no member is its failure, naming the port,
    the field, the value and the members (it was recorded, and the recording could not be read)."""
    from cosim.component import Component, Port
    from cosim.errors import SimulationError

    class Thrower(Component):
        outputs = {"state": Port(BodyState)}

        def _step_impl(self, t, dt, inputs):
            return {"state": _state(shape=7)}

    thrower = Thrower("stone")
    with pytest.raises(SimulationError, match=r"^component 'stone' failed at t = 0.002 s: output 'state' field "
                                              r"'shape': 7 is not a Shape \(0 disk, 1 sphere\)$"):
        thrower.step(2_000_000, 1_000_000, {})
    assert thrower.status == "failed"
