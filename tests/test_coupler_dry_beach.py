"""The water's forces end where the water does: over dry land (a beach whose bed rises above the
rest level, its surface the bed itself) a body meets no water, and over a shore's thin layer only
that layer (components.coupler.kernel._element_pass); a body that runs into the land, which is no
solid, ends the run naming it and a SolidGround as the remedy (WaterCoupler._check_not_through_the_bed)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from components.coupler import WaterCoupler, WaterCouplerParams
from components.coupler.fixtures import body, disk_at_depth, pitched, still_water
from components.messages import HeightPatch, Shape
from cosim.scenario import loads
from cosim.scheduler import Simulation
from tests.toys import Channels

R = 0.05  # [m] the stone's radius


def run(b, patch, **params):
    """One coupler step (1 us, so no stability bound interferes) at state b over patch."""
    c = WaterCoupler("c", WaterCouplerParams(**params))
    return c.step(0, 1000, {"body": b, "water": patch})["contact"]


def with_bed(patch: HeightPatch, height: float, bed: float) -> HeightPatch:
    """``patch`` with its surface at ``height`` [m] and its bed at ``bed`` [m] everywhere."""
    shape = patch.height.shape
    return HeightPatch(patch.i0, patch.j0, patch.cell, patch.origin_x, patch.origin_y, patch.rest_level,
                       np.full(shape, height), patch.velocity, np.full(shape, bed), np.zeros(shape))


# the general path (a column displacement, kernel.evaluate) and the compiled step (ring, step_kernel)
PATHS = [{"displacement_mode": "ring"}, {"displacement_mode": "column"}, {"smoothing": 1}]


@pytest.mark.parametrize("path", PATHS)
def test_a_stone_over_dry_land_meets_no_water(path):
    """A stone gliding at 3 m/s with its trailing edge 1 cm into a beach 2 cm above the rest level
    (the patch's surface there is the bed: no water) feels no pressure, friction or wave drag and
    is not wetted; the same stone as deep into water is (it was over the beach too: 3.5 N)."""
    b = body(position=disk_at_depth(0.01, math.radians(20), level=0.02), orientation=pitched(math.radians(20)),
             velocity=(3.0, 0.0, -0.2))
    dry = run(b, with_bed(still_water(), 0.02, 0.02), **path)
    assert not dry.wetted and dry.wetted_area == 0.0 and dry.submerged_fraction == 0.0
    for force in (dry.pressure, dry.friction, dry.wave_drag, dry.buoyancy):
        assert np.all(force == 0.0)
    wet = run(b, with_bed(still_water(), 0.02, -1.0), **path)
    assert wet.wetted and np.linalg.norm(wet.pressure) > 1.0


@pytest.mark.parametrize("path", PATHS)
def test_a_sphere_through_a_thin_layer_is_wetted_over_the_layer_only(path):
    """A ball 2 cm in radius whose lowest point is 1 cm into the bed under a 2 cm layer: its wetted
    area is the zone of the sphere between the bed and the surface, 2 pi R x 2 cm (Archimedes' hat
    box, which the bands' wetting holds exactly), not the 2 pi R x 3 cm below the surface."""
    radius = 0.02
    b = body(Shape.SPHERE, position=(0.0, 0.0, -0.01), radius=radius, velocity=(0.5, 0.0, -0.1))
    thin = run(b, with_bed(still_water(0.005), 0.0, -0.02), effects=["pressure", "friction"], **path)
    assert thin.wetted_area == pytest.approx(2.0 * math.pi * radius * 0.02, rel=1e-9)
    deep = run(b, with_bed(still_water(0.005), 0.0, -1.0), effects=["pressure", "friction"], **path)
    assert deep.wetted_area == pytest.approx(2.0 * math.pi * radius * 0.03, rel=1e-9)


POND = """
dt: 0.0005
until: 0.6
on_unstable: substep
components:
  stone: {type: RigidBody, shape: disk, radius: 0.05, thickness: 0.006, density: 2650, position: [1.9, 0.2, 0.012],
          velocity: [2.5, 0.0, 0.0], tilt_deg: 20, integrator: semi_implicit_euler, lock_attitude: true}
  pond: {type: WaterSurface, nx: 400, ny: 40, cell: 0.01, depth: 0.1, bottom_slope: [0.2, 0.0], boundary: absorbing,
         every: 4}
  water: {type: WaterCoupler}
connections:
  - stone.state -> water.body
  - pond.patch -> water.water
  - {from: water.wrench, to: stone.wrench, delay: 1, initial: {force: [0, 0, 0], torque: [0, 0, 0]}}
  - {from: water.occupied, to: pond.occupied, delay: 1, initial: {i0: 0, j0: 0, b: []}}
  - {from: water.request, to: pond.request, delay: 1, initial: {x_min: 1, x_max: 0, y_min: 1, y_max: 0}}
"""
SHORE = 1.995 + 0.5  # [m] where the bed, -0.1 + 0.2 (x - 1.995) m, meets the rest level


def bed(x: float) -> float:
    return -0.1 + 0.2 * (x - 1.995)


def test_a_stone_sliding_onto_a_dry_beach_is_not_pushed_up_it():
    """A stone planing at 2.5 m/s towards a beach (bed slope 0.2): over the dry land (its trailing
    edge past the shore) it meets no water, so it does not climb the beach as it did on dry cells
    pushing like water (from 5 to 10 mm here, 1.2 to 8 cm in the audit's scene); it sinks into the
    land, which is no solid, and the run stops there naming a SolidGround."""
    watch = Channels("stone.state", "water.contact")
    sim = Simulation(loads(POND), observers=[watch])
    result = sim.run()
    assert result.status == "stopped" and result.reason.startswith("water: the body ran into dry land at x = ")
    assert result.reason.endswith("the bed is not solid: to land the body on it, add a SolidGround there "
                                  "(as scenarios/float_sphere.yaml does)")
    states = dict(watch.seen["stone.state"])
    at_shore = next(s.position[2] for s in states.values() if s.position[0] >= SHORE)
    # each contact report with the state it was worked out from (the same time)
    dry = [(states[t].position[2], c) for t, c in watch.seen["water.contact"] if bed(states[t].position[0] - R) > 0.0]
    assert len(dry) >= 15  # (20 steps over the land before it is wholly inside it, judged by its own top)
    assert all(not c.wetted and np.all(c.pressure == 0.0) and np.all(c.friction == 0.0) for _, c in dry)
    assert max(z for z, _ in dry) < at_shore


def test_a_stone_flying_into_land_above_the_water_is_named_so():
    """A stone thrown over a beach into the hill behind it: the coupler idles while the stone is
    above the water and first looks at the bed when the stone comes down to the water's level,
    deep in the hill by then. The run stops saying it ran into dry land, not (as it failed before)
    that it "starts below the water's bed": it started 0.5 m above it."""
    scene = POND.replace("[1.9, 0.2, 0.012]", "[1.9, 0.2, 0.5]").replace("[2.5, 0.0, 0.0]", "[6.0, 0.0, 0.0]")
    result = Simulation(loads(scene)).run()
    assert result.status == "stopped", result
    assert result.reason.startswith("water: the body ran into dry land at x = ")
    assert "rises above the rest level z = 0 m, and the body is wholly inside it" in result.reason
    assert "found as it came down to the water's level" in result.reason
    assert "starts" not in result.reason and 0.2 < result.time_ns / 1e9 < 0.35
