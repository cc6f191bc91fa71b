"""Running a sweep: every point not yet in the table, on a backend, row by row into the table.

Nothing is lost: a run that fails is a row with status ``failed`` and the sweep goes on; a worker
process that dies is replaced, and the points it may have taken down are retried one at a time, so
only the point that kills a worker is recorded as failed (``error_type`` WorkerLost), on either
backend. An interrupted sweep (Ctrl-C, SIGTERM, a kill, or a backend that can run no more: the Dask
scheduler lost, a cluster left without workers) keeps every row written so far; running it again
resumes: points already in the table are skipped. A run that the machine cut short for want of room
(the disk full, a quota) is no result of its point either: it gets no row, the sweep says so once and
submits no more points (each would end the same way), and running it again once there is room
resumes it.
When every point has a row, the table is sorted by point index and the summary figure is drawn.
"""

from __future__ import annotations

import math
import os
import signal
import time
from collections import Counter, deque
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from cosim.errors import counted, ending_signals
from cosim.progress import work_progress
from cosim.sweep.backends import MACHINE_LIMITS, BackendLost, DaskBackend, ProcessBackend, Task, WorkerLost, versions
from cosim.sweep.plan import Point, Sweep
from cosim.sweep.table import NOT_RESULTS, ResultTable, cannot, column_kinds, figure_path, run_again, runs_folder

IN_FLIGHT_PER_SLOT = 2  # tasks queued per worker: keeps workers busy, bounds what an interruption drops
RECORDING_FAILURES = ("SinkError", "RecordingError")  # error types of a run whose recording failed
# the reason of the row of a point whose worker died while it ran alone: the same words whatever the
# backend (a point gives the same row on any), with no task id or address of the run that said so
WORKER_DIED = "the worker running this point died (it ran alone: this point ends its worker)"


@dataclass
class SweepOutcome:
    """What a sweep did: the table, how many points ran now or were already there, by status."""

    sweep: Sweep
    output: Path
    backend: str
    total: int
    already: int = 0
    ran: int = 0
    counts: Counter = field(default_factory=Counter)
    interrupted: bool = False
    unfinished: int = 0
    limit: str | None = None  # the machine limit that stopped the sweep (the disk full), in the system's words
    limit_on: str = "the recordings"  # what the machine had no room for: the runs' recordings, or the table
    dropped: int = 0  # rows of interrupted runs found in the table: no results, their points ran again
    lost: str | None = None  # why the backend could run no more (the Dask scheduler lost), if it stopped so
    wall_s: float = 0.0
    run_wall_s: float = 0.0  # the runs' own wall times summed [s] (each in its worker)
    rows: list[dict[str, str]] = field(default_factory=list)
    figure: Path | None = None
    failures: list[tuple[int, str, str]] = field(default_factory=list)
    notices: dict[str, str] = field(default_factory=dict)  # each point scene's notice, and the first point's label
    fresh: bool = False  # started with --fresh: the same command again would discard what this one kept
    late_signal: str | None = None  # a signal that came while the finished sweep wrote its table and figure

    @property
    def complete(self) -> bool:
        return not self.interrupted and self.unfinished == 0

    def points_left(self) -> int:
        """Points of the sweep with no row in its table (those a resumed sweep runs)."""
        return self.total - sum(self.counts.values())

    def stopped_line(self) -> str:
        """Why an incomplete sweep stopped and what is left, in one line: the summary's, and the
        command's error line on standard error."""
        left = f"{self.points_left()} of {self.total} points left"
        # (after --fresh, the same command again would discard the rows this one kept)
        again = "the command is run again without --fresh" if self.fresh else "the same command is run again"
        if self.limit is not None:
            return (f"stopped, the machine has no room for {self.limit_on} ({self.limit}): {left}; they run "
                    f"when {again} once there is room")
        why = (self.lost if self.lost is not None else "interrupted" if self.interrupted
               else f"{counted(self.unfinished, 'run was', 'runs were')} interrupted")
        return f"{why}: {left}; {run_again(self.fresh)} to resume"


    def summary(self) -> str:
        """The closing lines printed by ``cosim sweep``."""
        statuses = ", ".join(f"{n} {s}" for s, n in sorted(self.counts.items())) or "nothing"
        lines = [self.sweep.describe() + (f" on {self.backend}" if self.ran else "")]  # nothing ran on it else
        # the sweep's wall over its runs, and a run's own time in its worker (the workers run at once)
        per_run = (f" ({self.wall_s / self.ran:.3g} s a run; on average {self.run_wall_s / self.ran:.3g} s "
                   "in its worker)" if self.ran else "")
        dropped = (f" ({counted(self.dropped, 'interrupted run')} found in it, no result: run again)"
                   if self.dropped else "")
        lines.append(f"  ran {self.ran}, {self.already} already in the table{dropped}; {statuses}; "
                     f"wall {self.wall_s:.3g} s{per_run}")
        if not self.complete:
            lines.append(f"  {self.stopped_line()}")
        lines.append(f"  table: {self.output}")
        if self.figure is not None:
            lines.append(f"  figure: {self.figure}")
        for index, label, reason in self.failures[:5]:
            lines.append(f"  failed #{index} ({label}): {reason}")
        if len(self.failures) > 5:
            lines.append(f"  ... and {len(self.failures) - 5} more failed points (status column)")
        return "\n".join(lines)


@contextmanager
def _sigterm_interrupts() -> Iterator[None]:
    """SIGTERM (and SIGHUP, the terminal closed) end the sweep like Ctrl-C: rows written so far are
    kept, queued runs are dropped."""
    def handler(signum: int, frame: Any) -> None:
        raise KeyboardInterrupt

    try:
        old = {signum: signal.signal(signum, handler) for signum in ending_signals()}
    except ValueError:  # not the main thread
        yield
        return
    try:
        yield
    finally:
        for signum, handler_before in old.items():
            signal.signal(signum, handler_before)


class LateSignals:
    """Holds off Ctrl-C, SIGTERM and SIGHUP while a sweep whose every point has run writes its table
    and figure and closes its workers (a fraction of a second): a signal then cut the complete sweep
    short, said "interrupted", exit 1, nothing said of the table that was whole. The first signal is
    noted (``seen``: its name) and the work goes on; a second one ends it as elsewhere (a Ctrl-C as
    an interruption, SIGTERM or SIGHUP the process at once)."""

    def __init__(self, seen: str | None = None) -> None:
        self.seen = seen  # (one noted while the table was written, for the workers' close after it)
        self._old: dict[int, Any] = {}

    def _note(self, signum: int, frame: Any) -> None:
        if self.seen is None:
            self.seen = "Ctrl-C" if signum == signal.SIGINT else signal.Signals(signum).name
            return
        if signum == signal.SIGINT:
            raise KeyboardInterrupt
        signal.signal(signum, signal.SIG_DFL)  # a second SIGTERM or SIGHUP: ends the process, as it would
        os.kill(os.getpid(), signum)

    def __enter__(self) -> LateSignals:
        try:
            for signum in (signal.SIGINT, *ending_signals()):
                self._old[signum] = signal.signal(signum, self._note)
        except ValueError:  # not the main thread: its signals are not ours to hold
            pass
        return self

    def __exit__(self, *exc: object) -> None:
        for signum, old in self._old.items():
            signal.signal(signum, old)


def _failed_row(point: Point, reason: str, error_type: str) -> dict[str, Any]:
    return {"index": point.index, "point_id": point.point_id, "status": "failed", "reason": reason,
            "error_type": error_type, "sim_time_s": math.nan, "ticks": 0, "wall_s": 0.0}


def run_sweep(sweep: Sweep, output: str | Path | None = None,
              backend: ProcessBackend | DaskBackend | None = None, *, fresh: bool = False,
              progress: bool = True, figure: bool = True, command_line: str = "",
              on_resume: Callable[[int], None] | None = None) -> SweepOutcome:
    """Run every point of ``sweep`` not yet in the table at ``output`` (default: the sweep's).

    ``backend``: a process pool of all cores unless given; a backend passed in is started if needed
    and left open (a caller may run several sweeps on it). ``fresh``: discard an existing table
    instead of resuming it. Raises ScenarioError if the existing table belongs to another sweep, or
    another sweep is writing it now.
    ``on_resume(rows)``: called once the existing table is open as this sweep's, with its rows.
    """
    output = Path(output) if output is not None else sweep.output
    own = backend is None
    backend = backend if backend is not None else ProcessBackend()
    order = {p.point_id: p.index for p in sweep.points}
    meta: dict[str, Any] = {
        "sweep": sweep.name, "source": sweep.source, "fingerprint": sweep.fingerprint(),
        "command": command_line, "points": len(sweep.points), "columns": sweep.columns,
        "sweep_file": sweep.text, "scene_source": sweep.scene_source, "scene": sweep.scene_text,
        "fixed_overrides": sweep.fixed, "versions": versions()}
    table = ResultTable(output, sweep.columns, meta, column_kinds(sweep), {p.point_id: p.values for p in sweep.points})
    done = table.open(order, fresh=fresh)
    try:  # the table stays locked until the sweep is done with it: no other sweep writes it meanwhile
        if on_resume is not None:
            on_resume(len(done))
        return _run_points(sweep, output, backend, own, table, done, order, progress=progress, figure=figure,
                           command_line=command_line)
    finally:
        table.release()


def _run_points(sweep: Sweep, output: Path, backend: ProcessBackend | DaskBackend, own: bool, table: ResultTable,
                done: dict[str, dict[str, str]], order: dict[str, int], *, progress: bool, figure: bool,
                command_line: str) -> SweepOutcome:
    """Run the points of ``sweep`` that have no row in the open ``table`` (``done``: those that have),
    and finish the table if every point has one (:func:`run_sweep`)."""
    outcome = SweepOutcome(sweep, output, backend.describe(), len(sweep.points), already=len(done),
                           dropped=table.dropped, fresh=table.fresh)
    outcome.counts.update(row["status"] for row in done.values())
    todo = deque(p for p in sweep.points if p.point_id not in done)
    runs_dir = runs_folder(output)
    if sweep.record and todo:  # said once here, rather than by every run failing to record
        try:
            runs_dir.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            table.discard()
            raise cannot(output, exc, "write the sweep's recordings") from None
    label = {p.point_id: p for p in sweep.points}
    table_full = False  # the machine refused a row of the table (the disk full)

    def task(point: Point) -> Task:
        recording = str(runs_dir / f"{point.point_id}.mcap") if sweep.record else None
        return Task(point.index, point.point_id, sweep.scene_text, sweep.scene_source, point.overrides,
                    tuple(sweep.metrics), recording, f"{command_line} (point {point.point_id})".strip(),
                    point.problem, sweep.run_timeout_s)

    def record(point: Point, row: dict[str, Any]) -> None:
        if outcome.limit is not None and row.get("error_type") in RECORDING_FAILURES:
            # a recording that failed in other words once the disk was found full is taken for the
            # same failure: running the point again on resume loses nothing
            row["status"] = "unfinished"
        if row.get("status") in NOT_RESULTS:  # not a result: the point runs again on resume
            outcome.unfinished += 1
            if row.get("limit") and outcome.limit is None:  # no more are submitted
                outcome.limit = str(row["limit"])
            return
        nonlocal table_full
        if table_full:  # the table refused a row: those after it are not written either
            outcome.unfinished += 1
            return
        row.update({a.name: point.values[a.name] for a in sweep.axes})
        row["index"] = point.index
        try:
            table.append(row)
        except OSError as exc:
            if exc.errno not in MACHINE_LIMITS:
                raise
            # the machine's limit, as for a recording: the point runs again on resume, no more are submitted
            outcome.unfinished += 1
            outcome.limit, outcome.limit_on = exc.strerror or str(exc), f"the table {output}"
            table_full = True
            return
        for notice in row.get("notices") or ():
            outcome.notices.setdefault(notice, point.label())
        outcome.ran += 1
        wall = row.get("wall_s")
        outcome.run_wall_s += float(wall) if isinstance(wall, (int, float)) and math.isfinite(wall) else 0.0
        outcome.counts[row["status"]] += 1
        if row["status"] == "failed":
            outcome.failures.append((point.index, point.label(), str(row.get("reason", ""))))
        if outcome.failures:  # (before the update: a log line says the count as it is)
            bar.set_postfix(failed=len(outcome.failures), refresh=False)
        bar.update(1)

    wall0 = time.perf_counter()
    bar = work_progress(len(sweep.points), initial=len(done), desc=sweep.name, unit="run",
                       shown=bool(progress and todo), dynamic_ncols=True, smoothing=0.1)
    pending: dict[Any, Point] = {}
    try:
        with _sigterm_interrupts():
            if todo:
                backend.limit(len(todo))  # (a Dask cluster started already keeps its workers)
                backend.start()
                outcome.backend = backend.describe()
            limit = max(1, IN_FLIGHT_PER_SLOT * backend.slots)
            suspects: deque[Point] = deque()  # in flight when a worker died: retried one at a time
            alone: str | None = None  # the suspect running alone, if any
            broken = False
            while pending or ((todo or suspects) and outcome.limit is None):
                if not broken and outcome.limit is None:
                    try:  # a point leaves its queue only once submitted
                        if suspects:
                            if not pending:
                                alone = suspects[0].point_id
                                future = backend.submit(task(suspects[0]))
                                pending[future] = suspects.popleft()
                        else:
                            while todo and len(pending) < limit:
                                future = backend.submit(task(todo[0]))
                                pending[future] = todo.popleft()
                    except WorkerLost:  # the pool broke before its failed runs came back
                        broken = True
                for future in backend.wait(list(pending)):
                    point = pending.pop(future)
                    try:
                        row = backend.outcome(future)
                    except WorkerLost as exc:
                        if exc.isolate and point.point_id != alone:
                            suspects.append(point)
                            broken = True
                            continue
                        row = _failed_row(point, WORKER_DIED if exc.isolate else "the worker running this point died",
                                          "WorkerLost")
                    except BackendLost:  # no row: the point runs when the sweep is resumed
                        raise
                    except Exception as exc:  # the backend could not run the task at all
                        row = _failed_row(point, f"{type(exc).__name__}: {exc}", type(exc).__name__)
                    if point.point_id == alone:
                        alone = None
                        broken = broken or row["error_type"] == "WorkerLost"
                    record(point, row)
                # no future outlives its row here: Dask keeps a referenced future's result, and runs it
                # again (a run nobody waits for, on the cluster's workers) should its worker die
                future = None
                if broken and not pending:
                    backend.restart()
                    broken = False
    except KeyboardInterrupt:
        outcome.interrupted = True
        backend.abort(list(pending))
    except BackendLost as exc:  # nothing more can run: stopped as by an interruption, to resume later
        outcome.interrupted, outcome.lost = True, str(exc)
        backend.abort(list(pending))
    finally:
        bar.close()
        table.close()
        if own:
            backend.close()
        outcome.wall_s = time.perf_counter() - wall0
    outcome.failures.sort()
    if outcome.complete:
        with LateSignals() as late:
            summary = {"counts": dict(outcome.counts), "backend": backend.info()}
            outcome.rows = table.finish(order, summary)
            outcome.failures = [(int(r["index"]), label[r["point_id"]].label(), r["reason"])
                                for r in outcome.rows if r["status"] == "failed"]
            if figure and sweep.figure is not None:
                from cosim.sweep.figure import draw

                try:
                    outcome.figure = draw(sweep, outcome.rows, figure_path(output))
                except OSError as exc:
                    raise cannot(output, exc, "draw the sweep's figure",
                                 "; the table is complete (--no-figure leaves the figure out)") from None
        outcome.late_signal = late.seen
    return outcome
