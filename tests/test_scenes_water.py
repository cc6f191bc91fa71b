"""The water-coupling scenes run through the real loader and scheduler and obey their physics:
float_sphere, tilted_float, ball_wake, scripted_skim and the reference skip (scenarios/*.yaml).

Wiring shared by every scene (a body, a pond, a coupler; delayed edges close the loops)::

    body.state --> coupler.body        coupler.wrench   --(delay)--> body.wrench
    pond.patch --> coupler.water       coupler.occupied --(delay)--> pond.occupied
                                       coupler.request  --(delay)--> pond.request
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from components.coupler.forces import C_MIN
from components.rigid.script import Keyframes
from cosim.scenario import load
from cosim.scheduler import BaseObserver, Simulation

ROOT = Path(__file__).resolve().parent.parent
SCENES = ROOT / "scenarios"
EFFECTS = ["displacement", "buoyancy", "pressure", "friction", "wave_drag"]


class Channels(BaseObserver):
    """Keeps every (time [s], message) published on the watched ``component.port`` channels, and
    the volume of the named ponds after each of their steps."""

    def __init__(self, *names: str, ponds: dict | None = None):
        self.seen: dict[str, list] = {name: [] for name in names}
        self.ponds = ponds or {}
        self.volumes: dict[str, list[float]] = {name: [] for name in self.ponds}

    def __getitem__(self, name: str) -> list:
        return self.seen[name]

    def on_exchange(self, time_ns, component, port, msg):
        key = f"{component}.{port}"
        if key in self.seen:
            self.seen[key].append((time_ns / 1e9, msg))
        if port == "patch" and component in self.ponds:
            self.volumes[component].append(self.ponds[component].volume())


def run(scene_name: str, *channels: str, overrides=(), ponds=()):
    """Run a scene to its end; return the simulation and the watched channels."""
    scene = load(SCENES / f"{scene_name}.yaml", overrides=list(overrides))
    sim = Simulation(scene)
    watch = Channels(*channels, ponds={name: sim.components[name] for name in ponds})
    sim.observers.append(watch)
    result = sim.run()
    assert result.status in ("ok", "stopped"), result.reason
    return sim, watch


def window(series, t0, t1=math.inf):
    """The messages of a channel published in [t0, t1) [s]."""
    return [m for t, m in series if t0 <= t < t1]


def cap_fraction(radius: float, depth: float) -> float:
    """Volume fraction of a sphere below a level ``depth`` [m] above its lowest point."""
    d = min(max(depth, 0.0), 2.0 * radius)
    return d * d * (3.0 * radius - d) / (4.0 * radius**3)


# --- float_sphere -------------------------------------------------------------------------------

def test_float_sphere_light_floats_at_its_density_ratio_and_heavy_rests_on_the_bottom():
    """float_sphere: the pine ball (relative density 0.6) settles with 60% of its volume under water,
    within 2% on 1 cm columns, both as the coupler sums it and from its height against the water;
    the granite ball sinks, lands on the bed and the stage monitor reports it at rest there."""
    sim, seen = run("float_sphere", "pine.state", "pine_water.contact", "granite.state",
                    "granite_stages.stage", "bottom.contact")
    radius = 0.05
    late = window(seen["pine.state"], 5.0)
    reported = np.mean([m.submerged_fraction for m in window(seen["pine_water.contact"], 5.0)])
    assert reported == pytest.approx(0.6, rel=0.02)
    pond = sim.components["pine_pond"]
    g = pond.grid
    x = g.origin_x + np.arange(g.nx) * g.cell
    y = g.origin_y + np.arange(g.ny) * g.cell
    ring = np.hypot(*np.meshgrid(x, y)) > 4 * radius  # the water away from the ball
    level = float(pond.height[ring].mean())
    geometric = np.mean([cap_fraction(radius, level - (m.position[2] - radius)) for m in late])
    assert geometric == pytest.approx(0.6, rel=0.02)
    assert max(abs(m.velocity[2]) for m in late) < 0.005  # settled: under 5 mm/s of bobbing left

    labels = [m.label for _, m in seen["granite_stages.stage"]]
    assert labels[-2:] == ["sink", "rest"]
    resting = window(seen["granite.state"], 4.0)
    assert all(m.position[2] == pytest.approx(-0.3 + 0.03, abs=1e-4) for m in resting)
    assert all(m.speed < 0.01 for m in resting)
    assert all(m.in_contact for m in window(seen["bottom.contact"], 4.0))


CORK_DROP = """
name: cork_drop
dt: 0.0005
until: 0.25
components:
  pond: {type: WaterSurface, nx: 80, ny: 80, cell: 0.01, depth: 0.3, origin_x: 0.005, origin_y: 0.005,
         boundary: absorbing, every: 2}
  s: {type: RigidBody, shape: sphere, radius: 0.05, density: 100, position: [0.4, 0.4, 0.1]}
  s_water: {type: WaterCoupler}
  s_stages: {type: StageMonitor, stop_after: 0}
connections:
  - s.state -> s_water.body
  - pond.patch -> s_water.water
  - {from: s_water.wrench, to: s.wrench, delay: 1, initial: {force: [0, 0, 0], torque: [0, 0, 0]}}
  - {from: s_water.occupied, to: pond.occupied, delay: 1, initial: {i0: 0, j0: 0, b: []}}
  - {from: s_water.request, to: pond.request, delay: 1, initial: {x_min: 1, x_max: 0, y_min: 1, y_max: 0}}
  - s.state -> s_stages.body
  - s_water.contact -> s_stages.water
"""


def test_a_cork_ball_dropped_onto_the_water_floats_and_is_not_called_sunk():
    """A ball of 100 kg/m^3 dropped from 5 cm: its first wetted step (its lowest point at the surface,
    nothing under water, no buoyancy yet) was taken for water without buoyancy, and the monitor
    called it sunk, a final stage, while it bobbed up (the run then stopped 0.3 s later)."""
    from cosim.scenario import loads

    sim = Simulation(loads(CORK_DROP))
    watch = Channels("s_stages.stage", "s.state")
    sim.observers.append(watch)
    assert sim.run().status == "ok"
    labels = [m.label for _, m in watch["s_stages.stage"]]
    assert labels[0] == "approach" and labels[-1] == "float" and "sink" not in labels, labels


# --- tilted_float -------------------------------------------------------------------------------

def test_tilted_float_flattens_and_the_closed_basin_keeps_its_volume():
    """tilted_float: the wooden disk let go at 25 degrees is turned flat by the per-column buoyancy
    (under 1 degree after 3.5 s) and floats half immersed; the water volume of the reflecting basin
    stays constant to 1e-9 at every step while the disk pushes the water about."""
    _, seen = run("tilted_float", "disk.state", ponds=["pond"])
    states = seen["disk.state"]
    assert states[0][1].attack_angle_deg == pytest.approx(25.0)
    assert max(m.attack_angle_deg for m in window(states, 3.5)) < 1.0
    assert np.mean([m.position[2] for m in window(states, 3.5)]) == pytest.approx(0.0, abs=1e-3)
    volumes = np.array(seen.volumes["pond"])
    assert len(volumes) > 1000
    assert np.abs(volumes - volumes[0]).max() <= 1e-9 * volumes[0]


# --- ball_wake ----------------------------------------------------------------------------------

def _ball_run(until: float, snapshot: float, speed: float | None = None):
    """Run ball_wake to ``until`` [s]; return the ball's horizontal speeds (one per step), and the
    surface (ny, nx) [m] and the ball's x at ``snapshot`` [s]."""
    overrides = [f"until={until}"]
    if speed is not None:
        overrides.append(f"components.ball.velocity=[{speed}, 0, 0]")
    scene = load(SCENES / "ball_wake.yaml", overrides=overrides)
    sim = Simulation(scene)
    sim.initialize()
    ball, pond = sim.components["ball"], sim.components["pond"]
    speeds, surface, x = [], None, math.nan
    while sim.time_ns < scene.until_ns:
        sim.step()
        speeds.append(math.hypot(ball.state.velocity[0], ball.state.velocity[1]))
        if surface is None and sim.time_ns >= round(snapshot * 1e9):
            surface, x = pond.height, ball.state.position[0]
    return np.array(speeds), surface, x, pond.grid


def test_ball_wake_slows_the_ball_and_leaves_a_wake_behind_it():
    """ball_wake: after the start transient the pushed ball only slows down, from 1 m/s to below
    c_min (by 1.2 s: about 1.0 s, the ball riding on the water it pushes aside, which the scene's
    slow waves spread only slowly); while faster than the waves it leaves them behind: the surface
    it disturbed (the pushed run minus the same ball let go at rest, which removes the splash of
    putting it in) is rough along its path and still ahead of it and to the side."""
    dt = 0.001
    speeds, pushed, x, grid = _ball_run(1.2, 0.5)
    _, still, _, _ = _ball_run(0.5, 0.5, speed=0.0)
    start = round(0.05 / dt)
    below = int(np.argmax(speeds < C_MIN))
    assert speeds[below] < C_MIN and below * dt < 1.2
    assert np.all(np.diff(speeds[start:below + 1]) <= 0.0)

    wake = pushed - still
    r = 0.05
    xs = grid.origin_x + np.arange(grid.nx) * grid.cell
    ys = grid.origin_y + np.arange(grid.ny) * grid.cell
    gx, gy = np.meshgrid(xs, ys)
    length = x - 2 * r  # the path behind the ball, from its start at x = 0
    assert length > 0.1

    def rms(mask):
        return float(np.sqrt(np.mean(wake[mask] ** 2)))

    along = rms((gx > 0) & (gx < length) & (abs(gy) < 2 * r))
    ahead = rms((gx > x + 2 * r) & (gx < x + 2 * r + length) & (abs(gy) < 2 * r))
    aside = rms((gx > 0) & (gx < length) & (abs(gy - 0.35) < 2 * r))
    assert along > 1e-3  # millimetres of wake
    assert along > 100 * ahead
    assert along > 100 * aside


@pytest.mark.parametrize(("scene", "overrides"), [
    ("ball_wake", ["until=0.6", "components.coupler.effects=[displacement, buoyancy, pressure]"]),
    # the wave drag too: at the submerged centroid, below the centre, it rolled the pushed ball forward
    ("ball_wake", ["until=0.6", "components.coupler.effects=[displacement, buoyancy, pressure, wave_drag]"]),
    ("float_sphere", ["until=0.6", "components.pine.position=[0.0037, 0.0021, 0.03]",
                      "components.pine_water.effects=[displacement, buoyancy, pressure]"]),
])
def test_the_water_it_piles_up_lifts_a_ball_without_turning_it(scene, overrides):
    """The water's pressure on a sphere acts through its centre, the waves' too: without skin friction
    nothing turns a ball. The lift of the water a ball piles up (the mound) carried the torque of where the columns
    lie: the pushed ball of ball_wake spun backwards, 92% of its kinetic energy spin by the scene's end
    (-12.9 rad/s), and a pine ball let go a few millimetres off a column's centre turned."""
    sim = Simulation(load(SCENES / f"{scene}.yaml", ["record.visual_rate=0", *overrides]))
    sim.run()
    ball = sim.components["ball" if scene == "ball_wake" else "pine"].body_state()
    assert np.abs(ball.angular_velocity).max() < 1e-9


# --- scripted_skim ------------------------------------------------------------------------------

def test_scripted_skim_follows_its_script_while_the_water_lifts_it():
    """scripted_skim: the horizontal velocity, position and attitude follow the keyframes (to round-off);
    the vertical motion answers the water (thrown back up at the first contact, planing above the
    rest level, afloat once stopped); the closed basin keeps its volume to 1e-9."""
    sim, seen = run("scripted_skim", "disk.state", "coupler.contact", ponds=["pond"])
    params = sim.components["disk"].params
    speed, tilt = Keyframes(params.scripted_velocity), Keyframes(params.scripted_tilt_deg)
    states = seen["disk.state"]
    x0 = params.position[0]
    for t, m in states:
        vx, vy = speed.value(t)
        assert m.velocity[0] == pytest.approx(vx, abs=1e-12) and m.velocity[1] == pytest.approx(vy, abs=1e-12)
        assert m.position[0] == pytest.approx(x0 + speed.integral(t)[0], abs=1e-12)
        assert m.attack_angle_deg == pytest.approx(tilt.value(t)[0], abs=1e-9)

    first_wet = next(t for t, c in seen["coupler.contact"] if c.wetted)
    assert max(m.velocity[2] for m in window(states, first_wet, first_wet + 0.1)) > 0.2  # thrown up
    planing = [m.position[2] for m in window(states, 0.6, 1.0)]
    assert min(planing) > 0.01  # the centre rides 1 cm up: lifted by the pressure, not by buoyancy
    afloat = [c.submerged_fraction for c in window(seen["coupler.contact"], 2.0)]
    assert 0.5 < np.mean(afloat) < 0.9  # wood of relative density 0.7, rocked by the basin's waves

    volumes = np.array(seen.volumes["pond"])
    assert np.abs(volumes - volumes[0]).max() <= 1e-9 * volumes[0]


# --- the reference skip -------------------------------------------------------------------------

@pytest.fixture(scope="module")
def reference_skip():
    sim, _ = run("skip")
    return sim.components["stages"]


def test_reference_skip_skips_three_times_then_sinks(reference_skip):
    """skip: at least three skips, each approach -> hit -> slide -> fly-away, and then the stone sinks."""
    stages = reference_skip
    labels = [label for _, label in stages.timeline]
    assert stages.track.skips >= 3
    assert labels[:12] == ["approach", "hit", "slide", "fly-away"] * 3
    assert labels[-1] == "sink"
    assert [r.index for r in stages.records] == list(range(1, stages.track.skips + 1))
    assert all(r.speed_out < r.speed_in for r in stages.records)


def test_reference_skip_count_holds_at_half_the_step(reference_skip):
    """skip at dt / 2 (the stone and coupler step twice as often, the water at the same 2 ms): the
    skip count changes by at most one."""
    scene = load(SCENES / "skip.yaml")
    every = scene.components["pond"].every
    sim, _ = run("skip", overrides=[f"dt={scene.dt / 2!r}", f"components.pond.every={2 * every}"])
    assert sim.scene.components["pond"].every * sim.scene.dt == pytest.approx(every * scene.dt)
    halved = sim.components["stages"]
    assert abs(halved.track.skips - reference_skip.track.skips) <= 1
    assert [label for _, label in halved.timeline][-1] == "sink"


@pytest.mark.parametrize("removed", EFFECTS)
def test_each_effect_can_be_switched_off_alone(removed):
    """A short skip with one effect removed runs: without the pressure the stone does not skip and
    sinks; without displacement the pond stays flat; without friction or wave drag it keeps more
    speed; in every other case it skips as usual."""
    short = ["until=0.45"]
    kept = [e for e in EFFECTS if e != removed]
    sim, _ = run("held_skip", overrides=[*short, f"components.coupler.effects=[{','.join(kept)}]"])
    stages = sim.components["stages"]
    labels = [label for _, label in stages.timeline]
    if removed == "pressure":
        assert stages.track.skips == 0
        assert labels == ["approach", "hit", "sink"]
        return
    assert stages.track.skips == 2
    assert labels[:8] == ["approach", "hit", "slide", "fly-away"] * 2
    pond = sim.components["pond"]
    if removed == "displacement":
        assert np.abs(pond.height).max() == 0.0
    else:
        assert np.abs(pond.height).max() > 1e-4
    full, _ = run("held_skip", overrides=short)
    base = full.components["stages"].records[0].speed_out
    out = stages.records[0].speed_out
    if removed in ("friction", "wave_drag"):
        assert out > base
    else:
        assert out == pytest.approx(base, rel=0.01)


def test_a_scene_without_water_never_imports_the_water_components():
    """ground_bounce, run in a fresh interpreter, never imports components.water nor
    components.coupler."""
    code = (
        "import json, sys\n"
        "from cosim.runner import run_scene\n"
        "from cosim.scenario import load\n"
        f"scene = load({str(SCENES / 'ground_bounce.yaml')!r}, overrides=['until=0.2'])\n"
        "outcome = run_scene(scene, None, progress=False)\n"
        "print(json.dumps([outcome.result.status, sorted(m for m in sys.modules if m.startswith('components'))]))\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=ROOT)
    status, modules = json.loads(done.stdout.strip().splitlines()[-1])
    assert status == "ok"
    assert "components.rigid_body" in modules
    assert not [m for m in modules if m.startswith(("components.water", "components.coupler"))]
