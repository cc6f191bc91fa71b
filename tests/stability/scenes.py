"""Building and running the hard-case scenes: one pond scene in YAML, changed by ``--set``-style overrides.

``POND`` is a small version of the reference skip (a locked slate disk over 1 cm cells, a closed
basin so the water's volume is an exact invariant); ``BOTTOM`` adds a SolidGround at the pond's bed,
wired both ways (its impulses into the stone's impulse port, its contact report to the monitor)::

    stone.state --> coupler.body      pond.patch --> coupler.water
    coupler.wrench -(delay)-> stone.wrench            coupler.occupied/request -(delay)-> pond
    stone.state --> stages.body       coupler.contact --> stages.water
    stone.state --> bed.body          bed.impulse -(delay)-> stone.impulse   bed.contact --> stages.ground

:func:`run` runs a scene and keeps what the checks need: the stone's state and the water's volume
and energy at a fixed sampling interval, the monitor's metrics and the components themselves.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from cosim.runner import collect_metrics
from cosim.scenario import Scene, loads
from cosim.scheduler import BaseObserver, RunResult, Simulation

G = 9.81  # [m/s^2]
RHO_WATER = 1000.0  # [kg/m^3]

POND = """
name: hard_case
dt: 0.0002
until: 1.0
on_unstable: substep
components:
  stone:
    type: RigidBody
    shape: disk
    radius: 0.05
    thickness: 0.006
    density: 2650
    position: [0.3, 0.5, 0.15]
    velocity: [7.88, 0.0, -1.39]
    tilt_deg: 20
    lock_attitude: true
  pond:
    type: WaterSurface
    nx: 300
    ny: 100
    cell: 0.01
    depth: 0.5
    boundary: reflecting
    every: 10
  coupler:
    type: WaterCoupler
    effects: [displacement, buoyancy, pressure, friction, wave_drag]
  stages:
    type: StageMonitor
connections:
  - stone.state -> coupler.body
  - pond.patch -> coupler.water
  - {from: coupler.wrench, to: stone.wrench, delay: 1, initial: {force: [0, 0, 0], torque: [0, 0, 0]}}
  - {from: coupler.occupied, to: pond.occupied, delay: 1, initial: {i0: 0, j0: 0, b: []}}
  - {from: coupler.request, to: pond.request, delay: 1, initial: {x_min: 1, x_max: 0, y_min: 1, y_max: 0}}
  - stone.state -> stages.body
  - coupler.contact -> stages.water
"""

BOTTOM = POND.replace("""  stages:
    type: StageMonitor
""", """  stages:
    type: StageMonitor
  bed:
    type: SolidGround
    point: [0, 0, -0.5]      # the pond's bed
    restitution: 0.3
""") + """  - stone.state -> bed.body
  - {from: bed.impulse, to: stone.impulse, delay: 1,
     initial: {linear: [0, 0, 0], angular: [0, 0, 0], correction: [0, 0, 0]}}
  - bed.contact -> stages.ground
"""


def scene(*overrides: str, text: str = POND) -> Scene:
    """The scene ``text`` with ``key.path=value`` overrides (as ``cosim run --set``), validated."""
    return loads(text, source="hard_case", overrides=list(overrides))


def throw(speed: float, angle_deg: float) -> str:
    """The override for a throw at ``speed`` [m/s], ``angle_deg`` below the horizontal, along +x."""
    a = math.radians(angle_deg)
    return f"components.stone.velocity=[{speed * math.cos(a)!r}, 0.0, {-speed * math.sin(a)!r}]"


class Samples(BaseObserver):
    """The stone's state and the water's volume and energy every ``every_ns`` of simulated time."""

    def __init__(self, every_ns: int):
        self.every_ns = every_ns
        self.t: list[float] = []
        self.position: list[np.ndarray] = []
        self.velocity: list[np.ndarray] = []
        self.energy: list[float] = []  # the stone's kinetic + potential energy [J]
        self.volume: list[float] = []  # the water's volume [m^3]
        self.water_energy: list[float] = []  # the water's lattice energy [J]

    def on_initialized(self, sim: Simulation) -> None:
        self.sample(sim)

    def on_step_complete(self, sim: Simulation) -> None:
        if sim.time_ns % self.every_ns == 0:
            self.sample(sim)

    def sample(self, sim: Simulation) -> None:
        state = sim.components["stone"].body_state()
        pond = sim.components["pond"]
        self.t.append(sim.time_ns / 1e9)
        self.position.append(state.position)
        self.velocity.append(state.velocity)
        self.energy.append(state.kinetic_energy + state.potential_energy)
        self.volume.append(pond.volume())
        self.water_energy.append(pond.energy())


@dataclass
class Run:
    """A finished hard-case run: result, components, samples (as arrays) and the monitor's metrics."""

    result: RunResult
    sim: Simulation
    t: np.ndarray
    position: np.ndarray  # (n, 3) [m]
    velocity: np.ndarray  # (n, 3) [m/s]
    energy: np.ndarray  # (n,) stone's mechanical energy [J]
    volume: np.ndarray  # (n,) [m^3]
    water_energy: np.ndarray  # (n,) [J]
    metrics: dict = field(default_factory=dict)

    @property
    def stone(self):
        return self.sim.components["stone"]

    @property
    def pond(self):
        return self.sim.components["pond"]

    @property
    def coupler(self):
        return self.sim.components["coupler"]


def run(sc: Scene, *, sample_every: float = 0.01) -> Run:
    """Run ``sc`` to its end (or its stop) with the stone and water sampled every ``sample_every`` s."""
    samples = Samples(round(sample_every * 1e9))
    sim = Simulation(sc, observers=[samples])
    result = sim.run()
    samples.sample(sim)  # the end state, wherever the run stopped
    metrics = collect_metrics(sim)
    return Run(result, sim, np.array(samples.t), np.array(samples.position), np.array(samples.velocity),
               np.array(samples.energy), np.array(samples.volume), np.array(samples.water_energy),
               {k.split(".", 1)[1]: v for k, v in metrics.items() if k.startswith("stages.")})


# --- checks shared by the cases -------------------------------------------------------------------

def assert_finite(r: Run) -> None:
    """Every sampled figure and the final state of the stone and the water are finite."""
    for name in ("position", "velocity", "energy", "volume", "water_energy"):
        assert np.isfinite(getattr(r, name)).all(), f"non-finite {name}"
    assert np.isfinite(r.pond.height).all() and np.isfinite(r.pond.velocity).all()
    assert all(math.isfinite(c) for c in r.stone.state.position + r.stone.state.velocity)


def assert_volume_kept(r: Run, rel: float = 1e-9) -> None:
    """A closed basin keeps its water: every sampled volume within ``rel`` of the first."""
    drift = np.abs(r.volume - r.volume[0]).max() / r.volume[0]
    assert drift <= rel, f"water volume drifted by {drift:.3g} (relative)"


def assert_stone_never_gains_energy(r: Run, slack: float = 1e-6) -> None:
    """The water only takes energy from the stone: its kinetic + potential energy never exceeds the
    start by more than ``slack`` of the stone's weight times 1 m [J]."""
    weight = r.stone.body.mass * G
    assert r.energy.max() <= r.energy[0] + slack * weight, \
        f"the stone gained {r.energy.max() - r.energy[0]:.3g} J"


def assert_water_energy_not_growing(r: Run, after: float, factor: float = 1.1) -> None:
    """Once the source has stopped (from ``after`` [s] on), the water's energy never exceeds ``factor``
    times what it had then (a closed, undamped basin keeps it; the implicit model loses some)."""
    k = int(np.searchsorted(r.t, after))
    assert k < len(r.t) - 1, "the run ended before the check starts"
    ref = r.water_energy[k]
    peak = r.water_energy[k:].max()
    assert peak <= factor * ref + 1e-12, f"water energy grew from {ref:.4g} J to {peak:.4g} J after t = {after} s"
