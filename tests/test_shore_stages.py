"""A stone that slides out of the water up a beach onto dry land is on the ground there, not in the
water: lying on the bed of a dry column, where the surface is the bed itself, it met a film of no
water and the coupler said it wetted over 1e-20 m^2 now and then, every force zero; the stage monitor
said "slide" a dozen times on dry land, and the figures coloured its path so."""

import math

from cosim.scenario import loads
from cosim.scheduler import Simulation

SLOPE = 0.2  # the bed's rise along x: the waterline at x = 2.495 m, dry land beyond it

SHORE = f"""
name: shore
dt: 0.0005
until: 0.7
on_unstable: substep
components:
  stone: {{type: RigidBody, shape: disk, radius: 0.05, thickness: 0.006, density: 2650, position: [1.9, 0.2, 0.012],
          velocity: [2.5, 0.0, 0.0], tilt_deg: 20, integrator: semi_implicit_euler, lock_attitude: true}}
  pond: {{type: WaterSurface, nx: 400, ny: 40, cell: 0.01, depth: 0.1, bottom_slope: [{SLOPE}, 0.0],
         boundary: absorbing, every: 4, origin_x: 0.0, origin_y: 0.0}}
  water: {{type: WaterCoupler, effects: [displacement, buoyancy, pressure, friction]}}
  stages: {{type: StageMonitor, stop_after: 0}}
  beach: {{type: SolidGround, point: [2.495, 0.0, 0.0], slope_deg: {math.degrees(math.atan(SLOPE))!r},
          downhill_deg: 180, restitution: 0.2, mu_static: 0.6, mu_kinetic: 0.5}}
connections:
  - stone.state -> water.body
  - pond.patch -> water.water
  - {{from: water.wrench, to: stone.wrench, delay: 1, initial: {{force: [0, 0, 0], torque: [0, 0, 0]}}}}
  - {{from: water.occupied, to: pond.occupied, delay: 1, initial: {{i0: 0, j0: 0, b: []}}}}
  - {{from: water.request, to: pond.request, delay: 1, initial: {{x_min: 1, x_max: 0, y_min: 1, y_max: 0}}}}
  - stone.state -> stages.body
  - water.contact -> stages.water
  - stone.state -> beach.body
  - {{from: beach.impulse, to: stone.impulse, delay: 1, initial: {{linear: [0, 0, 0], angular: [0, 0, 0],
     correction: [0, 0, 0]}}}}
  - beach.impulse -> water.ground
  - beach.contact -> stages.ground
record: {{visual_rate: 0}}
"""


def test_a_stone_on_dry_land_is_on_the_ground_not_in_the_water():
    sim = Simulation(loads(SHORE, source="shore"))
    sim.run()
    monitor = sim.components["stages"]
    stages = [str(stage) for _, stage in monitor.timeline]
    landed = stages.index("ground")
    assert stages[landed:] == ["ground", "rest"]  # not ground -> slide -> ground -> ... on dry land
    stone = sim.components["stone"].body_state()
    assert stone.position[0] > 2.495 + 0.05  # it did end beyond the waterline, on dry land
