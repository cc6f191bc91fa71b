"""Running a scene end to end: recorder, progress bar, signals, and the closing summary.

Used by ``cosim run`` and ``cosim replay --from``, and by anything that wants a recorded run in one
call (tests, sweeps).
"""

from __future__ import annotations

import signal
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from cosim.errors import SimulationError
from cosim.progress import ProgressBar
from cosim.recorder import Recorder
from cosim.scenario import Scene
from cosim.scheduler import RunResult, Simulation
from cosim.timebase import NS_PER_S


@dataclass
class RunOutcome:
    """A finished run: its result, the recording (if any) and the components' summary lines."""

    result: RunResult
    recording: Path | None
    summary: list[str] = field(default_factory=list)
    simulation: Simulation | None = None

    @property
    def failed(self) -> bool:
        return self.result.status in ("failed", "interrupted")


@contextmanager
def _signals_interrupt(sim: Simulation) -> Iterator[None]:
    """Ctrl-C and SIGTERM end the run after the current tick; a second Ctrl-C aborts at once."""
    def handler(signum: int, frame: Any) -> None:
        if sim.interrupt_reason is not None and signum == signal.SIGINT:
            raise KeyboardInterrupt
        sim.interrupt(f"interrupted by {signal.Signals(signum).name}")

    try:
        old = {s: signal.signal(s, handler) for s in (signal.SIGINT, signal.SIGTERM)}
    except ValueError:  # not the main thread: leave signals alone
        yield
        return
    try:
        yield
    finally:
        for s, h in old.items():
            signal.signal(s, h)


def default_derivers(scene: Scene) -> list[Any]:
    """Viewer-channel derivers for a recording of ``scene`` (none until a viewer layer provides them)."""
    return []


def run_scene(scene: Scene, output: str | Path | None, *, until_ns: int | None = None,
              command_line: str = "", progress: bool = True, perf: bool = False,
              derivers: list[Any] | None = None, simulation: Simulation | None = None) -> RunOutcome:
    """Run ``scene`` (or a prepared ``simulation`` of it), recording to ``output`` unless None.

    The recording is closed whatever happens, so a failed or interrupted run leaves a valid file
    holding everything up to the end plus the final status record. A SimulationError does not
    propagate: it is in ``outcome.result``.
    """
    recorder = None
    observers: list[Any] = []
    if output is not None:
        output = Path(output)
        output.parent.mkdir(parents=True, exist_ok=True)
        recorder = Recorder(output, scene, command_line=command_line, perf=perf,
                            derivers=default_derivers(scene) if derivers is None else derivers)
        observers.append(recorder)
    end_ns = scene.until_ns if until_ns is None else until_ns
    if progress:
        observers.append(ProgressBar(end_ns, label=scene.name))
    sim = simulation if simulation is not None else Simulation(scene)
    sim.observers.extend(observers)
    try:
        with _signals_interrupt(sim):
            try:
                result = sim.run(end_ns)
            except SimulationError as exc:
                result = RunResult("failed", str(exc), sim.tick, sim.time_ns, 0.0,
                                   sim.component_steps(), exc)
    finally:
        path = recorder.close() if recorder is not None else None
    summary = [line for r in sim.runners for line in r.comp.summary()]
    return RunOutcome(result, path, summary, sim)


def collect_metrics(sim: Simulation) -> dict[str, float | int | str]:
    """Every component's metrics, keyed ``component.metric``."""
    return {f"{r.name}.{key}": value for r in sim.runners for key, value in r.comp.metrics().items()}


def format_summary(scene: Scene, outcome: RunOutcome) -> str:
    """The closing summary printed by ``cosim run``."""
    r = outcome.result
    lines = [f"{scene.name}: {r.status} - {r.reason}"]
    rtf = r.real_time_factor
    lines.append(f"  simulated {r.time_ns / NS_PER_S:.4g} s in {r.tick} steps of {scene.dt * 1e3:g} ms "
                 f"({r.component_steps} component steps); wall {r.wall_s:.3g} s; "
                 f"real-time factor {rtf:.3g}")
    lines += [f"  {line}" for line in outcome.summary]
    if outcome.recording is not None:
        size = outcome.recording.stat().st_size
        lines.append(f"  recording: {outcome.recording} ({size / 1e6:.3g} MB)")
    return "\n".join(lines)
