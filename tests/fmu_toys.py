"""What the FMI tests share: the example wind-gust model, a private FMU cache for the session, and a
small scene in which the gust acts on a stone flying over no water (fast: no water, no coupler)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
GUST_MODEL = ROOT / "scenarios" / "models" / "wind_gust.py"
SKIP_SCENE = ROOT / "scenarios" / "held_skip.yaml"

GUST_MAPPING = """
    inputs:
      body: {type: BodyState, fields: {"velocity[0]": vx, "velocity[1]": vy, "velocity[2]": vz}}
    outputs:
      wrench: {type: Wrench, fields: {"force[0]": Fx, "force[1]": Fy, "force[2]": Fz}}"""

GUST_SCENE = """
name: gust_flight
dt: 0.001
until: 0.2
components:
  stone:
    type: RigidBody
    radius: 0.05
    thickness: 0.006
    density: 2650
    position: [0, 0, 1.0]
    velocity: [8.0, 0.0, 0.0]
    lock_attitude: true
  gust:
    type: FMU
    <SOURCE>
    every: 2
    start: <START>""" + GUST_MAPPING + """
connections:
  - stone.state -> gust.body
  - {from: gust.wrench, to: stone.wrench, delay: 1, initial: {force: [0, 0, 0], torque: [0, 0, 0]}}
record: {checkpoint_every: 0.05, visual_rate: 0}
"""


def gust_scene(source: str = f"model: {GUST_MODEL}", start: str = "{peak_speed: 8.0, start_time: 0.05, "
               "duration: 0.1}") -> str:
    """The gust scene with the FMU given as ``source`` (``model: ...`` or ``path: ...``)."""
    return GUST_SCENE.replace("<SOURCE>", source).replace("<START>", start)


@pytest.fixture(scope="session", autouse=True)
def fmu_cache(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """FMUs built during the tests go to a folder of their own (built once per session)."""
    folder = tmp_path_factory.mktemp("fmu-cache")
    old = os.environ.get("COSIM_FMU_CACHE")
    os.environ["COSIM_FMU_CACHE"] = str(folder)
    yield folder
    if old is None:
        os.environ.pop("COSIM_FMU_CACHE", None)
    else:
        os.environ["COSIM_FMU_CACHE"] = old
