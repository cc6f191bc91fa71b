"""What the command line tells a user is true: its help's example works, a variant run does not
replace the scene's own recording, and replay refuses settings it would ignore."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

from cosim.cli import build_parser, main

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.parametrize("command", ["run", "validate"])
def test_the_set_example_in_the_help_is_accepted_by_the_reference_scene(command, capsys):
    """The `--set` example `run --help` and `validate --help` give is a key the reference skip has."""
    help_text = build_parser()._subparsers._group_actions[0].choices[command].format_help()
    example = re.search(r"e\.g\.\s+(\S+=\S+)", help_text).group(1)
    assert main(["validate", str(ROOT / "scenarios" / "skip.yaml"), "--set", example]) == 0
    assert "ok - scene" in capsys.readouterr().out


def test_a_run_with_set_and_no_output_does_not_replace_the_scenes_own_recording(tmp_path, monkeypatch):
    """`cosim run S.yaml --set ...` writes runs/<scene>-set-<hash>.mcap, not runs/<scene>.mcap; the
    same overrides give the same name, other overrides another."""
    monkeypatch.chdir(tmp_path)
    scene = str(ROOT / "scenarios" / "ping_pong.yaml")
    assert main(["run", scene, "-q"]) == 0
    own = (tmp_path / "runs" / "ping_pong.mcap").read_bytes()
    assert main(["run", scene, "-q", "--set", "until=1"]) == 0
    assert main(["run", scene, "-q", "--set", "until=2"]) == 0
    assert (tmp_path / "runs" / "ping_pong.mcap").read_bytes() == own
    variants = sorted(p.name for p in (tmp_path / "runs").glob("ping_pong-set-*.mcap"))
    assert len(variants) == 2
    # nor one shortened (--until) or thinned (--record-every): they replaced runs/ping_pong.mcap
    assert main(["run", scene, "-q", "--until", "1"]) == 0
    assert main(["run", scene, "-q", "--record-every", "5"]) == 0
    assert (tmp_path / "runs" / "ping_pong.mcap").read_bytes() == own
    assert len(list((tmp_path / "runs").glob("ping_pong-set-*.mcap"))) == 4


@pytest.mark.parametrize("flags", [["--set", "dt=0.0001"], ["-o", "x.mcap"], ["--until", "1"]])
def test_replay_without_from_refuses_the_settings_of_a_restart(tmp_path, flags):
    """Without --from, replay re-runs each component on its recorded inputs: a --set, -o or --until
    would be ignored, so it is refused in one line naming the flag, exit 2."""
    recording = tmp_path / "pp.mcap"
    assert main(["run", str(ROOT / "scenarios" / "ping_pong.yaml"), "-q", "-o", str(recording)]) == 0
    done = subprocess.run([sys.executable, "-m", "cosim.cli", "replay", str(recording), *flags],
                          capture_output=True, text=True, cwd=tmp_path)
    assert done.returncode == 2
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and flags[0] in lines[0] and "--from" in lines[0]


def test_inspect_prints_numbers_rounded_for_reading(tmp_path, capsys):
    """The stage timeline shows positions to 4 significant digits (x 0.8831, not 0.8831200000000052)."""
    recording = tmp_path / "skip.mcap"
    assert main(["run", str(ROOT / "scenarios" / "skip.yaml"), "-q", "-o", str(recording), "--until", "0.2"]) == 0
    capsys.readouterr()
    assert main(["inspect", str(recording)]) == 0
    timeline = [line for line in capsys.readouterr().out.splitlines() if "/stages/stage:" in line]
    assert timeline
    for line in timeline:
        for number in re.findall(r"x (\S+?)(?:,|$)", line):
            assert len(number.lstrip("-").replace(".", "").lstrip("0")) <= 4, line


def test_a_restart_counts_its_simulated_time_and_steps_from_the_checkpoint(tmp_path, capsys):
    """`replay --from 0.5 --set dt=...` simulates from the 0.5 s checkpoint: the summary says how
    long from there, in how many of its own steps, and its real-time factor uses that span."""
    recording = tmp_path / "skip.mcap"
    assert main(["run", str(ROOT / "scenarios" / "skip.yaml"), "-q", "-o", str(recording), "--until", "0.8"]) == 0
    capsys.readouterr()
    assert main(["replay", str(recording), "--from", "0.5", "--set", "dt=0.00025", "-q", "--until", "0.8",
                 "-o", str(tmp_path / "from.mcap")]) == 0
    out = capsys.readouterr().out
    line = next(x for x in out.splitlines() if x.strip().startswith("simulated"))
    assert "simulated 0.3 s from t = 0.5 s in 1200 steps of 0.25 ms" in line
    # its timeline says where what was in force at the restart is (a restart publishes changes only)
    assert main(["inspect", str(tmp_path / "from.mcap")]) == 0
    assert "    (a restart from t = 0.5 s: what was in force then, and what came before, is in the recording it " \
           "restarted from)" in capsys.readouterr().out.splitlines()


def test_inspect_dates_the_timeline_to_the_digit_of_the_runs_step(tmp_path, capsys):
    """At a 50 us step the held skip's touchdown is at 0.07415 s, as the run's summary says: inspect
    said 0.0741 s (four decimals whatever the step)."""
    recording = tmp_path / "fine.mcap"
    assert main(["run", str(ROOT / "scenarios" / "held_skip.yaml"), "--set", "dt=0.00005", "--set",
                 "components.pond.every=20", "--until", "0.08", "-o", str(recording)]) == 0
    summary = capsys.readouterr().out
    said = re.search(r"-> hit \((\S+) s\)", summary).group(1)
    assert len(said.split(".")[1]) == 5  # (a touchdown the coarser digits would round)
    assert main(["inspect", str(recording)]) == 0
    (row,) = [line for line in capsys.readouterr().out.splitlines() if "/stages/stage: hit" in line]
    assert row.split()[0] == said


@pytest.mark.parametrize("command", ["validate", "run"])
def test_a_command_given_a_sweep_file_says_it_is_one_and_how_to_run_it(command, capsys):
    """`cosim validate` or `cosim run` of a sweep file does not list its keys as unknown scene keys:
    one line says it is a sweep and names the command that runs it (exit 2; run listed 5 keys)."""
    sweep = str(ROOT / "scenarios" / "sweeps" / "magic_angle.yaml")
    assert main([command, sweep, "--no-record"][:3 if command == "run" else 2]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "sweep file" in err[0] and f"`cosim sweep {sweep}` (`--dry-run` checks it)" in err[0]


def test_a_flat_throw_called_sunk_has_sunk():
    """A flat throw (tilt 0) that the monitor calls 'sink' is under water and slow when the run ends;
    it does not resurface and plane on (a submerged stone swims, it does not plane)."""
    from cosim.scenario import load
    from cosim.scheduler import Simulation

    sim = Simulation(load(ROOT / "scenarios" / "held_skip.yaml", ["components.stone.tilt_deg=0"]))
    sim.run()
    state = sim.components["stone"].body_state()
    assert sim.components["stages"].stage.name == "SINK"
    assert state.position[2] < -0.05 and state.speed < 1.0


def test_a_steep_throw_counts_only_real_skips():
    """Thrown 45 deg down at 8 m/s, the stone skips once after a long contact that costs it most of its
    speed; no skip is a millisecond touch that changes nothing."""
    from cosim.scenario import load
    from cosim.scheduler import Simulation

    sim = Simulation(load(ROOT / "scenarios" / "held_skip.yaml", ["components.stone.velocity=[5.657, 0, -5.657]"]))
    sim.run()
    records = sim.components["stages"].records
    assert records
    for skip in records:
        assert skip.contact_time > 0.005
        assert skip.speed_out < 0.95 * skip.speed_in


def test_inspect_says_why_messages_outlast_the_runs_last_tick(tmp_path, capsys):
    """The pond steps every 4 ticks and stamps its outputs at its step's end: a run stopped at 0.2005 s
    (tick 401) holds a patch stamped 0.202 s. Inspect gives both times and says why, rather than a
    span that outlasts the status's end unexplained; a run ending on the pond's step says nothing."""
    for until, said in (("0.2005", "to t = 0.202 s: the last step of a component that steps every few ticks"),
                        ("0.2", None)):
        recording = tmp_path / f"skip{until}.mcap"
        assert main(["run", str(ROOT / "scenarios" / "skip.yaml"), "-q", "-o", str(recording), "--until", until]) == 0
        capsys.readouterr()
        assert main(["inspect", str(recording)]) == 0
        out = capsys.readouterr().out
        span = next(line for line in out.splitlines() if "time span:" in line)
        assert f"status: ok at t = {until} s" in out
        assert (said in span) if said else ("to t =" not in span), span


@pytest.mark.parametrize(("extra", "pattern", "refused"), [
    ([], "/tf", True),  # the ping-pong scene has no looks: no /tf is ever written
    ([], "/log", True),
    ([], "/perf/tick", True),  # written only with --perf
    (["--perf"], "/perf/tick", False),
])
def test_a_record_pattern_for_a_channel_the_run_never_writes_is_refused(tmp_path, capsys, extra, pattern, refused):
    """--record takes only channels this run writes: /tf and /log when something in the scene has
    looks, /perf/tick with --perf. They were always taken, and recorded nothing."""
    out = tmp_path / "r.mcap"
    code = main(["run", str(ROOT / "scenarios" / "ping_pong.yaml"), "-o", str(out), "-q", "--record", pattern,
                 *extra])
    err = capsys.readouterr().err
    assert code == (2 if refused else 0)
    assert (f"record.channels: {pattern!r} matches no channel of this scene" in err) is refused
    assert out.exists() is not refused


GROUND_ONLY = """\
name: ground_only
dt: 0.0005
until: 3.0
components:
  stone: {type: RigidBody, shape: disk, radius: 0.05, thickness: 0.015, density: 2650,
          position: [0.0, 0.0, 0.3], velocity: [3.0, 0.0, -1.0]}
  floor: {type: SolidGround, restitution: 0.5, mu_static: 0.5, mu_kinetic: 0.4}
  stages: {type: StageMonitor}
connections:
  - stone.state -> floor.body
  - {from: floor.impulse, to: stone.impulse, delay: 1,
     initial: {linear: [0, 0, 0], angular: [0, 0, 0], correction: [0, 0, 0]}}
  - stone.state -> stages.body
  - floor.contact -> stages.ground
"""


def test_inspect_dates_each_stage_as_the_runs_summary_does(tmp_path, capsys):
    """A disk thrown onto a floor slides to rest: the summary says rest from the start of its slow
    spell and the first stage from t = 0; inspect dated them by their messages' times, REST_HOLD and a
    step later (rest at 0.7105 s beside the summary's 0.6905 s)."""
    scene, recording = tmp_path / "ground_only.yaml", tmp_path / "ground_only.mcap"
    scene.write_text(GROUND_ONLY)
    assert main(["run", str(scene), "-o", str(recording)]) == 0
    summary = re.search(r"^  stages: (.*)", capsys.readouterr().out, re.M).group(1)
    said = re.findall(r"(\S+) \((\S+) s\)", summary)
    assert said[0] == ("approach", "0") and said[-1][0] == "rest"
    assert main(["inspect", str(recording)]) == 0
    rows = [line.split() for line in capsys.readouterr().out.splitlines() if "/stages/stage: " in line]
    shown = [(row[3].rstrip(","), row[0]) for row in rows]
    assert [(label, float(t)) for label, t in shown] == [(label, float(t)) for label, t in said]


def test_inspect_lists_the_timeline_in_the_order_its_events_began(tmp_path, capsys):
    """A rest is published REST_HOLD after its slow spell began and dated from its start: listed in
    the order of the messages, one ball's rest (from 0.0005 s) came after the other ball's landing
    (0.0105 s), the timeline's times going back."""
    scene = tmp_path / "two_balls.yaml"
    ball = "{type: RigidBody, shape: sphere, radius: 0.02, density: 2700.0, position: [%s, 0, %s]}"
    answer = "{from: %s.impulse, to: %s.impulse, delay: 1, initial: {linear: [0, 0, 0], angular: [0, 0, 0], " \
             "correction: [0, 0, 0]}}"
    scene.write_text(f"""
name: two_balls
dt: 0.0005
until: 0.25
components:
  resting: {ball % (0, 0.02)}
  dropped: {ball % (1, 0.0205)}
  floor_a: {{type: SolidGround}}
  floor_b: {{type: SolidGround}}
  resting_st: {{type: StageMonitor, stop_after: 0}}
  dropped_st: {{type: StageMonitor, stop_after: 0}}
connections:
  - resting.state -> floor_a.body
  - {answer % ("floor_a", "resting")}
  - dropped.state -> floor_b.body
  - {answer % ("floor_b", "dropped")}
  - resting.state -> resting_st.body
  - floor_a.contact -> resting_st.ground
  - dropped.state -> dropped_st.body
  - floor_b.contact -> dropped_st.ground
""")
    recording = tmp_path / "two_balls.mcap"
    assert main(["run", str(scene), "-o", str(recording)]) == 0
    capsys.readouterr()
    assert main(["inspect", str(recording)]) == 0
    out = capsys.readouterr().out.splitlines()
    rows = out[out.index("  timeline:") + 1:]
    times = [float(row.split()[0]) for row in rows]
    rest = next(k for k, row in enumerate(rows) if "/resting_st/stage: rest" in row)
    landing = next(k for k, row in enumerate(rows) if "/dropped_st/stage: ground" in row)
    assert times == sorted(times) and rest < landing and times[rest] < 0.002 < 0.01 < times[landing] < 0.02


def test_a_restart_keeps_the_name_of_a_scene_without_one(tmp_path, capsys):
    """A scene without ``name:`` is named after its file; a restart from its recording keeps that
    name (it was named after the recording's attachment, 'c.mcap_scene', in what it said and wrote)."""
    from cosim.record.reader import Recording

    scene = tmp_path / "counter.yaml"
    scene.write_text('dt: 0.001\nuntil: 0.02\ncomponents:\n  src: {type: "tests.toys:Source"}\n'
                     "record: {checkpoint_every: 0.01}\n")
    assert main(["run", str(scene), "-q", "-o", str(tmp_path / "c.mcap")]) == 0
    capsys.readouterr()
    assert main(["replay", str(tmp_path / "c.mcap"), "--from", "0.01", "-o", str(tmp_path / "d.mcap")]) == 0
    assert "restarting 'counter' from the checkpoint at t = 0.01 s" in capsys.readouterr().out
    assert Recording(tmp_path / "d.mcap").scene().name == "counter"
