"""Running a scene end to end: recorder, progress bar, signals, and the closing summary.

Used by ``cosim run`` and ``cosim replay --from``, and by anything that wants a recorded run in one
call (tests, sweeps).
"""

from __future__ import annotations

import fnmatch
import math
import signal
import sys
import warnings
from collections.abc import Callable, Iterator
from contextlib import contextmanager, nullcontext
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from cosim.errors import ScenarioError, SimulationError, counted, ending_signals, one_line
from cosim.jit_time import compile_notice
from cosim.progress import ProgressBar
from cosim.record.recorder import PERF_TOPIC, Recorder, physics_topics
from cosim.record.writer import SinkError
from cosim.scenario import Scene
from cosim.scheduler import RunResult, Simulation
from cosim.timebase import exact_milliseconds, exact_seconds

COMPILE_NOTE_S = 0.05  # compiling shorter than this [s] goes unmentioned in the summary


@dataclass
class RunOutcome:
    """A finished run: its result, the recording (if any) and the components' summary lines."""

    result: RunResult
    recording: Path | None
    summary: list[str] = field(default_factory=list)
    simulation: Simulation | None = None
    live: Any = None  # with keep_live: the still-serving cosim.view.live.LiveView, for the caller to close

    @property
    def failed(self) -> bool:
        return self.result.status in ("failed", "interrupted")


@contextmanager
def _signals_interrupt(sim: Simulation, recorder: Any = None, signalled: list[int] | None = None) -> Iterator[None]:
    """Ctrl-C, SIGTERM and SIGHUP (the terminal closed; not when started ignoring it, as under
    ``nohup``) end the run after the current tick; a second Ctrl-C aborts at once. The
    ``recorder`` is told of each (:meth:`cosim.record.recorder.Recorder.interrupted`): a writer process
    that has stopped answering is then not waited for without end. ``signalled``: the signals taken
    so far, shared by the contexts of one run (a sweep's timeout or stop is no signal; a Ctrl-C in
    the run and one while its recording is finished are two)."""
    signalled = [] if signalled is None else signalled

    def handler(signum: int, frame: Any) -> None:
        if recorder is not None:
            recorder.interrupted()
        if signalled and signum == signal.SIGINT:
            raise KeyboardInterrupt
        signalled.append(signum)
        sim.interrupt(f"interrupted by {signal.Signals(signum).name}")

    try:
        old = {s: signal.signal(s, handler) for s in (signal.SIGINT, *ending_signals())}
    except ValueError:  # not the main thread: leave signals alone
        yield
        return
    try:
        yield
    finally:
        for s, h in old.items():
            signal.signal(s, h)


VIEWER_PACKAGES = ("google.protobuf", "foxglove_schemas_protobuf")  # what the viewer channels need ([viz])


def default_derivers(scene: Scene) -> list[Any]:
    """Viewer-channel derivers for a recording of ``scene``: Foxglove scene, transform and log
    channels at ``record.visual_rate`` frames per second, made in the recording's writer process
    where it can (:class:`cosim.view.channels.RecordedVisuals`); none at rate 0, or without the
    ``[viz]`` extra, which is said once as a warning."""
    rate = scene.record.visual_rate
    if rate <= 0:
        return []
    from importlib.util import find_spec

    for name in VIEWER_PACKAGES:
        try:
            found = find_spec(name) is not None
        except ImportError:  # its parent package is missing
            found = False
        if not found:
            warnings.warn(f"no viewer channels: {name} is not installed "
                          "(pip install 'cosim[viz]'; or set record.visual_rate: 0)", stacklevel=2)
            return []
    from cosim.view.channels import RecordedVisuals

    return [RecordedVisuals(rate, physics_topics(scene))]


def check_channel_patterns(scene: Scene, perf: bool = False) -> None:
    """record.channels (``--record``): each pattern must match a channel the scene can record (a
    component's output ``/<component>/<port>``, the framework's own, ``/perf/tick`` with ``perf``,
    the viewer's ``/tf`` and ``/log`` when something in it has looks), or the recording silently
    leaves out what a misspelt pattern meant: a ScenarioError naming it and the scene's channels.
    The viewer's per-item channels under ``/scene/`` depend on the components' looks, not known
    before the run: a pattern there is taken as it is."""
    if scene.record.channels is None:
        return
    topics = sorted((physics_topics(scene) - (set() if perf else {PERF_TOPIC})) | _viewer_topics(scene))
    problems = []
    for pattern in scene.record.channels:
        if str(pattern).startswith("/scene/") or any(fnmatch.fnmatchcase(t, str(pattern)) for t in topics):
            continue
        shown = ", ".join(topics[:12]) + (", ..." if len(topics) > 12 else "")
        problems.append(f"record.channels: {pattern!r} matches no channel of this scene (its channels: {shown}; "
                        "/perf/tick is one with --perf, /tf and /log when something in it has looks and "
                        "record.visual_rate is above 0)")
    if problems:
        raise ScenarioError(problems, scene.source)


def _viewer_topics(scene: Scene) -> set[str]:
    """The viewer's channels beside its per-item ones, ``/tf`` and ``/log``: written only at a
    visual rate and when a component draws itself or one of its outputs has looks (a --record /tf on
    the ping-pong scene, which has none, was taken and recorded nothing)."""
    if scene.record.visual_rate <= 0:
        return set()
    from cosim.view.channels import registered_here
    from cosim.view.items import LOG_TOPIC, TF_TOPIC
    from cosim.view.lookup import has_installed_visuals, type_draws_itself

    registered = registered_here()  # looks given in this process (cosim.view.items.register)
    for cfg in scene.components.values():
        if type_draws_itself(cfg.cls) or any(
                port.type in registered or has_installed_visuals(port.type) for port in cfg.cls.outputs.values()):
            return {TF_TOPIC, LOG_TOPIC}
    return set()


def run_scene(scene: Scene, output: str | Path | None, *, until_ns: int | None = None,
              command_line: str = "", progress: bool = True, perf: bool = False,
              derivers: list[Any] | None = None, simulation: Simulation | None = None,
              live: str | None = None, live_speed: float = 1.0, keep_live: bool = False,
              inputs: tuple[str | Path, ...] = (), before_run: Callable[[], None] | None = None) -> RunOutcome:
    """Run ``scene`` (or a prepared ``simulation`` of it), recording to ``output`` unless None.

    The recording is closed whatever happens, so a failed or interrupted run leaves a valid file
    holding everything up to the end plus the final status record. A SimulationError does not
    propagate: it is in ``outcome.result``. ``live`` (``[HOST:]PORT``) also streams the physics and
    viewer channels to Foxglove over WebSocket, paced at ``live_speed`` times real time (0: unpaced);
    it uses the ``foxglove-sdk`` package's WebSocket server; with ``keep_live`` the server is left
    running after a run that ended (it is ``outcome.live``: call its ``linger()`` or ``close()``).
    ``inputs``: files the run reads besides the scene, which the recording must not replace.
    ``before_run`` is called once everything is ready, just before the first step (``cosim run``
    ends its start-up there: :func:`cosim.cli.start_up_done`).

    An output that may not be written (:func:`cosim.record.output.check_output`) raises
    RecordingError before anything runs, as does a record.channels pattern that matches no channel
    (:func:`check_channel_patterns`); a recording that cannot be finished raises
    :class:`cosim.record.writer.SinkError` once the run has ended: a writer that died leaves the
    recording salvaged up to the failure (:mod:`cosim.record.salvage`), a full disk the recording
    closed where it stopped (:mod:`cosim.record.seal`; no file only when not even its start fitted),
    a target that cannot be replaced the whole recording kept beside it.
    """
    if output is not None:
        check_channel_patterns(scene, perf)
    sim = simulation if simulation is not None else Simulation(scene)
    live_view = None
    if live is not None:
        from cosim.view.live import LiveView  # only with --live

        live_view = LiveView(scene, live, speed=live_speed, components=sim.components)
    recorder = None
    observers: list[Any] = []
    finished = False
    signalled: list[int] = []  # the signals this run has taken, in the run and while its file is finished
    try:
        if output is not None:
            # the writer process starts here (unless cosim run started it first, or this process kept
            # one from its last recording) and imports what deriving viewer channels needs while the
            # run's kernels load (a short run waits at its end for the writer to finish the file)
            recorder = Recorder(output, scene, command_line=command_line, perf=perf, inputs=inputs,
                                derivers=default_derivers(scene) if derivers is None else list(derivers),
                                start_ns=sim.time_ns)
            for deriver in recorder.derivers:  # components may override their looks (Component.visuals)
                if hasattr(deriver, "bind"):
                    deriver.bind(sim.components)
            observers.append(recorder)
        end_ns = scene.until_ns if until_ns is None else until_ns
        if progress:
            observers.append(ProgressBar(end_ns, label=scene.name))
        if live_view is not None:
            observers.append(live_view)
        sim.observers.extend(observers)
        notice = compile_notice(lambda: print(f"{scene.name}: compiling the kernels this scene uses (once for this "
                                              f"checkout: later runs load them from disk)...", file=sys.stderr,
                                              flush=True)
                                ) if progress else nullcontext()
        if before_run is not None:
            try:
                before_run()
            except BaseException:
                # (a Ctrl-C remembered from the start-up) nothing ran: no recording, and a recording
                # already at the output is not replaced by an empty one without a status
                if recorder is not None:
                    recorder.discard()
                raise
        with _signals_interrupt(sim, recorder, signalled), notice:
            try:
                result = sim.run(end_ns)
            except SimulationError as exc:
                # the run's own result (its wall time, its compiling) unless it failed before one was made
                result = sim.last_result if sim.last_result is not None and sim.last_result.error is exc else \
                    RunResult("failed", str(exc), sim.tick, sim.time_ns, 0.0, sim.component_steps(), exc)
            except SinkError:  # the writer stopped mid-run: nothing more can be recorded
                if recorder is not None:
                    recorder.discard()
                raise
        finished = True
    finally:
        try:
            # the run's own signal handling stays on while the file is finished: a Ctrl-C or SIGTERM
            # there (after the run ended) waits for the writer as one during the run would, and the
            # run is told as what it was, not as interrupted (a second Ctrl-C still aborts)
            with _signals_interrupt(sim, recorder, signalled) if recorder is not None else nullcontext():
                path = recorder.close() if recorder is not None else None
        except BaseException:
            finished = False  # a recording that could not be finished: nothing left to serve
            raise
        finally:
            if live_view is not None and not (keep_live and finished):
                live_view.close()
    summary = [line for r in sim.runners for line in r.comp.summary()]
    return RunOutcome(result, path, summary, sim, live_view if keep_live else None)


def collect_metrics(sim: Simulation) -> dict[str, float | int | str]:
    """Every component's metrics, keyed ``component.metric``."""
    return {f"{r.name}.{key}": value for r in sim.runners for key, value in r.comp.metrics().items()}


def _stepped_before_failure(outcome: RunOutcome) -> dict[int, list[str]]:
    """The components whose last step reached past the time a failed run simulated to (the start of
    the step where a component failed), by the time [ns] they reached: those stepped before it in
    that step (the scheduler steps them in order), and a slower one whose step begun earlier spans
    it. Their summary lines are of that time. Empty unless a component failed."""
    sim, error = outcome.simulation, outcome.result.error
    if sim is None or not isinstance(error, SimulationError):
        return {}
    ahead: dict[int, list[str]] = {}
    for runner in sim.runners:
        # (its steps counted from t = 0, a restart's brought back with its state)
        reached = runner.comp.step_count * runner.every * sim.dt_ns
        if runner.name != error.component and reached > sim.time_ns:
            ahead.setdefault(reached, []).append(runner.name)
    return dict(sorted(ahead.items()))


def _listed(names: list[str]) -> str:
    """``names`` in words: "a", "a and b", "a, b and c"."""
    return names[0] if len(names) == 1 else f"{', '.join(names[:-1])} and {names[-1]}"


def format_summary(scene: Scene, outcome: RunOutcome) -> str:
    """The closing summary printed by ``cosim run``."""
    r = outcome.result
    lines = [f"{scene.name}: {r.status} - {one_line(r.reason)}"]  # (an FMU's reason can hold line breaks)
    # no real-time factor of a run that simulated nothing or took no time (beyond compiling)
    rate = (f"real-time factor {r.real_time_factor:.3g}" if r.simulated_ns > 0 and math.isfinite(r.real_time_factor)
            else "")
    speed = f"wall {r.wall_s:.3g} s" + (f"; {rate}" if rate else "")
    if r.compile_s >= COMPILE_NOTE_S:
        speed = (f"wall {r.wall_s:.3g} s, of which {r.compile_s:.3g} s compiling kernels once (later runs "
                 "load them from disk)" + (f"; {rate} (compiling left out)" if rate else ""))
    since = f" from t = {exact_seconds(r.start_ns)} s" if r.start_ns else ""
    lines.append(f"  simulated {exact_seconds(r.simulated_ns)} s{since} in {counted(r.steps, 'step')} of "
                 f"{exact_milliseconds(scene.dt_ns)} ms ({counted(r.component_steps, 'component step')}); {speed}")
    if r.start_ns and outcome.summary:  # a restart: the components' counters came back with their state
        lines.append(f"  (the components' figures below count from t = 0: the checkpoint at "
                     f"{exact_seconds(r.start_ns)} s brought back their totals)")
    substepped = [f"{runner.name} up to {runner.most_substeps}" for runner in
                  (outcome.simulation.runners if outcome.simulation is not None else []) if runner.most_substeps > 1]
    if substepped:  # the stable step was shorter than the component's own: it took several in one
        lines.append(f"  substeps for stability (on_unstable: substep): {', '.join(substepped)} per step; a "
                     "smaller dt (or every) avoids them")
    ahead = _stepped_before_failure(outcome)
    if ahead and outcome.summary:
        moved = ", and ".join(f"{_listed(names)}{' had stepped on' if i == 0 else ''} to {exact_seconds(end)} s"
                              for i, (end, names) in enumerate(ahead.items()))
        others = ("" if sum(map(len, ahead.values())) == len(outcome.simulation.runners) - 1 else
                  f", the others' of {exact_seconds(r.error.time_ns)} s")
        times = "those times" if len(ahead) > 1 else "that time"
        lines.append(f"  (when {r.error.component!r} failed in the step from {exact_seconds(r.error.time_ns)} s, "
                     f"{moved}: their figures below are of {times}{others})")
    lines += [f"  {line}" for line in outcome.summary]
    if outcome.recording is not None:
        size = outcome.recording.stat().st_size
        # one line whatever the name holds (a newline in it broke the summary over two)
        lines.append(f"  recording: {one_line(str(outcome.recording))} ({size / 1e6:.3g} MB)")
    return "\n".join(lines)
