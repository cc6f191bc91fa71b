"""An FMI 3.0 co-simulation FMU as a component: Float64, Int32 variables on typed ports, doStep,
state saved and restored through FMI 3.0's own serialization.

    stone.state --> spring.body        spring.wrench -(delay)-> stone.wrench

The spring is built in the test with pythonfmu3 (FMI 3.0), skipped where it is not installed.
"""

from __future__ import annotations

import subprocess
import sys

import pytest

pytest.importorskip("fmpy")
pytest.importorskip("pythonfmu3")

from components.messages import Stage, Wrench
from cosim.record.reader import Recording
from cosim.replay import replay_component, restart_simulation
from cosim.runner import run_scene
from cosim.scenario import load

MODEL = '''
from pythonfmu3 import Fmi3Causality, Fmi3Slave, Fmi3Variability, Float64, Int32

globals().setdefault("_held_namespaces", []).append(globals())  # see scenarios/models/wind_gust.py


class Spring3(Fmi3Slave):
    """F = -k x, and the number of steps taken."""

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.time, self.k, self.x, self.F, self.steps = 0.0, 2.0, 0.0, 0.0, 0
        self.register_variable(Float64("time", causality=Fmi3Causality.independent,
                                       variability=Fmi3Variability.continuous))
        self.register_variable(Float64("k", causality=Fmi3Causality.parameter, variability=Fmi3Variability.tunable))
        self.register_variable(Float64("x", causality=Fmi3Causality.input))
        self.register_variable(Float64("F", causality=Fmi3Causality.output))
        self.register_variable(Int32("steps", causality=Fmi3Causality.output))

    def do_step(self, current_time, step_size):
        self.F = -self.k * self.x
        self.steps += 1
        return True
'''

SCENE = """
name: spring3
dt: 0.001
until: 0.05
components:
  stone: {type: RigidBody, position: [0, 0, 1.0], lock_attitude: true}
  spring:
    type: FMU
    path: Spring3.fmu
    start: {k: 3.0}
    inputs: {body: {type: BodyState, fields: {"position[2]": x}}}
    outputs:
      wrench: {type: Wrench, fields: {"force[2]": F}}
      count: {type: Stage, fields: {skips: steps, x: F}}
connections:
  - stone.state -> spring.body
  - {from: spring.wrench, to: stone.wrench, delay: 1, initial: {force: [0, 0, 0], torque: [0, 0, 0]}}
record: {checkpoint_every: 0.01, visual_rate: 0}
"""


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    folder = tmp_path_factory.mktemp("fmi3")
    (folder / "spring3.py").write_text(MODEL)
    subprocess.run([sys.executable, "-m", "pythonfmu3", "build", "-f", "spring3.py", "-d", ".", "--handle-state",
                    "--serialize-state"], cwd=folder, check=True, capture_output=True, timeout=300)
    (folder / "spring3.yaml").write_text(SCENE)
    outcome = run_scene(load(folder / "spring3.yaml"), folder / "spring3.mcap", progress=False)
    assert outcome.result.status == "ok", outcome.result.reason
    return Recording(outcome.recording)


def test_an_fmi3_fmu_steps_with_its_start_values_and_mapped_ports(recorded):
    wrenches = dict(recorded.messages("/spring/wrench", Wrench))
    counts = recorded.messages("/spring/count", Stage)
    assert counts[-1] == (50_000_000, counts[-1][1]) and counts[-1][1].skips == 50  # one doStep per ms
    last_x = wrenches[50_000_000].force[2] / -3.0  # k = 3 from the scene, not the model's 2
    assert 0.9 < last_x < 1.0  # the stone's height at the last step's start, falling from 1 m
    assert counts[-1][1].x == wrenches[50_000_000].force[2]


def test_an_fmi3_fmu_replays_bit_for_bit_and_restarts_from_its_serialized_state(recorded, tmp_path):
    assert replay_component(recorded, "spring").ok
    sim, stamp = restart_simulation(recorded, 20_000_000)
    outcome = run_scene(sim.scene, tmp_path / "again.mcap", simulation=sim, progress=False)
    again = Recording(outcome.recording).messages("/spring/count", Stage)
    assert stamp == 20_000_000 and again[-1][1].skips == 50  # the step counter came back with the state
    assert again[-1][1].x == recorded.messages("/spring/count", Stage)[-1][1].x
