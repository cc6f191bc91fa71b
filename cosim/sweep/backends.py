"""Where the runs of a sweep execute: a local process pool, or a Dask cluster.

Both run the same function, :func:`run_task`, on the same :class:`Task` (the base scene's text and the
point's overrides), so a point gives the same row whatever the backend or the worker count; only
``wall_s`` differs. :func:`run_task` never raises: a scene that does not validate, a run that fails
and any other exception all become a row with status ``failed``.

A run that the machine cut short for want of room (the disk full, a quota: :func:`machine_limit`) is
no result of its point: its row has status ``unfinished``, which, like ``interrupted``, the table does
not keep, so the point runs again when the sweep is resumed.

A backend offers ``start``, ``submit(task) -> future``, ``wait(futures) -> done``, ``outcome(future)
-> row``, ``restart``, ``close`` and ``abort``; ``submit`` and ``outcome`` raise :class:`WorkerLost`
when a worker died, and ``submit``, ``wait`` and ``outcome`` raise :class:`BackendLost` when the
backend can run nothing more (the Dask scheduler lost, a cluster left without workers): the sweep
then stops as if interrupted. Dask is imported only by :class:`DaskBackend`.
"""

from __future__ import annotations

import concurrent.futures as cf
import errno
import gc
import logging
import math
import multiprocessing
import os
import platform
import signal
import socket
import struct
import sys
import threading
import time
from collections.abc import Iterable, Iterator
from contextlib import ExitStack, contextmanager
from dataclasses import dataclass
from typing import Any

from cosim.errors import CosimError, ScenarioError, quiet_interrupts
from cosim.params import whole_digits
from cosim.timebase import NS_PER_S, exact_seconds

DASK_CONNECT_TIMEOUT_S = 20  # how long to try reaching a Dask scheduler before giving up
DASK_HANDSHAKE_MAX = 1 << 20  # [bytes] more than any scheduler's first message (its handshake, about 60)
DASK_POLL_S = 1.0  # how often a sweep waiting on Dask looks at whether its cluster can still run its points (s)
# how long a Dask cluster may go on without a worker, or with every worker idle while the sweep's points
# wait, before the sweep stops (s): a local worker that dies is back within seconds, but a cluster whose
# workers do not come back left the sweep waiting without end and without a word
DASK_IDLE_S = 30.0
# what Dask's loggers still print during a sweep: they said, with tracebacks, what the sweep itself says
# in one line (a worker that died and was replaced, a run retried, the scheduler lost)
DASK_LOG_LEVEL = logging.CRITICAL
WORKER_JOIN_TIMEOUT_S = 10  # how long a worker gets to leave at each step of ending a pool (s)
PARENT_POLL_S = 0.2  # how often a pool worker checks that the sweep that started it is still there (s)
# how long a worker whose run a signal interrupted waits for the sweep's stop before taking its next run
# (s): a Ctrl-C reaches the sweep and its workers at once, and the sweep says stop within milliseconds
STOP_WAIT_S = 2.0
# writes the machine refused for want of room (a full disk, a quota, a file-size limit): a run they
# end is no result of its point
MACHINE_LIMITS = (errno.ENOSPC, errno.EDQUOT, errno.EFBIG)
# the terminal's signals, which reach the whole process group: a worker ignores them (the sweep decides
# what to do), and they are held back from it from its spawn until it does (:func:`_spawning_workers`)
WORKER_IGNORED = tuple(getattr(signal, name) for name in ("SIGINT", "SIGHUP") if hasattr(signal, name))


@dataclass(frozen=True)
class Task:
    """Everything a worker needs to run one point (plain data, cheap to pickle)."""

    index: int
    point_id: str
    scene_text: str
    scene_source: str
    overrides: tuple[str, ...]
    metrics: tuple[str, ...]
    recording: str | None = None
    command_line: str = ""
    problem: str | None = None
    timeout_s: float | None = None  # wall seconds the run may take, from its start (None: no bound)


class WorkerLost(Exception):
    """The process running a task died. ``isolate``: the backend cannot tell which of the tasks in
    flight killed it, so each should be retried alone before it is blamed."""

    def __init__(self, reason: str, isolate: bool):
        super().__init__(reason)
        self.isolate = isolate


def _worker_died(exc: BaseException) -> WorkerLost:
    """What a broken (or cancelled) process pool means to a sweep: some worker died, unknown which."""
    return WorkerLost(f"a worker process died ({type(exc).__name__})", isolate=True)


class BackendError(CosimError):
    """A backend that cannot be used (Dask missing, a scheduler out of reach, workers without cosim)."""


class BackendLost(BackendError):
    """A backend that stopped working during the sweep (the Dask scheduler lost, a cluster left without
    workers): nothing more can run on it, and the sweep stops as if interrupted, its rows kept."""


def _cell(value: Any) -> Any:
    """A metric value as plain data (numpy scalars become Python numbers)."""
    item = getattr(value, "item", None)
    return item() if callable(item) and not isinstance(value, (str, bytes)) else value


def machine_limit(exc: BaseException) -> str | None:
    """The operating system's words when ``exc`` is a write the machine refused for want of room
    (:data:`MACHINE_LIMITS`: the disk full, a quota), else None. The recording's writer reports such
    a failure by those words only (a SinkError or RecordingError made from its message), so they are
    looked for in the messages of ``exc`` and its causes too."""
    words = [os.strerror(code) for code in MACHINE_LIMITS]
    seen: set[int] = set()
    while exc is not None and id(exc) not in seen:
        seen.add(id(exc))
        if isinstance(exc, OSError) and exc.errno in MACHINE_LIMITS:
            return os.strerror(exc.errno)
        if isinstance(exc, CosimError):
            found = next((w for w in words if w in str(exc)), None)
            if found is not None:
                return found
        exc = exc.__cause__ or exc.__context__  # type: ignore[assignment]
    return None


# --- in a pool worker: the sweep's stop -------------------------------------------------------------

_stop: Any = None  # the pool's stop event (a multiprocessing Event) once the worker has started
_running: Any = None  # the Simulation this worker runs now, if any
_running_lock = threading.Lock()


def _stopping() -> bool:
    return _stop is not None and _stop.is_set()


def _interrupt(sim: Any) -> None:
    # a run that a Ctrl-C already interrupted keeps its reason: interrupting it again would make the
    # Ctrl-C's own handler take a second signal for "abort at once"
    if sim.interrupt_reason is None:
        sim.interrupt("interrupted: the sweep was stopped")


def _watch_stop(stop: Any) -> None:
    """End the run in progress at its next tick once the sweep says stop (the recording is closed as
    for any interrupted run); the runs queued behind it then return at once (:func:`run_task`)."""
    stop.wait()
    with _running_lock:
        if _running is not None:
            _interrupt(_running)


def _interrupted_row(row: dict[str, Any]) -> dict[str, Any]:
    row.update(status="interrupted", reason="interrupted: the sweep was stopped before this run started")
    return row


TIMED_OUT = "timed out"


def _timeout(sim: Any, seconds: float | None) -> threading.Timer | None:
    """A timer that stops ``sim`` at the end of its step once ``seconds`` of wall time have passed
    (a sweep's stop or a signal that came first keeps its own reason); None without a bound, or with
    one longer than a timer can wait (about 290 years: none)."""
    if seconds is None or seconds >= threading.TIMEOUT_MAX:
        return None

    def stop() -> None:
        with _running_lock:
            # (a run in its last tick is left to reach its end: interrupted there, a finished run was
            # written as timed out)
            last = (sim.tick + 1) * sim.dt_ns >= sim.scene.until_ns
            if sim.interrupt_reason is None and not last:
                sim.interrupt(f"{TIMED_OUT}: still running after {seconds:g} s of wall time (run_timeout)")

    timer = threading.Timer(seconds, stop)
    timer.daemon = True
    timer.start()
    return timer


def _recorded(task: Task, reached: bool) -> bool:
    """Whether the row of ``task`` names its recording: only a run that was started (``reached``) and
    left the file. A point whose derived values failed, or whose scene was refused at load, never ran:
    a cell naming its file would point at nothing, or at a file an earlier run of the point left."""
    return task.recording is not None and reached and os.path.isfile(task.recording)


def run_task(task: Task) -> dict[str, Any]:
    """Run one point and return its row (never raises, except KeyboardInterrupt).

    In a pool worker of a sweep that was stopped the run does not start: its row says ``interrupted``.
    A run ended by a machine limit (:func:`machine_limit`) has status ``unfinished``. A run still going
    ``task.timeout_s`` wall seconds after it started is stopped at the end of its step (its recording
    closed as an interrupted run's) and its row says ``failed``, timed out: a result of its point, not
    run again on resume (a step that never returns is not ended by it). The row names ``task.recording``
    only if the run started and left that file (:func:`_recorded`)."""
    from cosim.runner import collect_metrics, run_scene
    from cosim.scenario import loads
    from cosim.scheduler import Simulation

    global _running
    start = time.perf_counter()
    row: dict[str, Any] = {"index": task.index, "point_id": task.point_id, "status": "failed", "reason": "",
                           "error_type": "", "sim_time_s": math.nan, "ticks": 0}
    row.update(dict.fromkeys(task.metrics))
    if _stopping():
        return _interrupted_row(row)
    reached = False  # whether the run was started: before that, no recording of this task was written
    try:
        if task.problem is not None:
            row.update(reason=task.problem, error_type="ScenarioError")
        else:
            scene = loads(task.scene_text, task.scene_source, list(task.overrides))
            row["notices"] = list(scene.notices)  # said by the command, not kept in the table
            sim = Simulation(scene)
            with _running_lock:
                _running = sim
            if _stopping():  # said while the scene loaded: the run ends at its first tick
                _interrupt(sim)
            timer = _timeout(sim, task.timeout_s)
            reached = True
            try:
                outcome = run_scene(scene, task.recording, progress=False, command_line=task.command_line,
                                    simulation=sim)
            finally:
                if timer is not None:
                    timer.cancel()
                with _running_lock:
                    _running = None
            result = outcome.result
            row.update(status=result.status, reason=result.reason, sim_time_s=result.time_ns / NS_PER_S,
                       ticks=result.tick, error_type=type(result.error).__name__ if result.error else "")
            if result.status == "interrupted" and result.reason.startswith(TIMED_OUT):
                row.update(status="failed", error_type="Timeout",
                           reason=f"{result.reason}; stopped at t = {exact_seconds(result.time_ns)} s")
            limit = machine_limit(result.error) if result.error is not None else None
            if limit:  # a component's own write refused (its file on a full disk)
                row.update(status="unfinished", limit=limit)
            if outcome.simulation is not None:
                metrics = collect_metrics(outcome.simulation)
                row.update({key: _cell(metrics.get(key)) for key in task.metrics})
            if row["status"] == "interrupted" and _stop is not None:
                # a signal (a Ctrl-C reaches every worker with the sweep): the sweep's stop follows
                # at once, and the run queued behind this one must see it before it starts
                _stop.wait(STOP_WAIT_S)
    except ScenarioError as exc:
        row.update(reason="invalid scene: " + "; ".join(exc.problems), error_type="ScenarioError")
    except Exception as exc:  # a sweep goes on whatever one run does: the row says what happened
        limit = machine_limit(exc)
        row.update(status="unfinished" if limit else "failed", reason=f"{type(exc).__name__}: {exc}",
                   error_type=type(exc).__name__)
        if limit:
            row["limit"] = limit  # said once by the sweep, which stops: every run would end the same way
    if _recorded(task, reached):
        row["recording"] = task.recording
    row["wall_s"] = time.perf_counter() - start
    return row


def versions() -> dict[str, str]:
    """The versions that shape a run's results, as recorded with a sweep's table."""
    import numpy

    from cosim import __version__

    return {"cosim": __version__, "python": platform.python_version(), "numpy": numpy.__version__,
            "platform": platform.platform()}


def _warm(seconds: float) -> int:
    """A task that only occupies a worker for a moment (to start every worker of a pool)."""
    time.sleep(seconds)
    return os.getpid()


def _watch_parent(parent: int) -> None:
    """End this worker as soon as the process that started it is gone (killed with SIGKILL, say):
    nobody would collect its results, and the pool's resource tracker waits for every worker to
    leave. A run in progress is cut off; its recording's writer still finishes the file."""
    while os.getppid() == parent:
        time.sleep(PARENT_POLL_S)
    os._exit(1)


@contextmanager
def _spawning_workers() -> Iterator[None]:
    """Hold back the signals a worker ignores (:data:`WORKER_IGNORED`) from the calling thread while it
    spawns workers, and so from each worker it spawns: a child keeps its parent's signal mask across
    fork and exec, and a Ctrl-C that reaches it before it has set them ignored (about a second of
    start-up: the interpreter, the imports, the unpickling) waits, and is dropped when it does
    (:func:`_ignore_terminal_signals`); such a worker printed a KeyboardInterrupt traceback and died.
    A thread started meanwhile keeps the mask for good (Dask's loop, which spawns the workers of a
    local cluster, and starts them again when they die). This process still gets the signal: another
    of its threads takes it at once, or this one once the block ends."""
    if not WORKER_IGNORED or not hasattr(signal, "pthread_sigmask"):
        yield
        return
    before = signal.pthread_sigmask(signal.SIG_BLOCK, WORKER_IGNORED)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, before)


def _ignore_terminal_signals() -> None:
    """In a worker as it starts: ignore :data:`WORKER_IGNORED`, then let them in (they were held back
    since its spawn, :func:`_spawning_workers`; one that came meanwhile is dropped, being ignored)."""
    for signum in WORKER_IGNORED:
        signal.signal(signum, signal.SIG_IGN)
    if WORKER_IGNORED and hasattr(signal, "pthread_sigmask"):
        signal.pthread_sigmask(signal.SIG_UNBLOCK, WORKER_IGNORED)


def _worker_init(parent: int | None = None, stop: Any = None) -> None:
    # Ctrl-C, and SIGHUP when the terminal closes, reach the whole process group: the parent decides
    # what to do, and its stop event ends the runs in flight (a worker that died of the SIGHUP never
    # answered that event, and the sweep waited on it for good). A run in progress still ends
    # cleanly (run_scene installs its own handler for the run's duration).
    global _stop
    _ignore_terminal_signals()
    # a second Ctrl-C raised inside a callback the interpreter runs itself (numba's compiler notifying
    # its cache through ctypes) cannot be passed on: it is dropped, and printed with a traceback by the
    # default hook; the run ends at its next tick all the same (the first one stopped it)
    sys.unraisablehook = quiet_interrupts(sys.unraisablehook)
    if parent is not None:
        threading.Thread(target=_watch_parent, args=(parent,), name="cosim-parent-watch", daemon=True).start()
    if stop is not None:
        _stop = stop
        threading.Thread(target=_watch_stop, args=(stop,), name="cosim-stop-watch", daemon=True).start()
    import cosim.runner  # noqa: F401  (import once per worker, not once per run)


def _inheritable_descriptors() -> list[int]:
    """This process's open file descriptors that a process it spawns would inherit (none listed where
    /proc/self/fd is not there to list them)."""
    try:
        listed = [int(name) for name in os.listdir("/proc/self/fd")]
    except OSError:
        return []
    kept = []
    for fd in listed:
        try:
            if os.get_inheritable(fd):
                kept.append(fd)
        except OSError:  # the listing's own descriptor, closed since
            pass
    return kept


def _start_resource_tracker() -> None:
    """Start multiprocessing's resource tracker, the process that removes the pool's semaphores
    (named files under spawn, /dev/shm/sem.mp-*) once every process using them is gone, in a session
    of its own. In the sweep's process group it died with the group: a SIGKILL of the group left ten
    semaphores in /dev/shm for good, and SIGHUP (the terminal closed) ended it, after which the
    tracker started in its place printed a traceback for each semaphore it did not know. Out of the
    group it sees the sweep and its workers gone, removes what they left, and leaves (it ignores
    Ctrl-C and SIGTERM itself). Its warnings about what it removes go nowhere: it speaks only once
    the sweep is gone, killed, and what it announces is the cleanup it is there for.

    It is multiprocessing's own tracker (its ``main``), started as ``ensure_running`` would start it;
    a tracker already running in this process is kept."""
    from multiprocessing import resource_tracker, spawn

    tracker = resource_tracker._resource_tracker
    if getattr(tracker, "_fd", None) is not None or not hasattr(tracker, "_pid"):
        resource_tracker.ensure_running()  # started already (or a Python whose tracker is built otherwise)
        return
    with tracker._lock:
        read, write = os.pipe()
        try:
            # spawned by its pid alone, as multiprocessing spawns it: it outlives this process's use of
            # it (it leaves once this process is gone), and multiprocessing waits for it by that pid (a
            # subprocess.Popen held for it warned "subprocess ... is still running" at every exit)
            os.set_inheritable(read, True)
            executable = spawn.get_executable()
            # its standard streams on /dev/null, and no other descriptor of this process kept open in it
            # (one it holds keeps a pipe of the sweep's caller open after the sweep has ended)
            actions = [(os.POSIX_SPAWN_OPEN, fd, os.devnull, os.O_RDWR, 0) for fd in (0, 1, 2)]
            actions += [(os.POSIX_SPAWN_CLOSE, fd) for fd in _inheritable_descriptors() if fd > 2 and fd != read]
            pid = os.posix_spawn(executable, [executable, "-c",
                                              f"from multiprocessing.resource_tracker import main; main({read})"],
                                 os.environ, file_actions=actions, setsid=True)
        except BaseException:
            os.close(write)
            raise
        finally:
            os.close(read)
        tracker._fd, tracker._pid = write, pid


class ProcessBackend:
    """A local pool of ``workers`` processes (spawned, so no state leaks from the parent), kept alive
    across runs; the default backend."""

    def __init__(self, workers: int | None = None):
        self.workers = max(1, workers or os.cpu_count() or 1)
        self.pool: cf.ProcessPoolExecutor | None = None
        self.stop: Any = None  # the pool's stop event, shared with its workers: set, no queued run starts

    @property
    def slots(self) -> int:
        return self.workers

    def limit(self, points: int) -> None:
        """No more workers than the ``points`` there are to run (a worker is a process holding its own
        copy of the simulation: a sweep of 16 points with --workers 1000 started 16, and said 1000).
        Only before the pool starts."""
        if self.pool is None:
            self.workers = max(1, min(self.workers, points))

    def describe(self) -> str:
        return f"process pool of {self.workers} worker{'s' * (self.workers != 1)}"

    def info(self) -> dict[str, Any]:
        return {"backend": "process", "workers": self.workers}

    def start(self) -> None:
        if self.pool is None:
            _start_resource_tracker()
            context = multiprocessing.get_context("spawn")
            self.stop = context.Event()
            self.pool = cf.ProcessPoolExecutor(self.workers, mp_context=context, initializer=_worker_init,
                                               initargs=(os.getpid(), self.stop))

    def warm_up(self) -> None:
        """Start every worker now (benchmarks time the runs, not the start-up)."""
        self.start()
        assert self.pool is not None
        with _spawning_workers():
            futures = [self.pool.submit(_warm, 0.2) for _ in range(self.workers)]
        for future in futures:
            future.result()

    def submit(self, task: Task) -> cf.Future:
        """Queue ``task``; raises :class:`WorkerLost` if a worker died since the last restart."""
        assert self.pool is not None, "start() the backend first"
        try:
            with _spawning_workers():  # (the pool spawns its workers as tasks are submitted)
                return self.pool.submit(run_task, task)
        except cf.process.BrokenProcessPool as exc:
            raise _worker_died(exc) from None

    def wait(self, futures: Iterable[cf.Future]) -> set[cf.Future]:
        return cf.wait(list(futures), return_when=cf.FIRST_COMPLETED).done

    def outcome(self, future: cf.Future) -> dict[str, Any]:
        try:
            return future.result()
        except (cf.process.BrokenProcessPool, cf.CancelledError) as exc:
            raise _worker_died(exc) from None

    def restart(self) -> None:
        """A fresh pool after a worker died (the old one is unusable)."""
        self._end_pool(grace_s=0.0)
        self.start()

    def close(self) -> None:
        """End the workers: queued runs are dropped, runs in flight get ``WORKER_JOIN_TIMEOUT_S``."""
        self._end_pool(grace_s=WORKER_JOIN_TIMEOUT_S)

    def abort(self, futures: Iterable[cf.Future]) -> None:
        """Stop at once (an interrupted sweep): no queued run starts, and the runs in flight end at
        their next tick with status ``interrupted``, their recordings closed.

        The executor cannot withdraw the calls already in its call queue, and SIGTERM ends only a
        worker's run in progress, not the worker (run_scene's handler), which took the next queued
        call and ran it until SIGKILL. So the workers are told first, by the pool's stop event: each
        ends its run and returns the calls still queued at once, then leaves on the executor's own
        sentinel; only one that does not within ``WORKER_JOIN_TIMEOUT_S`` gets SIGTERM, then SIGKILL."""
        if self.stop is not None:
            self.stop.set()
        self._end_pool(grace_s=WORKER_JOIN_TIMEOUT_S)

    def _end_pool(self, grace_s: float) -> None:
        """Shut the pool down and make sure every worker is gone.

        ``ProcessPoolExecutor.shutdown(wait=True)`` can wait forever on a pool a dying worker broke:
        a worker started by a submit that raced the executor's own clean-up never gets its SIGTERM
        nor a sentinel, and the executor joins it without a time limit. So the workers are ended
        here: each gets ``grace_s`` to leave on its own, then SIGTERM (a run in progress ends at
        its next tick: run_scene's handler), then SIGKILL.
        """
        pool, self.pool = self.pool, None
        if pool is None:
            return
        processes = list((getattr(pool, "_processes", None) or {}).values())  # no public handle on them
        manager = getattr(pool, "_executor_manager_thread", None)
        if getattr(pool, "_broken", False):
            grace_s = 0.0  # nothing left to finish
        pool.shutdown(wait=False, cancel_futures=True)
        for proc in processes:
            proc.join(grace_s)
        for proc in processes:
            if proc.is_alive():
                proc.terminate()
        for proc in processes:
            proc.join(WORKER_JOIN_TIMEOUT_S)
            if proc.is_alive():
                proc.kill()
                proc.join()
        if manager is not None:
            manager.join(WORKER_JOIN_TIMEOUT_S)  # it only joins the workers, all gone by now


def dask_setup(worker: Any) -> None:
    """Run by Dask in each worker process of a local cluster as it starts (its ``preload``).

    Ctrl-C, and SIGHUP when the terminal closes, reach the whole process group, the workers of
    ``--dask local`` with the sweep: each printed a KeyboardInterrupt traceback as it died. They are
    ignored here, as in a pool worker (:func:`_worker_init`); the sweep stops its cluster itself. A
    worker the nanny starts again after one died runs this again."""
    if threading.current_thread() is not threading.main_thread():
        return  # a worker thread of this very process (processes=False): signals are not its to set
    _ignore_terminal_signals()  # (held back since its spawn: DaskBackend.start)


def _quiet_loggers(level: int) -> ExitStack:
    """Set Dask's loggers (``distributed`` and those below it that have a level of their own, such
    as ``distributed.client``, and ``tornado``, whose errors come from Dask's connections) to
    ``level`` until the returned stack is closed."""
    stack = ExitStack()
    names = {"distributed", "tornado", *(name for name in logging.root.manager.loggerDict
                                         if name.split(".")[0] in ("distributed", "tornado"))}
    for name in sorted(names):
        logger = logging.getLogger(name)
        if logger.level != logging.NOTSET or "." not in name:  # the others take their parent's
            stack.callback(logger.setLevel, logger.level)
            logger.setLevel(max(level, logger.level))
    return stack


def _lost_errors() -> tuple[type[BaseException], ...]:
    """What Dask raises once its scheduler is gone: the sweep's futures cancelled when the client gave
    up reconnecting (FuturesCancelledError, a concurrent.futures CancelledError), asyncio's
    CancelledError from a call cut off, and a closed or refused connection (CommClosedError and any
    other OSError)."""
    import asyncio

    return (cf.CancelledError, asyncio.CancelledError, OSError)


class DaskBackend:
    """Runs on a Dask cluster: ``address`` ``tcp://HOST:PORT`` of a running scheduler, or ``local``
    for a LocalCluster of ``workers`` single-threaded workers on 127.0.0.1 (``processes=False``:
    threads of this process, for tests). Every worker must have this project installed.

    A worker that dies takes down every run it held (Dask blames them all, KilledWorker): as in the
    process pool, each is retried alone before it is taken for the one that kills its worker. Waiting
    is bounded: a cluster left without workers, or whose workers all stay idle while the sweep's
    points wait, for ``DASK_IDLE_S``, and a scheduler lost, raise :class:`BackendLost`. ``quiet``: Dask's
    loggers print only critical messages while the backend is open (the sweep says what happened)."""

    def __init__(self, address: str = "local", workers: int | None = None, *, processes: bool = True,
                 timeout_s: float | None = None, quiet: bool = True):
        self.address = address
        self.timeout_s = timeout_s
        self.workers = max(1, workers or os.cpu_count() or 1)
        self.processes = processes
        self.quiet = quiet
        self.client: Any = None
        self.cluster: Any = None
        self.worker_versions: dict[str, dict[str, str]] = {}
        self._slots = 0
        self._settings = ExitStack()  # undone by close(): Dask's loggers quieted, its settings for a local cluster

    @property
    def slots(self) -> int:
        return self._slots

    def limit(self, points: int) -> None:
        """A local cluster of no more workers than the ``points`` there are to run, as a process pool
        (:meth:`ProcessBackend.limit`: ``--dask local --workers 8`` for 2 points started 8). Only before
        it starts; a remote cluster's workers are its own."""
        if self.address == "local" and self.client is None:
            self.workers = max(1, min(self.workers, points))

    def _where(self, part: str = "") -> str:
        """The cluster (or ``part`` of it: "scheduler"), as the sweep's lines name it."""
        if self.address == "local":
            return f"the local Dask cluster's {part}" if part else "the local Dask cluster"
        return f"the Dask {part} at {self.address}" if part else f"the Dask cluster at {self.address}"

    def describe(self) -> str:
        where = (f"a local Dask cluster of {self.workers} worker{'s' * (self.workers != 1)}" if self.address == "local"
                 else f"the Dask cluster at {self.address}")
        return f"{where} ({self._slots} threads)" if self._slots else where

    def info(self) -> dict[str, Any]:
        return {"backend": "dask", "address": self.address, "threads": self._slots,
                "worker_versions": self.worker_versions}

    def start(self) -> None:
        if self.client is not None:
            return
        try:
            import dask
            from distributed import Client, LocalCluster
        except ImportError:
            raise BackendError("--dask needs dask and distributed: pip install 'cosim[dask]' "
                               "(or pip install dask distributed)") from None
        if self.quiet:
            self._settings.enter_context(_quiet_loggers(DASK_LOG_LEVEL))
        began = time.monotonic()
        try:
            if self.address == "local":
                options: dict[str, Any] = {}
                if self.processes:
                    # the tracker of the semaphores its nannies make, out of reach of the terminal's
                    # signals as for a pool (a SIGHUP ended it, and the one started in its place printed
                    # a traceback for each of them)
                    _start_resource_tracker()
                    # each worker process ignores the terminal's signals (dask_setup), and logs as quietly
                    options.update(preload=[__name__],
                                   silence_logs=DASK_LOG_LEVEL if self.quiet else logging.WARNING)
                # a nanny starts its worker again when it dies, but the cluster also closed any nanny
                # whose worker was gone lost-worker-timeout (15 s) after some earlier death: one caught
                # between its worker's lives was closed for good, and the sweep left without workers
                # (read whenever a worker leaves: set while the backend is open)
                self._settings.enter_context(dask.config.set({"distributed.deploy.lost-worker-timeout": "1000d"}))
                # a task whose worker died fails at once (KilledWorker) rather than being retried on
                # three more workers with whatever runs there: the sweep retries each such point alone
                # itself, and Dask's retries only multiplied the deaths, and the innocent points blamed.
                # Its workers are spawned by the loop thread the cluster starts here, which keeps the
                # terminal's signals held back for good (_spawning_workers): a Ctrl-C meanwhile is said
                # once the cluster is made, and closes it (a cluster cut off halfway was left to
                # Dask's exit hook, which printed a KeyboardInterrupt traceback)
                with (dask.config.set({"distributed.scheduler.allowed-failures": 0}),
                      _spawning_workers() if self.processes else ExitStack()):
                    self.cluster = LocalCluster(n_workers=self.workers, threads_per_worker=1,
                                                processes=self.processes, host="127.0.0.1",
                                                protocol="tcp://",
                                                dashboard_address="127.0.0.1:0",  # any free port, not 8787
                                                **options)
                self.client = Client(self.cluster)
            else:
                timeout = self.timeout_s or DASK_CONNECT_TIMEOUT_S
                probe_scheduler(self.address, timeout)
                self.client = Client(self.address, timeout=f"{timeout}s")
        except BackendError:
            self.close()
            raise
        except (OSError, TimeoutError, ValueError) as exc:  # unreachable, or not an address
            # (a scheduler still starting refuses at first: it was tried again for as long as that takes)
            waited = f" (tried for {time.monotonic() - began:.0f} s)" if self.address != "local" else ""
            failed = f"cannot reach the Dask scheduler at {self.address}: {exc}{waited}"
        except MemoryError:  # its answer read as a Dask message announced an absurd size
            failed = f"{self.address} is not a Dask scheduler: its answer is not Dask's protocol"
        else:
            failed = ""
        if failed:
            self.close()
            # a Client whose making failed is left in a reference cycle and closes itself once the
            # collector finds it, taking the lock of Dask's loop runners: found in the loop thread of the
            # next local cluster as that started (holding the lock), it hung it for 10 s, then failed.
            # Collected here, out of the except clause (whose traceback held it), with no lock held
            gc.collect()
            raise BackendError(failed)
        try:
            self.worker_versions = self.client.run(versions)
        except Exception as exc:  # e.g. a worker that cannot import cosim cannot even unpickle the call
            self.close()
            raise BackendError(f"the Dask workers at {self.address} cannot run cosim ({type(exc).__name__}: "
                               f"{exc}); install this project on every worker") from None
        self._slots = sum(self.client.nthreads().values())
        if not self._slots:
            self.close()
            raise BackendError(f"the Dask cluster at {self.address} has no workers")

    def mismatched_versions(self) -> list[str]:
        """Workers whose cosim, Python or numpy version differs from this process's."""
        here = versions()
        return [f"{worker}: {key} {theirs[key]} (here {here[key]})"
                for worker, theirs in sorted(self.worker_versions.items())
                for key in ("cosim", "python", "numpy") if theirs.get(key) != here[key]]

    def _lost(self, exc: BaseException) -> BackendLost:
        return BackendLost(f"lost {self._where('scheduler')} ({type(exc).__name__})")

    def submit(self, task: Task) -> Any:
        try:
            return self.client.submit(run_task, task, pure=False)
        except _lost_errors() as exc:
            raise self._lost(exc) from None

    def wait(self, futures: Iterable[Any]) -> set[Any]:
        """The futures done, once one is; raises :class:`BackendLost` when none can be (see the class)."""
        from distributed import wait

        futures = list(futures)
        stalled_since: float | None = None
        while True:
            try:
                return set(wait(futures, timeout=DASK_POLL_S, return_when="FIRST_COMPLETED").done)
            except TimeoutError:  # (an OSError: before the lost connections below)
                pass
            except _lost_errors() as exc:
                raise self._lost(exc) from None
            stalled_since = self._check(stalled_since)

    def outcome(self, future: Any) -> dict[str, Any]:
        """The row of a future that is done. Fetching it is bounded as waiting is: a result whose worker
        left before it was fetched is computed again, on a worker there may no longer be."""
        from distributed import KilledWorker

        stalled_since: float | None = None
        while True:
            try:
                return future.result(timeout=DASK_POLL_S)
            except KilledWorker:
                # every run the dead worker held is blamed, not only the one that killed it: retried alone
                raise WorkerLost("a Dask worker died (KilledWorker)", isolate=True) from None
            except TimeoutError:  # (an OSError: before the lost connections below)
                pass
            except _lost_errors() as exc:
                raise self._lost(exc) from None
            stalled_since = self._check(stalled_since)

    def _check(self, stalled_since: float | None) -> float | None:
        """After a wait that timed out: when the cluster has been stalled (:meth:`_stalled`) since
        ``stalled_since`` for ``DASK_IDLE_S``, raise :class:`BackendLost`; else return since when it
        is stalled (None: it is not)."""
        stalled = self._stalled()
        now = time.monotonic()
        if stalled is None:
            return None
        if stalled_since is None:
            return now
        if now - stalled_since >= DASK_IDLE_S:
            raise BackendLost(stalled.format(where=self._where(), s=f"{DASK_IDLE_S:g} s"))
        return stalled_since

    def _stalled(self) -> str | None:
        """Why the cluster runs none of the sweep's waiting points now (a message with ``{where}`` and
        ``{s}`` to fill), or None while it can: workers busy, with the sweep's runs or with another
        client's, are progress."""
        try:
            if not self.client.nthreads():
                return "{where} has had no workers for {s} (they died, and none came back)"
            if not any(self.client.processing().values()):
                return "{where} has left the sweep's points waiting for {s} with every worker idle"
        except _lost_errors() as exc:
            raise self._lost(exc) from None
        return None

    def restart(self) -> None:
        pass  # Dask replaces lost workers itself

    def close(self) -> None:
        try:
            if self.client is not None:
                self.client.close()
                self.client = None
            if self.cluster is not None:
                self.cluster.close()
                self.cluster = None
        finally:
            self._settings.close()

    def abort(self, futures: Iterable[Any]) -> None:
        if self.client is not None:
            try:
                self.client.cancel(list(futures))
            except _lost_errors():
                pass  # the scheduler is gone: nothing runs there to cancel
        self.close()


def probe_scheduler(address: str, timeout_s: float) -> None:
    """Check that a ``tcp://HOST:PORT`` address is a Dask scheduler before Dask's client connects
    (which waits without end on a server that never answers, and reads another server's reply as a
    message of absurd size): a scheduler speaks first, its handshake an 8-byte little-endian length
    and a few dozen bytes. Raises :class:`BackendError` naming what answered instead; an address of
    another protocol (tls://, ucx://) is left to Dask. An unreachable one raises OSError."""
    scheme, sep, rest = address.partition("://")
    if sep and scheme != "tcp":
        return
    host, _, port = (rest if sep else address).rpartition(":")
    if not host or not whole_digits(port):
        return  # Dask's own parsing says what is wrong with it
    hint = "is it the scheduler's address (port 8786 by default), not its dashboard's (8787)?"
    deadline = time.monotonic() + timeout_s
    while True:  # a scheduler still starting refuses at first: tried again until the timeout, as Dask does
        try:
            conn = socket.create_connection((host.strip("[]"), int(port)), timeout=timeout_s)
            break
        except ConnectionRefusedError:
            if time.monotonic() + 0.2 > deadline:
                raise
            time.sleep(0.2)
    first = b""
    with conn:
        while len(first) < 8:  # its header may come in more than one piece
            left = deadline - time.monotonic()
            try:
                if left <= 0:
                    raise TimeoutError
                conn.settimeout(left)
                got = conn.recv(64)
            except TimeoutError:
                raise BackendError(f"{address} is not a Dask scheduler: it accepted the connection but said "
                                   f"nothing within {timeout_s:g} s (a scheduler speaks first); {hint}") from None
            if not got:
                if first:
                    break
                raise BackendError(f"{address} is not a Dask scheduler: it closed the connection without a "
                                   f"word (a scheduler speaks first); {hint}")
            first += got
    if first.startswith(b"HTTP/"):
        status = first.split(b"\r\n", 1)[0].decode("ascii", "replace")
        raise BackendError(f"{address} is not a Dask scheduler: it answered as a web server ({status!r}); {hint}")
    if len(first) < 8 or not 0 < struct.unpack("<Q", first[:8])[0] <= DASK_HANDSHAKE_MAX:
        raise BackendError(f"{address} is not a Dask scheduler: its first bytes {first[:16]!r} are not a Dask "
                           f"message; {hint}")


def make_backend(dask: str | None = None, workers: int | None = None, *,
                 quiet: bool = True) -> ProcessBackend | DaskBackend:
    """The backend the CLI flags ask for: a process pool, or Dask at ``dask`` (``local`` or an address).
    ``quiet``: Dask's own log lines are left out (see :class:`DaskBackend`)."""
    if dask is None:
        return ProcessBackend(workers)
    return DaskBackend(dask, workers, quiet=quiet)
