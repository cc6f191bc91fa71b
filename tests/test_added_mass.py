"""A body under water carries water along (added mass): exact sinking accelerations, closed energy
books, and a scene that names the effect without connecting it is refused."""

from __future__ import annotations

import itertools
import math

import pytest

from components.coupler.added_mass import full_added_mass, scaled
from components.messages import AddedMass, Shape
from cosim.errors import ScenarioError
from cosim.scenario import loads
from cosim.scheduler import BaseObserver, Simulation

RHO, DENSITY, G = 1000.0, 2650.0, 9.81
RADIUS, THICKNESS = 0.02, 0.006  # [m]

SCENE = """
name: sink
dt: 0.0005
until: {until}
components:
  body:
    type: RigidBody
    shape: {shape}
    radius: {radius}
    thickness: {thickness}
    density: {density}
    position: [0.2, 0.2, -0.2]
  pond:
    type: WaterSurface
    nx: 40
    ny: 40
    cell: 0.01
    depth: 0.5
    boundary: absorbing
    every: 4
    field_rate: 0
  coupler:
    type: WaterCoupler
    effects: [displacement, buoyancy, pressure, friction{added}]
connections:
  - body.state -> coupler.body
  - pond.patch -> coupler.water
  - {{from: coupler.wrench, to: body.wrench, delay: 1, initial: {{force: [0, 0, 0], torque: [0, 0, 0]}}}}
  - {{from: coupler.occupied, to: pond.occupied, delay: 1, initial: {{i0: 0, j0: 0, b: []}}}}
  - {{from: coupler.request, to: pond.request, delay: 1, initial: {{x_min: 1, x_max: 0, y_min: 1, y_max: 0}}}}
{connection}
"""
CONNECTION = ("  - {from: coupler.added_mass, to: body.added_mass, delay: 1, "
              "initial: {axial: 0, radial: 0, axial_inertia: 0, diameter_inertia: 0}}")


def sinking(shape: str, added_mass: bool, until: float, density: float = DENSITY
            ) -> tuple[dict[int, float], dict[int, float]]:
    """A body released at rest 20 cm under a still pond: its vertical velocity and its energy (kinetic
    plus potential plus what the water took, the coupler's books) by time [ns]."""
    text = SCENE.format(until=until, shape=shape, radius=RADIUS, thickness=THICKNESS, density=density,
                        added=", added_mass" if added_mass else "", connection=CONNECTION if added_mass else "")
    log = Books()
    Simulation(loads(text), observers=[log]).run()
    return log.vz, {t: log.energy[t] + log.water[t] for t in log.water if t in log.energy}


class Books(BaseObserver):
    def __init__(self) -> None:
        self.vz: dict[int, float] = {}
        self.energy: dict[int, float] = {}
        self.water: dict[int, float] = {}

    def on_exchange(self, time_ns, component, port, msg) -> None:
        if port == "state":
            self.vz[time_ns] = float(msg.velocity[2])
            self.energy[time_ns] = msg.kinetic_energy + msg.potential_energy
        elif port == "contact":
            self.water[time_ns] = msg.dissipated_energy


def acceleration(vz: dict[int, float]) -> float:
    """The mean vertical acceleration [m/s^2] from 5 to 15 ms after the release (after the first
    step, which the coupler's answer reaches a step late, and while the drag is below 0.4% of the
    weight in water)."""
    return (vz[15_000_000] - vz[5_000_000]) / 0.01


@pytest.mark.parametrize(("shape", "added"), [
    ("sphere", 0.5 * RHO * 4.0 / 3.0 * math.pi * RADIUS**3),  # half the water it displaces
    ("disk", 8.0 / 3.0 * RHO * RADIUS**3),  # falling broadside: 2.7 times the slate's own mass
])
def test_a_body_released_under_water_sinks_as_body_and_water_together(shape, added):
    """Released at rest, a = g (M - rho V) / (M + M_a) (potential flow), within 0.5%; without the
    effect, g (M - rho V) / M, 19% (sphere) and 2.1 times (disk) faster."""
    volume = 4.0 / 3.0 * math.pi * RADIUS**3 if shape == "sphere" else math.pi * RADIUS**2 * THICKNESS
    mass = DENSITY * volume
    exact = -G * (mass - RHO * volume) / (mass + added)
    assert acceleration(sinking(shape, True, 0.02)[0]) == pytest.approx(exact, rel=5e-3)
    assert acceleration(sinking(shape, False, 0.02)[0]) == pytest.approx(-G * (mass - RHO * volume) / mass,
                                                                          rel=2.5e-2)


def test_a_ball_lighter_than_its_added_mass_rises_steadily():
    """A cork-light ball (200 kg/m^3: its added mass is 2.5 times its own) released under water rises
    at g (rho V - M) / (M + M_a) = 11.2 m/s^2, not at 39 m/s^2; the force held a step late would
    overshoot and grow (the added-mass instability of partitioned schemes), taken by the body it
    cannot."""
    mass = 200.0 * 4.0 / 3.0 * math.pi * RADIUS**3
    water = RHO * 4.0 / 3.0 * math.pi * RADIUS**3
    vz, _ = sinking("sphere", True, 0.02, density=200.0)
    rising = (vz[8_000_000] - vz[3_000_000]) / 0.005  # earlier than the heavy ones: its drag grows faster
    assert rising == pytest.approx(G * (water - mass) / (mass + 0.5 * water), rel=1e-2)
    steps = sorted(vz)
    assert all(vz[b] > vz[a] for a, b in itertools.pairwise(steps[2:]))  # speeding up, no ringing


@pytest.mark.parametrize("shape", ["sphere", "disk"])
def test_the_energy_the_water_carries_along_is_in_the_books(shape):
    """Kinetic plus potential energy plus what the coupler says the water took stays constant to
    round-off over 0.3 s of sinking (without the added mass's own work it drifts by 1e-2 J for the
    sphere: the water set moving)."""
    _, total = sinking(shape, True, 0.3)
    values = list(total.values())
    assert len(values) > 500
    assert max(values) - min(values) < 1e-12


def test_the_body_takes_the_water_along_its_axis_and_across_it_apart():
    """(M + M_a) a = F: along the axis with the axial added mass, across it with the radial one;
    torques about the axis and about a diameter likewise."""
    axis = (0.0, 0.0, 1.0)
    force, torque = AddedMass(2.0, 6.0, 5.0, 0.0).carried(2.0, (3.0, 3.0, 5.0), axis, (1.0, 2.0, 4.0),
                                                          (6.0, 9.0, 10.0))
    assert force == pytest.approx((0.25, 0.5, 2.0))  # across: 2 / (2 + 6); along: 2 / (2 + 2)
    assert torque == pytest.approx((6.0, 9.0, 5.0))  # about a diameter: unchanged; about the axis: 5 / 10


def test_the_added_mass_comes_in_as_the_body_goes_under():
    """Potential-flow values wholly under water, scaled by the submerged share (0 at the surface)."""
    disk = full_added_mass(Shape.DISK, 0.05, RHO)
    assert (disk.axial, disk.radial, disk.axial_inertia) == (pytest.approx(8.0 / 3.0 * RHO * 0.05**3), 0.0, 0.0)
    assert disk.diameter_inertia == pytest.approx(16.0 / 45.0 * RHO * 0.05**5)
    assert scaled(disk, 0.5).axial == pytest.approx(0.5 * disk.axial)
    assert not any((scaled(disk, 0.0).axial, scaled(disk, 0.0).diameter_inertia))


def test_an_added_mass_that_reaches_no_body_is_refused():
    """Named among the effects but not connected, the added mass would silently do nothing."""
    text = SCENE.format(until=0.01, shape="sphere", radius=RADIUS, thickness=THICKNESS, density=DENSITY,
                        added=", added_mass", connection="")
    with pytest.raises(ScenarioError, match=r"components\.coupler: its output 'added_mass' feeds nothing, but "
                                            r"effect added_mass acts only through it"):
        loads(text)
