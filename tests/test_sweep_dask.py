"""The Dask backend: the same rows as the process pool, on a cluster reached over loopback TCP."""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from cosim.cli import main
from cosim.sweep.backends import BackendError, DaskBackend, ProcessBackend
from cosim.sweep.plan import load_sweep
from cosim.sweep.run import run_sweep
from tests.sweep_toys import interrupt_sweep, read_table, write_sweep

distributed = pytest.importorskip("distributed")

SWEEP = """
scene: ball.yaml
axes:
  components.ball.angle_deg: {linspace: [20, 70, 3]}
  components.ball.speed: [2, 3, 5]
  components.ball.fail_at_bounce: [0, 3]
"""


@pytest.fixture
def cluster():
    """A Dask LocalCluster on 127.0.0.1 over TCP, its two workers threads of this process."""
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False, host="127.0.0.1",
                                  protocol="tcp://", dashboard_address="127.0.0.1:0") as local:
        yield local


def test_dask_cluster_gives_the_process_pool_table(tmp_path, cluster):
    """A sweep run on a Dask scheduler at tcp://127.0.0.1:PORT writes the very table the process pool
    writes (failed points included), wall time aside."""
    sweep = load_sweep(write_sweep(tmp_path, SWEEP))
    assert cluster.scheduler_address.startswith("tcp://127.0.0.1:")
    dask = DaskBackend(cluster.scheduler_address, timeout_s=10)
    try:
        on_dask = run_sweep(sweep, tmp_path / "dask.csv", dask, progress=False, figure=False)
        assert dask.slots == 2 and dask.mismatched_versions() == []
    finally:
        dask.close()
    pool = ProcessBackend(2)
    try:
        run_sweep(sweep, tmp_path / "pool.csv", pool, progress=False, figure=False)
    finally:
        pool.close()
    assert on_dask.complete and on_dask.counts["failed"] > 0
    assert read_table(tmp_path / "dask.csv") == read_table(tmp_path / "pool.csv")
    assert on_dask.backend == f"the Dask cluster at {cluster.scheduler_address} (2 threads)"


def test_a_local_dask_cluster_resumes_a_pool_table(tmp_path):
    """`--dask local` starts its own LocalCluster on loopback; it resumes a table the process pool
    began, and the result equals a table written by one backend alone."""
    sweep = load_sweep(write_sweep(tmp_path, SWEEP))
    pool = ProcessBackend(1)
    try:
        run_sweep(sweep, tmp_path / "whole.csv", pool, progress=False, figure=False)
    finally:
        pool.close()
    lines = (tmp_path / "whole.csv").read_text().splitlines(keepends=True)
    (tmp_path / "half.csv").write_text("".join(lines[:10]))
    (tmp_path / "half.meta.json").write_text((tmp_path / "whole.meta.json").read_text())
    dask = DaskBackend("local", 2, processes=False)
    try:
        outcome = run_sweep(sweep, tmp_path / "half.csv", dask, progress=False, figure=False)
    finally:
        dask.close()
    assert (outcome.already, outcome.ran) == (9, 9)
    assert read_table(tmp_path / "half.csv") == read_table(tmp_path / "whole.csv")


def test_an_unreachable_scheduler_is_reported(tmp_path):
    """A scheduler that does not answer, or an address that is not one, is a BackendError."""
    with pytest.raises(BackendError, match=r"cannot reach the Dask scheduler at tcp://127\.0\.0\.1:9: "
                                           r".*Connection refused"):
        DaskBackend("tcp://127.0.0.1:9", timeout_s=1).start()
    with pytest.raises(BackendError, match=r"cannot reach the Dask scheduler at nowhere: .*port"):
        DaskBackend("nowhere", timeout_s=1).start()


def test_an_address_dask_cannot_take_leaves_no_client_behind():
    """A Client whose making failed (an address with no port) is closed at once: left in a reference
    cycle, it closed itself whenever the collector found it, taking the lock Dask's loop runners share,
    and found in the loop thread of the next local cluster as that started, it hung it for 10 s and
    failed it (an AssertionError in distributed)."""
    import gc

    def clients() -> int:
        # (by the object's own type: isinstance asks a weak proxy for its class, and a dead one raises)
        return sum(issubclass(type(o), distributed.Client) for o in gc.get_objects())

    gc.collect()  # (what earlier tests left)
    before = clients()
    with pytest.raises(BackendError, match="missing port number"):
        DaskBackend("nowhere", timeout_s=1).start()
    assert clients() == before


def test_dask_local_with_worker_processes(tmp_path):
    """A LocalCluster of worker processes (loopback TCP) gives the same table as the process pool."""
    sweep = load_sweep(write_sweep(tmp_path, SWEEP))
    dask = DaskBackend("local", 2, processes=True)
    try:
        run_sweep(sweep, tmp_path / "dask.csv", dask, progress=False, figure=False)
    finally:
        dask.close()
    pool = ProcessBackend(2)
    try:
        run_sweep(sweep, tmp_path / "pool.csv", pool, progress=False, figure=False)
    finally:
        pool.close()
    assert read_table(tmp_path / "dask.csv") == read_table(tmp_path / "pool.csv")


def test_a_local_cluster_starts_while_the_default_dashboard_port_is_taken():
    """Another Dask cluster (or anything) on port 8787 does not stop ``--dask local``: its HTTP
    server takes any free port (port-in-use warnings are errors in this suite)."""
    import socket

    blocker = socket.socket()
    try:
        try:
            blocker.bind(("0.0.0.0", 8787))
            blocker.listen()
        except OSError:
            pass  # taken already: the very case
        backend = DaskBackend("local", 1, processes=False)
        try:
            backend.start()
            assert backend.slots == 1
        finally:
            backend.close()
    finally:
        blocker.close()


def _server(answer: bytes | list[bytes] | None, *, pause_s: float = 0.0):
    """A TCP server on 127.0.0.1 that accepts and then sends ``answer`` (None: says nothing; a list:
    its parts, each ``pause_s`` after the one before, the first too); its address and a function
    stopping it."""
    import socket
    import threading

    srv = socket.socket()
    srv.bind(("127.0.0.1", 0))
    srv.listen()
    held = []

    def serve():
        while True:
            try:
                conn, _ = srv.accept()
            except OSError:
                return
            held.append(conn)
            if answer is not None:
                try:
                    for part in ([answer] if isinstance(answer, bytes) else answer):
                        time.sleep(pause_s)
                        conn.sendall(part)
                except OSError:  # stopped, or the client left: nothing more to send
                    return

    threading.Thread(target=serve, daemon=True).start()

    def stop():
        srv.close()
        for conn in held:
            conn.close()

    return f"tcp://127.0.0.1:{srv.getsockname()[1]}", stop


@pytest.mark.parametrize(("answer", "said"), [
    (None, "it accepted the connection but said nothing within 2 s"),
    (b"HTTP/1.1 400 Bad Request\r\nContent-Length: 0\r\n\r\n", "answered as a web server ('HTTP/1.1 400 Bad Request')"),
    (b"\xff" * 64, "are not a Dask message"),
])
def test_an_address_that_is_no_dask_scheduler_is_named_so(answer, said):
    """A server that is not a Dask scheduler (a web server, the dashboard's port by mistake): one
    BackendError saying what answered, within the timeout. Before, Dask's client waited without end
    on a silent server and read a web server's reply as a message of absurd size ("out of memory")."""
    address, stop = _server(answer)
    try:
        with pytest.raises(BackendError, match=re.escape(f"{address} is not a Dask scheduler: ") + ".*"
                           + re.escape(said) + r".*port 8786 by default"):
            DaskBackend(address, timeout_s=2).start()
    finally:
        stop()


def test_a_scheduler_whose_handshake_comes_in_pieces_and_late_passes_the_probe():
    """A Dask header split across TCP segments (3 bytes, then the rest), each part 1 s after the one
    before (within the 3 s timeout), is a scheduler's: the probe does not refuse it (it read once,
    and waited 5 s at most whatever the timeout)."""
    import struct

    from cosim.sweep.backends import probe_scheduler

    handshake = struct.pack("<Q", 58) + bytes(58)
    address, stop = _server([handshake[:3], handshake[3:]], pause_s=1.0)
    try:
        probe_scheduler(address, 3.0)
    finally:
        stop()


SLOW = """
scene: ball.yaml
axes:
  components.ball.speed: [2, 3, 4, 5, 6, 7, 8, 9]
set: {components.ball.burn: 2000}
"""

DIE = """
scene: ball.yaml
axes:
  components.ball.speed: [2, 3, 4]
  components.ball.die: [false, true]
set: {components.ball.burn: 2000}
"""


def test_a_point_that_kills_its_dask_worker_is_the_only_one_lost(tmp_path):
    """On a local cluster of worker processes, a point that ends its worker is retried alone, as on
    the process pool: only it is a failed row (WorkerLost), with the same words as the pool's, so the
    table equals the pool's. Dask blamed every run the dead worker held (KilledWorker), and those
    innocent points were failed rows for good; each reason held a task id and a worker's port."""
    sweep = load_sweep(write_sweep(tmp_path, DIE))
    dask = DaskBackend("local", 2, processes=True)
    try:
        outcome = run_sweep(sweep, tmp_path / "dask.csv", dask, progress=False, figure=False)
    finally:
        dask.close()
    assert outcome.complete and outcome.counts["failed"] == 3
    pool = ProcessBackend(2)
    try:
        run_sweep(sweep, tmp_path / "pool.csv", pool, progress=False, figure=False)
    finally:
        pool.close()
    on_dask = read_table(tmp_path / "dask.csv")
    assert on_dask == read_table(tmp_path / "pool.csv")
    reasons = {row[5] for row in on_dask[1:] if row[3] == "true"}
    assert reasons == {"the worker running this point died (it ran alone: this point ends its worker)"}


def _sweep_until(run, seconds: float):
    """``run()``'s result, run in a thread; None if it has not returned within ``seconds`` (a hang
    fails the test instead of stalling the suite)."""
    import threading

    box = []
    thread = threading.Thread(target=lambda: box.append(run()), daemon=True)
    thread.start()
    thread.join(seconds)
    return box[0] if box else None


def test_a_cluster_left_without_workers_stops_the_sweep_saying_so(tmp_path, cluster, monkeypatch):
    """Every worker gone during a sweep (workers that died and were not replaced): once the cluster
    has had none for DASK_IDLE_S, the sweep stops as an interrupted one, its rows kept, its line
    naming the cause and saying that running it again resumes (it waited without end, without a
    word). A result fetched from a worker that has left is bounded the same way."""
    import cosim.sweep.backends as backends

    monkeypatch.setattr(backends, "DASK_IDLE_S", 1.0, raising=False)
    monkeypatch.setattr(backends, "DASK_POLL_S", 0.2, raising=False)
    sweep = load_sweep(write_sweep(tmp_path, SLOW))
    dask = DaskBackend(cluster.scheduler_address, timeout_s=10)
    fetch = dask.outcome

    def outcome(future):  # the workers leave as the first row comes back
        row = fetch(future)
        cluster.scale(0)
        return row

    dask.outcome = outcome
    try:
        stopped = _sweep_until(lambda: run_sweep(sweep, tmp_path / "t.csv", dask, progress=False, figure=False), 60)
    finally:
        dask.close()
    assert stopped is not None, "the sweep should have stopped"
    assert stopped.interrupted and not stopped.complete
    rows = len((tmp_path / "t.csv").read_text().splitlines()) - 1
    assert rows >= 1 and stopped.points_left() == 8 - rows
    assert stopped.stopped_line() == (f"the Dask cluster at {cluster.scheduler_address} has had no workers for 1 s "
                                      f"(they died, and none came back): {8 - rows} of 8 points left; run the same "
                                      "command again to resume")



@pytest.fixture
def doomed_cluster():
    """A cluster like ``cluster`` whose scheduler a test closes: ending it then tries to reach that
    scheduler, for 2 s rather than Dask's 30."""
    import dask

    with dask.config.set({"distributed.comm.timeouts.connect": "2s"}), distributed.LocalCluster(
            n_workers=2, threads_per_worker=1, processes=False, host="127.0.0.1", protocol="tcp://",
            dashboard_address="127.0.0.1:0") as local:
        yield local


def test_a_lost_scheduler_stops_the_sweep_in_one_line(tmp_path, doomed_cluster):
    """The scheduler gone during a sweep: the sweep stops as an interrupted one, its rows kept, and
    says in one line that it lost the scheduler and that running it again resumes (it ended in an
    internal FuturesCancelledError, a point became a failed row, and Dask's loggers printed
    tracebacks); while the backend is open, Dask's loggers say nothing short of critical."""
    import logging

    records: list[logging.LogRecord] = []

    class Keep(logging.Handler):
        def emit(self, record):
            records.append(record)

    sweep = load_sweep(write_sweep(tmp_path, SLOW))
    dask = DaskBackend(doomed_cluster.scheduler_address, timeout_s=2)
    fetch = dask.outcome

    def outcome(future):  # the scheduler goes as the first row comes back
        row = fetch(future)
        if doomed_cluster.scheduler.status.name == "running":
            doomed_cluster.sync(doomed_cluster.scheduler.close)
        return row

    dask.outcome = outcome
    keep = Keep()
    loggers = [logging.getLogger(name) for name in ("distributed", "distributed.client", "tornado")]
    dask.start()
    for logger in loggers:
        logger.addHandler(keep)
    try:
        stopped = _sweep_until(lambda: run_sweep(sweep, tmp_path / "t.csv", dask, progress=False, figure=False), 60)
    finally:
        dask.close()
        for logger in loggers:
            logger.removeHandler(keep)
    assert stopped is not None, "the sweep should have stopped"
    assert stopped.interrupted and stopped.counts.get("failed", 0) == 0
    rows = len((tmp_path / "t.csv").read_text().splitlines()) - 1
    assert rows >= 1 and stopped.points_left() == 8 - rows
    assert re.fullmatch(re.escape(f"lost the Dask scheduler at {doomed_cluster.scheduler_address} (") + r"\w+\): "
                        + re.escape(f"{8 - rows} of 8 points left; run the same command again to resume"),
                        stopped.stopped_line()), stopped.stopped_line()
    assert [r for r in records if r.levelno < logging.CRITICAL] == []


def test_ctrl_c_on_a_local_dask_cluster_says_one_line(tmp_path):
    """Ctrl-C (SIGINT to the process group, workers of `--dask local` included): exit 1, the rows kept,
    one line saying how to resume, no traceback (each worker process printed its KeyboardInterrupt)."""
    path = write_sweep(tmp_path, SLOW.replace("burn: 2000", "burn: 20000"))
    code, stdout, stderr = interrupt_sweep(path, tmp_path / "c.csv", ["--dask", "local", "--workers", "2",
                                                                       "--no-figure"], rows=2, timeout=120)
    assert code == 1, stderr
    assert "Traceback" not in stderr and "KeyboardInterrupt" not in stderr, stderr
    assert stderr.strip().splitlines() == [f"error: cosim sweep: {stdout.splitlines()[2].strip()}"], (stdout, stderr)
    assert "interrupted: " in stdout and "run the same command again to resume" in stdout


def _spawned_worker(parent: int) -> bool:
    """Whether a child of ``parent`` is a process multiprocessing spawned (a worker, still starting)."""
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            ppid = int(stat.read_text().rsplit(")", 1)[1].split()[1])
            cmdline = (stat.parent / "cmdline").read_bytes()
        except (OSError, ValueError, IndexError):
            continue  # (a process gone meanwhile)
        if ppid == parent and b"spawn_main" in cmdline:
            return True
    return False


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="finds the worker processes in /proc")
def test_ctrl_c_while_a_local_dask_cluster_starts_says_one_line(tmp_path):
    """Ctrl-C to the process group the moment the first worker process of `--dask local` is spawned,
    the cluster and that worker still starting: exit 1 and one line, no traceback. The worker printed
    a KeyboardInterrupt traceback from its imports (it ignored the signal only once started), and the
    cluster cut off as it was made was left to Dask's exit hook, which printed another."""
    path = write_sweep(tmp_path, SLOW)
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[1])}
    proc = subprocess.Popen([sys.executable, "-m", "cosim.cli", "sweep", str(path), "-q", "-o", str(tmp_path / "c.csv"),
                             "--dask", "local", "--workers", "1"], cwd=tmp_path, env=env, start_new_session=True,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 60
    while proc.poll() is None and not _spawned_worker(proc.pid) and time.monotonic() < deadline:
        time.sleep(0.005)
    os.killpg(proc.pid, signal.SIGINT)
    stdout, stderr = proc.communicate(timeout=120)
    assert (proc.returncode, stderr) == (1, "error: cosim sweep: interrupted (Ctrl-C)\n"), stdout
    assert not (tmp_path / "c.csv").exists()


def test_a_local_dask_cluster_has_no_more_workers_than_points(tmp_path, capsys):
    """`--dask local --workers 2` for a sweep of one point starts one worker, as a process pool does (it
    started two, and said so); so does a local cluster given to run_sweep, for the points left to run."""
    path = write_sweep(tmp_path, "scene: ball.yaml\naxes:\n  components.ball.speed: [2]\n")
    assert main(["sweep", str(path), "-q", "--dask", "local", "--workers", "2", "-o", str(tmp_path / "one.csv"),
                 "--no-figure"]) == 0
    assert "on a local Dask cluster of 1 worker (1 threads)" in capsys.readouterr().out
    sweep = load_sweep(write_sweep(tmp_path, "scene: ball.yaml\naxes:\n  components.ball.speed: [2, 3]\n"))
    dask = DaskBackend("local", 3, processes=False)
    try:
        run_sweep(sweep, tmp_path / "two.csv", dask, progress=False, figure=False)
        assert (dask.workers, dask.slots) == (2, 2)
    finally:
        dask.close()
