"""`cosim run --live` keeps serving the finished run until Ctrl-C (or ``--live-linger`` seconds), says
so, and Ctrl-C then ends it with exit 0 and no traceback."""

from __future__ import annotations

import os
import queue
import re
import signal
import struct
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

pytest.importorskip("foxglove", reason="the foxglove-sdk package is not installed")

from tests.test_foxglove_live import WsClient, refused
from tests.viewer_toys import SKIP_SCENE

ROOT = Path(__file__).resolve().parents[1]
STILL_SERVING = re.compile(r"run finished; still serving on ws://127\.0\.0\.1:(\d+); (.*)")


def start_live(tmp_path: Path, *extra: str) -> tuple[subprocess.Popen, queue.Queue]:
    """``cosim run`` of the toy skip with --live on a free loopback port, unpaced unless ``extra``
    gives --live-speed; its stderr lines arrive on the returned queue (None at the end)."""
    scene = tmp_path / "skip.yaml"
    scene.write_text(SKIP_SCENE)
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    with open(tmp_path / "stdout.txt", "w") as out:
        proc = subprocess.Popen(
            [sys.executable, "-m", "cosim.cli", "run", str(scene), "--no-record", "-q", "--live", "127.0.0.1:0",
             *(extra if "--live-speed" in extra else ["--live-speed", "0", *extra])],
            cwd=tmp_path, env=env, stdout=out, stderr=subprocess.PIPE, text=True)
    lines: queue.Queue = queue.Queue()

    def pump() -> None:
        assert proc.stderr is not None
        with proc.stderr:
            for line in proc.stderr:
                lines.put(line)
        lines.put(None)

    threading.Thread(target=pump, daemon=True).start()
    return proc, lines


def stop(proc: subprocess.Popen) -> None:
    """Kill the command if a failed check left it running."""
    if proc.poll() is None:
        proc.kill()
        proc.wait()


def rest_of(lines: queue.Queue) -> list[str]:
    """The stderr lines still to come, up to the end."""
    rest = []
    while (line := lines.get(timeout=10)) is not None:
        rest.append(line)
    return rest


def wait_for(lines: queue.Queue, pattern: re.Pattern, within: float = 60.0) -> tuple[re.Match, list[str]]:
    """The first stderr line matching ``pattern`` and every line read so far."""
    seen: list[str] = []
    deadline = time.monotonic() + within
    while time.monotonic() < deadline:
        try:
            line = lines.get(timeout=max(0.01, deadline - time.monotonic()))
        except queue.Empty:
            break
        if line is None:
            break
        seen.append(line)
        match = pattern.search(line)
        if match:
            return match, seen
    raise AssertionError(f"no line matching {pattern.pattern!r} in {seen}")


def test_the_finished_run_is_still_served_until_ctrl_c(tmp_path):
    """After the run's summary the server stays up and says so in one line; a viewer connecting
    then is welcomed; SIGINT ends the command with exit 0, no traceback, and the port is freed."""
    proc, lines = start_live(tmp_path)
    try:
        match, _ = wait_for(lines, STILL_SERVING)
        port = int(match.group(1))
        assert match.group(2) == "Ctrl-C to stop"
        time.sleep(0.5)  # the run is over: what follows is the lingering server
        assert proc.poll() is None
        client = WsClient("127.0.0.1", port)
        assert client.status.endswith("101 Switching Protocols")
        client.close()
        proc.send_signal(signal.SIGINT)
        proc.wait(timeout=30)
    finally:
        stop(proc)
    rest = rest_of(lines)
    assert proc.returncode == 0, rest
    assert "Traceback" not in "".join(rest) and not any(line.startswith("error:") for line in rest)
    assert "toy_skip: ok" in (tmp_path / "stdout.txt").read_text()
    assert refused("127.0.0.1", port)


def test_live_linger_stops_serving_after_the_given_time(tmp_path):
    """`--live-linger 1` keeps serving after the run and then exits 0 by itself: a viewer connecting
    after the "still serving" line is welcomed and told where the run ended (the lingering server's
    clock broadcast: the run's last time, 0.6 s), so the line is not all there is; once the command
    has exited, the port is freed."""
    proc, lines = start_live(tmp_path, "--live-linger", "1")
    try:
        match, _ = wait_for(lines, STILL_SERVING)
        port = int(match.group(1))
        assert match.group(2) == "for 1 s (Ctrl-C to stop sooner)"
        client = WsClient("127.0.0.1", port)
        try:
            assert client.status.endswith("101 Switching Protocols")
            # text frames (serverInfo, advertise) first; the linger's clock broadcast is the binary
            # frame with op 2 and the log time in ns (a server gone would end the read with an error)
            while (frame := client.recv())[0] != 2 or frame[1][0] != 2:
                pass
            assert struct.unpack_from("<Q", frame[1], 1)[0] == 600_000_000
        finally:
            client.close()
        assert proc.wait(timeout=30) == 0
    finally:
        stop(proc)
    rest_of(lines)
    assert refused("127.0.0.1", port)


def test_live_linger_zero_ends_with_the_run(tmp_path):
    """`--live-linger 0` stops the server with the run, saying nothing of serving on."""
    proc, lines = start_live(tmp_path, "--live-linger", "0")
    try:
        assert proc.wait(timeout=60) == 0
    finally:
        stop(proc)
    err = rest_of(lines)
    assert not any("still serving" in line for line in err), err


def test_ctrl_c_during_the_run_stops_it_without_serving_on(tmp_path):
    """A Ctrl-C while the run is still going ends the run (exit 1, interrupted, as without --live)
    and the server with it: there is no finished run to keep serving."""
    proc, lines = start_live(tmp_path, "--live-speed", "0.01")  # paced slowly: 60 s for the 0.6 s run
    try:
        wait_for(lines, re.compile(r"live view: ws://"))
        time.sleep(0.5)
        proc.send_signal(signal.SIGINT)
        assert proc.wait(timeout=30) == 1
    finally:
        stop(proc)
    err = rest_of(lines)
    assert not any("still serving" in line for line in err) and "Traceback" not in "".join(err), err
