"""The one-time compiling of JIT kernels is measured apart, and left out of the real-time factor."""

from __future__ import annotations

import math
from dataclasses import dataclass

import pytest
from numba import njit

from cosim.component import Component, Port
from cosim.jit_time import compile_notice, compile_timer
from cosim.runner import COMPILE_NOTE_S, RunOutcome, format_summary, run_scene
from cosim.scenario import loads
from cosim.scheduler import RunResult, Simulation
from tests.toys import Scalar


def fresh_kernel():
    """A kernel numba has never compiled (a new dispatcher, no on-disk cache)."""

    @njit(cache=False)
    def kernel(x):
        total = 0.0
        for i in range(10):
            total += x * i
        return total

    return kernel


class Compiling(Component):
    """Calls a kernel it has just made at every step: the first call compiles it."""

    @dataclass(frozen=True)
    class Params:
        pass

    outputs = {"out": Port(Scalar)}

    def setup(self) -> None:
        self.kernel = fresh_kernel()

    def _step_impl(self, t, dt, inputs):
        return {"out": Scalar(self.kernel(t))}


SCENE = """
name: jit
dt: 0.001
until: 0.01
components:
  k: {type: "tests.test_jit_time:Compiling"}
"""


def test_the_timer_counts_a_compile_and_not_a_call_of_compiled_code():
    kernel = fresh_kernel()
    with compile_timer() as compiling:
        assert kernel(2.0) == 90.0
    first = compiling()
    with compile_timer() as compiling:
        for _ in range(100):
            kernel(3.0)
    assert first > 0.0 and compiling() == 0.0


def test_a_run_reports_its_compiling_and_leaves_it_out_of_the_real_time_factor():
    result = Simulation(loads(SCENE)).run()
    assert result.status == "ok" and 0.0 < result.compile_s < result.wall_s
    assert result.real_time_factor == pytest.approx(0.01 / (result.wall_s - result.compile_s))


def test_real_time_factor_without_compiling():
    result = RunResult("ok", "", 100, 2_000_000_000, wall_s=5.0, component_steps=100, compile_s=4.0)
    assert result.real_time_factor == 2.0
    assert RunResult("ok", "", 0, 0, 1.0, 0, compile_s=1.0).real_time_factor == math.inf


@pytest.mark.parametrize("compile_s", [0.0, 4.0])
def test_the_summary_names_the_compiling_only_when_there_was_some(compile_s):
    scene = loads(SCENE)
    result = RunResult("ok", "reached t = 2 s", 2000, 2_000_000_000, 5.0, 2000, compile_s=compile_s)
    line = format_summary(scene, RunOutcome(result, None)).splitlines()[1]
    if compile_s >= COMPILE_NOTE_S:
        assert "wall 5 s, of which 4 s compiling kernels once" in line
        assert line.endswith("real-time factor 2 (compiling left out)")
    else:
        assert "compiling" not in line and line.endswith("wall 5 s; real-time factor 0.4")


def test_the_notice_is_given_once_and_only_when_something_compiles():
    said = []
    first, second = fresh_kernel(), fresh_kernel()
    with compile_notice(lambda: said.append("compiling")):
        first(1.0)
        second(1.0)  # a second compile in the same run: no second notice
    with compile_notice(lambda: said.append("again")):
        first(2.0)  # compiled already: nothing to say
    assert said == ["compiling"]


def test_a_run_with_progress_says_it_is_compiling(capsys):
    scene = loads(SCENE)
    run_scene(scene, None, progress=True)
    assert capsys.readouterr().err.count("jit: compiling the kernels this scene uses (once for this checkout") == 1
    run_scene(scene, None, progress=False)
    assert "compiling" not in capsys.readouterr().err


def test_a_run_that_took_no_time_or_simulated_nothing_prints_no_real_time_factor():
    """No 'real-time factor inf' (a run that failed before any time passed) nor 0 (nothing simulated):
    the wall time alone."""
    scene = loads(SCENE)
    for wall, ticks in ((0.0, 7), (0.5, 0)):
        result = RunResult("failed", "x", ticks, ticks * 1_000_000, wall, ticks)
        line = format_summary(scene, RunOutcome(result, None)).splitlines()[1]
        assert "real-time factor" not in line and line.endswith(f"wall {wall:.3g} s")


def test_a_run_that_only_compiled_keeps_the_compiling_note():
    """A run whose wall time went to compiling (none left to simulate in) still says so, without a
    real-time factor."""
    scene = loads(SCENE)
    result = RunResult("ok", "x", 7, 7_000_000, 1.0, 7, compile_s=1.0)
    line = format_summary(scene, RunOutcome(result, None)).splitlines()[1]
    assert line.endswith("wall 1 s, of which 1 s compiling kernels once (later runs load them from disk)")


def test_a_restart_says_its_components_figures_count_from_the_start():
    """After a restart the components' summaries carry their restored totals (doStep calls, energy
    taken since t = 0): the summary says so, beside its own figures counted from the checkpoint."""
    scene = loads(SCENE)
    result = RunResult("ok", "x", 70, 70_000_000, 1.0, 40, start_tick=50, start_ns=50_000_000)
    lines = format_summary(scene, RunOutcome(result, None, summary=["gust: 70 doStep calls"])).splitlines()
    assert "from t = 0.05 s" in lines[1]
    assert lines[2] == ("  (the components' figures below count from t = 0: the checkpoint at 0.05 s brought back "
                        "their totals)")
