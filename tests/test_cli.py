"""The command line: exit codes 0/1/2, one-line errors without tracebacks, nothing half-written."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from cosim.cli import main
from tests.cli_toys import CHECKPOINTED_SCENE

ROOT = Path(__file__).resolve().parents[1]

SCENE = CHECKPOINTED_SCENE


@pytest.fixture
def scene(tmp_path):
    path = tmp_path / "demo.yaml"
    path.write_text(SCENE)
    return path


def cosim(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    return subprocess.run([sys.executable, "-m", "cosim.cli", *args], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=120)


def test_run_writes_recording_and_summary(scene, tmp_path, capsys):
    """`cosim run` exits 0, writes the MCAP and prints simulated time, steps, wall time and RTF."""
    out = tmp_path / "out" / "demo.mcap"
    assert main(["run", str(scene), "-o", str(out), "-q"]) == 0
    text = capsys.readouterr().out
    assert "demo: ok - reached t = 0.05 s" in text
    assert "simulated 0.05 s in 50 steps of 1 ms (100 component steps)" in text
    assert "real-time factor" in text and out.exists()


def test_validate_inspect_and_replay(scene, tmp_path, capsys):
    """validate, inspect and replay all exit 0 on good input and say what they found."""
    out = tmp_path / "demo.mcap"
    assert main(["validate", str(scene)]) == 0
    assert "order within a tick: src -> g" in capsys.readouterr().out
    assert main(["run", str(scene), "-o", str(out), "-q"]) == 0
    capsys.readouterr()
    assert main(["inspect", str(out)]) == 0
    text = capsys.readouterr().out
    assert "status: ok at t = 0.05 s (50 steps)" in text and "/g/out" in text
    assert main(["replay", str(out)]) == 0
    text = capsys.readouterr().out
    assert "src: 50 steps replayed, 100 outputs identical bit for bit" in text
    assert main(["replay", str(out), "--from", "0.02", "-o", str(tmp_path / "r.mcap"), "-q"]) == 0
    assert "restarting 'demo' from the checkpoint at t = 0.02 s" in capsys.readouterr().out


def test_bad_scene_exits_2_without_traceback_or_file(tmp_path):
    """A malformed scene prints one error line per problem, exits 2, and writes no recording."""
    bad = tmp_path / "bad.yaml"
    bad.write_text(SCENE.replace("type: \"tests.toys:Gain\"", "type: \"tests.toys:Gain\", gain: x"))
    proc = cosim("run", str(bad), "-o", str(tmp_path / "x.mcap"), cwd=tmp_path)
    assert proc.returncode == 2
    assert proc.stderr.strip() == f"error: {bad}: components.g.gain: must be a number (got 'x')"
    assert "Traceback" not in proc.stderr
    assert list(tmp_path.glob("*.mcap*")) == []


def test_simulation_failure_exits_1_and_keeps_the_recording(tmp_path):
    """A run that fails exits 1 with the reason and keeps a valid recording up to the failure."""
    scene = tmp_path / "fail.yaml"
    scene.write_text("dt: 0.001\nuntil: 1\ncomponents:\n  bad: {type: \"tests.toys:Faulty\", fail_at: 0.01}\n")
    proc = cosim("run", str(scene), "-o", "f.mcap", "-q", cwd=tmp_path)
    assert proc.returncode == 1
    assert "error: component 'bad' failed at t = 0.01 s: RuntimeError: boom" in proc.stderr
    assert "Traceback" not in proc.stderr
    assert (tmp_path / "f.mcap").exists() and not list(tmp_path.glob("f.mcap*.part"))
    replayed = cosim("replay", "f.mcap", cwd=tmp_path)  # it says the run failed, and replays up to it
    assert replayed.returncode == 0
    assert replayed.stdout.splitlines()[0] == ("the recorded run failed at t = 0.01 s (component 'bad' failed at "
                                               "t = 0.01 s: RuntimeError: boom): each component is replayed up to it")


def test_corrupt_recording_exits_2(tmp_path):
    """inspect and replay of a corrupt file exit 2 with a one-line error."""
    junk = tmp_path / "junk.mcap"
    junk.write_bytes(b"\x89MCAP0\r\n" + b"\x00" * 100)
    for command in ("inspect", "replay"):
        proc = cosim(command, str(junk), cwd=tmp_path)
        assert proc.returncode == 2, proc.stderr
        assert proc.stderr.startswith(f"error: {junk}: not a readable MCAP recording")
        assert len(proc.stderr.strip().splitlines()) == 1


def test_bad_arguments_exit_2(tmp_path):
    """Unknown options and bad values are bad input (exit 2)."""
    proc = cosim("run", "x.yaml", "--until", "soon", cwd=tmp_path)
    assert proc.returncode == 2 and "expected seconds, got 'soon'" in proc.stderr


def test_unwritable_output_is_bad_input(scene, tmp_path):
    """An output path that cannot be written is reported in one line with exit 2, before running."""
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    proc = cosim("run", str(scene), "-o", str(blocker / "sub" / "x.mcap"), cwd=tmp_path)
    assert proc.returncode == 2
    assert proc.stderr.startswith(f"error: {blocker / 'sub' / 'x.mcap'}: cannot create its folder")
    assert "Traceback" not in proc.stderr


def test_a_restart_refuses_an_override_of_what_the_checkpoint_holds(tmp_path, capsys):
    """`replay --from T --set components.stone.position=...`: the restart takes the stone's state
    from the checkpoint, so the override would do nothing (and was listed as applied): exit 2 and one
    line saying so, no recording; an override the restart does use (dt) still runs."""
    skip = Path(__file__).resolve().parents[1] / "scenarios" / "skip.yaml"
    recording = tmp_path / "skip.mcap"
    assert main(["run", str(skip), "--until", "0.1", "--set", "record.checkpoint_every=0.05", "--set",
                 "record.visual_rate=0", "-o", str(recording), "-q"]) == 0
    capsys.readouterr()
    out = tmp_path / "again.mcap"
    assert main(["replay", str(recording), "--from", "0.05", "--set", "components.stone.position=[1, 1, 1]",
                 "-o", str(out), "-q"]) == 2
    assert capsys.readouterr().err.strip() == (
        "error: --set components.stone.position: sets stone's state at t = 0, which a restart takes from the "
        "checkpoint at 0.05 s instead; to change it, run the scene from the start (cosim run)")
    assert not out.exists()
    # (tilt_axis too: the stone is tilted about it at t = 0 only; a restart ran on, the override doing nothing)
    for start_only in ("components.stone.tilt_deg=45", "components.stone.spin=0", "components.stone.tilt_axis=[1,0,0]"):
        assert main(["replay", str(recording), "--from", "0.05", "--set", start_only, "-o", str(out), "-q"]) == 2
        assert f"--set {start_only.partition('=')[0]}: sets stone's state at t = 0" in capsys.readouterr().err
    # held from a state that turns across the disk's axis (after its first contact): a held disk never
    # does, and the restart kept that turn for ever, the rim moving and the energy counting it
    assert main(["replay", str(recording), "--from", "0.1", "--set", "components.stone.lock_attitude=true",
                 "-o", str(out), "-q"]) == 2
    assert capsys.readouterr().err.strip() == (
        f"error: {recording}: cannot restart from the checkpoint at 0.1 s: component 'stone' turns across its axis "
        "at 21.73 rad/s in this state (about it at 74.36), which a held disk (lock_attitude) never does; restart it "
        "with its attitude free, or run the scene held from t = 0")
    assert not out.exists()
    assert main(["replay", str(recording), "--from", "0.05", "--set", "dt=0.00025", "-o", str(out), "-q"]) == 0


def test_replay_says_it_restarts_only_once_the_restart_is_accepted_and_refuses_component_with_from(
        tmp_path, capsys):
    """`replay --from T -o` the recording itself: exit 2 without first saying "restarting" (it said so,
    then refused); `--component X --from T`: exit 2 (the component was silently dropped and the whole
    scene restarted)."""
    skip = Path(__file__).resolve().parents[1] / "scenarios" / "skip.yaml"
    recording = tmp_path / "skip.mcap"
    assert main(["run", str(skip), "--until", "0.1", "--set", "record.checkpoint_every=0.05", "--set",
                 "record.visual_rate=0", "-o", str(recording), "-q"]) == 0
    capsys.readouterr()
    assert main(["replay", str(recording), "--from", "0.05", "-o", str(recording), "-q"]) == 2
    said = capsys.readouterr()
    assert "restarting" not in said.out and "is the run's own input" in said.err
    assert main(["replay", str(recording), "--component", "stone", "--from", "0.05"]) == 2
    assert "--component stone and --from: " in capsys.readouterr().err
    assert main(["replay", str(recording), "--from", "0.05", "-o", str(tmp_path / "again.mcap"), "-q"]) == 0
    assert "restarting 'skip' from the checkpoint at t = 0.05 s" in capsys.readouterr().out


def test_a_failed_run_reports_the_time_it_ran():
    """A run that fails says how long it ran, as one that ends does (it said "wall 0 s")."""
    from cosim.runner import format_summary, run_scene
    from cosim.scenario import loads

    scene = loads("dt: 0.001\nuntil: 1\ncomponents:\n  bad: {type: \"tests.toys:Faulty\", fail_at: 0.2}\n")
    outcome = run_scene(scene, None, progress=False)
    result = outcome.result
    assert result.status == "failed" and result is outcome.simulation.last_result
    assert result.wall_s > 0.0 and result.steps == 200
    assert f"wall {result.wall_s:.3g} s" in format_summary(scene, outcome)


def test_a_failed_run_says_which_figures_are_of_the_step_that_failed():
    """A component that fails mid-step: those stepped before it in that step are one step on, and so
    is a slower one whose step spans it, and the summary says so (the stone's line was of 0.0885 s
    under "simulated 0.088 s"). A free fall under semi-implicit Euler: n steps of 1 ms give n g dt.
    A failure before any step says nothing of it (it said every body had stepped on)."""
    from cosim.runner import format_summary, run_scene
    from cosim.scenario import loads

    text = ("dt: 0.001\nuntil: 1\ncomponents:\n"
            "  early: {type: RigidBody, shape: sphere, radius: 0.01, density: 1000}\n"
            "  slow: {type: RigidBody, shape: sphere, radius: 0.01, density: 1000, every: 2}\n"
            "  bad: {type: \"tests.toys:Faulty\", fail_at: 0.01}\n"
            "  late: {type: RigidBody, shape: sphere, radius: 0.01, density: 1000}\n")

    def summary(scene_text: str) -> list[str]:
        scene = loads(scene_text)
        return format_summary(scene, run_scene(scene, None, progress=False)).splitlines()

    def speeds(lines: list[str]) -> dict[str, str]:
        return {line.split(":")[0].strip(): line.split("speed ")[1].split(" ")[0] for line in lines if "speed " in line}

    def fell(steps: int) -> str:
        return f"{steps * 9.81e-3:.4g}"

    lines = summary(text)
    assert lines[1].startswith("  simulated 0.01 s in 10 steps")
    assert lines[2] == ("  (when 'bad' failed in the step from 0.01 s, early had stepped on to 0.011 s, and slow to "
                        "0.012 s: their figures below are of those times, the others' of 0.01 s)")
    assert speeds(lines) == {"early": fell(11), "slow": fell(12), "late": fell(10)}
    lines = summary(text.replace("fail_at: 0.01", "fail_at: 0.011"))  # slow's step from 0.01 s spans it
    assert lines[2] == ("  (when 'bad' failed in the step from 0.011 s, early and slow had stepped on to 0.012 s: "
                        "their figures below are of that time, the others' of 0.011 s)")
    assert speeds(lines) == {"early": fell(12), "slow": fell(12), "late": fell(11)}
    for failing_first in (text.replace("  early", "  bad: {type: \"tests.toys:Faulty\", fail_at: 0.01}\n  early", 1)
                          .replace("  bad: {type: \"tests.toys:Faulty\", fail_at: 0.01}\n  late", "  late"),
                          text.replace("fail_at: 0.01}", "mode: start}")):
        lines = summary(failing_first)
        assert "stepped on" not in "\n".join(lines)
        assert set(speeds(lines).values()) == ({fell(10)} if "mode" not in failing_first else {"0"})


def test_a_run_that_substeps_says_so_in_its_summary():
    """Substeps taken for stability (on_unstable: substep) are said in the summary, with the most one
    step took (they were only an event in the recording, invisible with --no-record); a run without
    them says nothing of it."""
    from cosim.runner import format_summary, run_scene
    from cosim.scenario import loads

    text = ("dt: 0.001\nuntil: 0.01\non_unstable: substep\ncomponents:\n"
            "  acc: {type: \"tests.toys:Accumulator\", stable_step: 0.0003}\n")
    scene = loads(text)
    summary = format_summary(scene, run_scene(scene, None, progress=False))
    assert ("  substeps for stability (on_unstable: substep): acc up to 4 per step; a smaller dt (or every) "
            "avoids them") in summary.splitlines()
    calm = loads(text.replace("0.0003", "0.01"))
    assert "substeps" not in format_summary(calm, run_scene(calm, None, progress=False))
