"""Scripted stand-ins for the physics, for viewer, plot and render tests.

They publish the real message types along a known path, so a test can compare what the viewer
channels, figures and frames show with exactly what was published:

- ScriptedStone: a disk (or sphere) moving along x at a constant speed, bouncing in arcs with short
  dips below z = 0 (the contacts), tilted by a constant attack angle and spinning about its axis;
- ScriptedCoupler: WaterContact and Wrench reports while the stone's lowest point is under water;
- ScriptedPond: a WaterField with a travelling wave, larger than the drawn surface (decimation).

``SKIP_SCENE`` wires them with the real StageMonitor, with the reference scene's component names
(stone, pond, coupler, stages), so the shipped Foxglove layout applies to its recordings.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np

from components.messages import BodyState, Shape, WaterContact, WaterField, Wrench
from cosim.component import Component, Port
from cosim.params import param

G = 9.81  # [m/s^2]
DENSITY = 2600.0  # [kg/m^3], stone

SKIP_SCENE = """
name: toy_skip
dt: 0.001
until: 0.6
components:
  stone: {type: "tests.viewer_toys:ScriptedStone"}
  coupler: {type: "tests.viewer_toys:ScriptedCoupler"}
  stages: {type: StageMonitor, stop_after: 0}
  pond: {type: "tests.viewer_toys:ScriptedPond", every: 10}
connections:
  - stone.state -> coupler.body
  - stone.state -> stages.body
  - coupler.contact -> stages.water
record: {visual_rate: 30, checkpoint_every: 0}
"""


def _quat_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    w1, x1, y1, z1 = a
    w2, x2, y2, z2 = b
    return np.array([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                     w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2])


def arc_height(t: float, p: ScriptedStone.Params) -> tuple[float, float]:
    """(z [m], dz/dt [m/s]) of the scripted path at time t [s]: a falling quarter arc, then dips
    of ``dip`` below the surface lasting ``contact`` and arcs shrinking by ``decay`` each skip."""
    if t < p.descent:
        w = 0.5 * math.pi / p.descent
        return p.height * math.cos(w * t), -p.height * w * math.sin(w * t)
    t -= p.descent
    flight, height = p.flight, p.height
    while True:
        if t < p.contact:
            w = math.pi / p.contact
            return -p.dip * math.sin(w * t), -p.dip * w * math.cos(w * t)
        t -= p.contact
        if t < flight:
            w = math.pi / flight
            return height * math.sin(w * t), height * w * math.cos(w * t)
        t -= flight
        flight *= p.decay
        height *= p.decay * p.decay


class ScriptedStone(Component):
    """Publishes a BodyState along the scripted skipping path (inputs ignored)."""

    @dataclass(frozen=True)
    class Params:
        shape: Literal["disk", "sphere"] = param("disk")
        radius: float = param(0.03, unit="m", gt=0)
        thickness: float = param(0.008, unit="m", ge=0)
        speed: float = param(4.0, unit="m/s")
        height: float = param(0.08, unit="m", gt=0)
        descent: float = param(0.1, unit="s", gt=0)
        flight: float = param(0.2, unit="s", gt=0)
        contact: float = param(0.02, unit="s", gt=0)
        dip: float = param(0.004, unit="m", ge=0)
        decay: float = param(0.8, gt=0)
        attack_deg: float = param(20.0)
        spin: float = param(30.0, unit="rad/s")

    outputs = {"state": Port(BodyState)}

    def setup(self) -> None:
        p = self.params
        self.shape = Shape.DISK if p.shape == "disk" else Shape.SPHERE
        if self.shape is Shape.DISK:
            volume = math.pi * p.radius ** 2 * p.thickness
            self.mass = DENSITY * volume
            self.inertia = np.array([self.mass * (3 * p.radius ** 2 + p.thickness ** 2) / 12] * 2
                                    + [self.mass * p.radius ** 2 / 2])
        else:
            self.mass = DENSITY * 4 / 3 * math.pi * p.radius ** 3
            self.inertia = np.full(3, 0.4 * self.mass * p.radius ** 2)

    def state_at(self, t: float) -> BodyState:
        p = self.params
        z, vz = arc_height(t, p)
        a = math.radians(p.attack_deg)
        tilt = np.array([math.cos(a / 2), 0.0, math.sin(a / 2), 0.0])
        turn = p.spin * t
        spin = np.array([math.cos(turn / 2), 0.0, 0.0, math.sin(turn / 2)])
        q = _quat_mul(tilt, spin)
        omega = np.array([math.sin(a), 0.0, math.cos(a)]) * p.spin
        v = np.array([p.speed, 0.0, vz])
        speed = float(np.linalg.norm(v))
        kinetic = 0.5 * self.mass * speed ** 2 + 0.5 * float(self.inertia[2]) * p.spin ** 2
        attack = p.attack_deg if self.shape is Shape.DISK else 0.0
        return BodyState(position=np.array([p.speed * t, 0.0, z]), orientation=q, velocity=v,
                         angular_velocity=omega, shape=self.shape, radius=p.radius,
                         thickness=p.thickness if self.shape is Shape.DISK else 0.0, mass=self.mass,
                         inertia=self.inertia.copy(), attack_angle_deg=attack, speed=speed,
                         kinetic_energy=kinetic, potential_energy=self.mass * G * z)

    def initial_outputs(self):
        return {"state": self.state_at(0.0)}

    def _step_impl(self, t, dt, inputs):
        return {"state": self.state_at(t + dt)}


class ScriptedCoupler(Component):
    """Reports contact while the stone's lowest point is below z = 0, with made-up forces."""

    inputs = {"body": Port(BodyState, required=True)}
    outputs = {"contact": Port(WaterContact), "wrench": Port(Wrench)}

    def setup(self) -> None:
        self.dissipated = 0.0

    def get_state(self):
        return {"dissipated": self.dissipated}  # (it publishes it: a restart must carry it on)

    def set_state(self, state):
        self.dissipated = float(state["dissipated"])

    def _step_impl(self, t, dt, inputs):
        body: BodyState = inputs["body"]
        lowest = float(body.position[2]) - body.radius * math.sin(math.radians(body.attack_angle_deg))
        depth = -lowest
        zero = np.zeros(3)
        if depth > 0:
            pressure = np.array([0.0, 0.0, 4000.0 * depth * body.speed])
            friction = np.array([-0.2 * pressure[2], 0.0, 0.0])
            buoyancy = np.array([0.0, 0.0, 1000.0 * G * depth * math.pi * body.radius ** 2])
            drag = np.array([-0.05 * body.speed, 0.0, 0.0])
            self.dissipated += float(-(friction[0] + drag[0]) * body.velocity[0] * dt)
            contact = WaterContact(True, min(1.0, depth / (2 * body.radius)), math.pi * body.radius ** 2,
                                   buoyancy, pressure, friction, drag, depth, self.dissipated)
            force = pressure + friction + buoyancy + drag
        else:
            contact = WaterContact(False, 0.0, 0.0, zero, zero, zero, zero, depth, self.dissipated)
            force = zero
        return {"contact": contact, "wrench": Wrench(force, np.zeros(3))}


class ScriptedPond(Component):
    """A WaterField with a wave travelling along x: h = amplitude sin(k (x - c t)) over nx x ny cells."""

    @dataclass(frozen=True)
    class Params:
        nx: int = param(150, gt=1)
        ny: int = param(50, gt=1)
        cell: float = param(0.02, unit="m", gt=0)
        origin_x: float = param(-0.5, unit="m")
        origin_y: float = param(-0.5, unit="m")
        amplitude: float = param(0.003, unit="m")
        wavelength: float = param(0.3, unit="m", gt=0)
        celerity: float = param(0.5, unit="m/s")

    outputs = {"field": Port(WaterField)}

    def field_at(self, t: float) -> WaterField:
        p = self.params
        x = p.origin_x + p.cell * np.arange(p.nx)
        y = p.origin_y + p.cell * np.arange(p.ny)
        k = 2 * math.pi / p.wavelength
        h = p.amplitude * np.sin(k * (x[None, :] - p.celerity * t)) * np.exp(-(y[:, None] / 0.4) ** 2)
        return WaterField(cell=p.cell, origin_x=p.origin_x, origin_y=p.origin_y, height=h,
                          volume=float(np.sum(h + 1.0) * p.cell ** 2), energy=float(np.sum(h ** 2)))

    def initial_outputs(self):
        return {"field": self.field_at(0.0)}

    def _step_impl(self, t, dt, inputs):
        return {"field": self.field_at(t + dt)}


def record_skip(path, overrides: list[str] | None = None, **run_options):
    """Run SKIP_SCENE (with ``--set``-style overrides) into the recording ``path``; return the outcome."""
    from cosim.runner import run_scene
    from cosim.scenario import loads

    return run_scene(loads(SKIP_SCENE, overrides=overrides), path, progress=False, **run_options)
