"""A sweep run's wall-time bound (run_timeout) against the other ways a run ends: a signal, the sweep's
stop, the scene's end, and what the log says of the failures."""

from __future__ import annotations

import os
import signal
import time
from pathlib import Path

import pytest

import cosim.sweep.backends as backends
from cosim.cli import main
from cosim.scenario import loads
from cosim.scheduler import Simulation
from tests.sweep_toys import BALL_SCENE, Ball, write_sweep


def test_a_timeout_leaves_a_run_in_its_last_tick_to_end():
    """The timer finding the run in its last tick lets it reach its end (interrupted there, a finished run
    was written as timed out); in an earlier tick it interrupts it."""
    scene = loads(BALL_SCENE.replace("until: 3.0", "until: 0.005"), "ball.yaml")
    sim = Simulation(scene)
    timer = backends._timeout(sim, 1000.0)
    timer.cancel()
    sim.tick = 4  # (its fifth and last tick under way)
    timer.function()
    assert sim.interrupt_reason is None
    sim.tick = 3
    timer.function()
    assert sim.interrupt_reason == "timed out: still running after 1000 s of wall time (run_timeout)"


def test_a_second_ctrl_c_while_the_recording_is_finished_aborts(tmp_path):
    """One Ctrl-C in the run, a second while its recording is finished: the second aborts, as the run's
    own words promise (each context counted its own signals: the second was taken for a first, and the
    finishing went on). In a process of its own: an abort leaves the writer to its own end."""
    import subprocess
    import sys
    import textwrap

    probe = textwrap.dedent(f"""
        import os, signal
        import cosim.scheduler as scheduler
        from cosim.record.recorder import Recorder
        from cosim.runner import run_scene
        from cosim.scenario import loads
        from tests.sweep_toys import BALL_SCENE

        closing, stepping = Recorder.close, scheduler.Simulation.step

        def close(self):
            os.kill(os.getpid(), signal.SIGINT)  # the second Ctrl-C, while the file is finished
            return closing(self)

        def step(self):
            stepping(self)
            if self.tick == 3:
                os.kill(os.getpid(), signal.SIGINT)  # the first, in the run

        Recorder.close, scheduler.Simulation.step = close, step
        try:
            run_scene(loads(BALL_SCENE, "ball.yaml"), {str(tmp_path / "ball.mcap")!r}, progress=False)
            print("finished")
        except KeyboardInterrupt:
            print("aborted")
    """)
    root = Path(__file__).resolve().parents[1]
    env = {**os.environ, "COSIM_COMPONENT_PACKAGES": "tests", "PYTHONPATH": str(root)}
    done = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, timeout=120, env=env,
                          cwd=root)
    assert done.stdout.strip() == "aborted", done.stderr


def test_one_ctrl_c_after_a_timeout_lets_the_step_end(monkeypatch):
    """The timeout sets the run's interrupt; a Ctrl-C after it is the first signal, not a second one: the
    step in progress ends and the run with it, interrupted by the signal (it raised KeyboardInterrupt and
    cut the step off, no tick taken)."""
    monkeypatch.setenv("COSIM_COMPONENT_PACKAGES", "tests")
    stepping = Ball._step_impl

    def step_until_timed_out_then_ctrl_c(self, t, dt, inputs):
        # the Ctrl-C is sent in the first step, once the timeout has set the run's interrupt: by the
        # run's state, not by a guess of how long loading and the step take (a busy machine loaded the
        # scene past a fixed 0.3 s, and the signal reached the test itself)
        deadline = time.monotonic() + 30.0
        while backends._running.interrupt_reason is None and time.monotonic() < deadline:
            time.sleep(0.005)
        os.kill(os.getpid(), signal.SIGINT)
        return stepping(self, t, dt, inputs)

    monkeypatch.setattr(Ball, "_step_impl", step_until_timed_out_then_ctrl_c)
    task = backends.Task(0, "p0", BALL_SCENE, "ball.yaml", (), (), None, "", None, 0.1)
    row = backends.run_task(task)
    assert (row["status"], row["reason"], row["ticks"]) == ("interrupted", "interrupted by SIGINT", 1)


def test_a_worker_interrupted_by_a_signal_waits_for_the_sweeps_stop(monkeypatch):
    """A Ctrl-C reaches the workers with the sweep: the interrupted run's worker waits for the sweep's
    stop before it takes the next run (which would start and be cut); a timed-out run does not wait."""
    monkeypatch.setenv("COSIM_COMPONENT_PACKAGES", "tests")
    waits = []

    class Stop:
        def is_set(self) -> bool:
            return False

        def wait(self, seconds: float) -> bool:
            waits.append(seconds)
            return True

    monkeypatch.setattr(backends, "_stop", Stop())
    stepping = Ball._step_impl

    sent = []

    def ctrl_c_in_the_first_step(self, t, dt, inputs):
        # (in the step, where the run's handler takes it: a timer guessing when the run had started
        # reached the test itself on a busy machine)
        if not sent:
            sent.append(t)
            os.kill(os.getpid(), signal.SIGINT)
        return stepping(self, t, dt, inputs)

    monkeypatch.setattr(Ball, "_step_impl", ctrl_c_in_the_first_step)
    task = backends.Task(0, "p0", BALL_SCENE, "ball.yaml", (), ())
    assert backends.run_task(task)["status"] == "interrupted" and waits == [backends.STOP_WAIT_S]
    waits.clear()
    timed = backends.Task(0, "p0", BALL_SCENE, "ball.yaml", ("components.ball.burn=2000000",), (), None, "", None,
                          0.2)
    row = backends.run_task(timed)
    assert (row["status"], row["error_type"]) == ("failed", "Timeout") and waits == []


def test_the_last_progress_line_counts_every_failure(tmp_path, monkeypatch, capsys):
    """Into a log, the line a run's end prints counts that run's failure too (the last said 'failed 1'
    of two failed runs)."""
    monkeypatch.chdir(tmp_path)
    path = write_sweep(tmp_path, "scene: ball.yaml\naxes:\n  components.ball.fail_at_bounce: [1, 2]\n"
                                 "output: results/f.csv\n")
    assert main(["sweep", str(path), "--workers", "1", "--no-figure"]) == 1
    lines = [line for line in capsys.readouterr().err.splitlines() if line.startswith("sweep: ")]
    assert lines[-1].startswith("sweep: 2/2 runs (100%), failed 2, ")


@pytest.fixture(autouse=True)
def _no_pending_signal():
    """(A test's timer signal that came after its run would reach the next test.)"""
    yield
    signal.signal(signal.SIGINT, signal.default_int_handler)
