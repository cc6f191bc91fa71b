"""A sweep killed with SIGKILL leaves nothing running: its pool workers watch the process that started
them and leave when it is gone, and with them the pool's resource tracker."""

from __future__ import annotations

import contextlib
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

from tests.sweep_toys import write_sweep

ROOT = Path(__file__).resolve().parents[1]
WAIT_S = 60  # longest wait for processes to start or to leave (never a measured time)

SLOW = """
scene: ball.yaml
axes:
  components.ball.angle_deg: {linspace: [20, 70, 5]}
  components.ball.speed: [2, 3, 4, 5]
set: {components.ball.burn: 20000}
"""


def alive(pid: int) -> bool:
    """True while ``pid`` runs (a zombie waiting to be reaped has left)."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except (FileNotFoundError, ProcessLookupError):
        return False
    return fields[0] != "Z"


def children(pid: int) -> list[int]:
    try:
        return [int(c) for c in Path(f"/proc/{pid}/task/{pid}/children").read_text().split()]
    except FileNotFoundError:
        return []


def test_a_sweep_killed_with_sigkill_leaves_no_worker_or_tracker_running(tmp_path):
    path = write_sweep(tmp_path, SLOW)
    out = tmp_path / "killed.csv"
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    proc = subprocess.Popen([sys.executable, "-m", "cosim.cli", "sweep", str(path), "-o", str(out), "-q",
                             "--workers", "2"], cwd=tmp_path, env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    spawned: list[int] = []
    try:
        deadline = time.monotonic() + WAIT_S
        while time.monotonic() < deadline and proc.poll() is None:
            spawned = children(proc.pid)
            if len(spawned) >= 3 and out.exists() and len(out.read_text().splitlines()) >= 2:
                break  # two workers and the resource tracker, and the first rows written
            time.sleep(0.02)
        assert proc.poll() is None and len(spawned) >= 3, "the sweep should still be running, with its workers"
        proc.send_signal(signal.SIGKILL)  # the sweep alone: its workers are not signalled
        proc.wait(WAIT_S)
        deadline = time.monotonic() + WAIT_S
        while time.monotonic() < deadline and any(alive(p) for p in spawned):
            time.sleep(0.05)
        assert not [p for p in spawned if alive(p)], "workers or the resource tracker outlived the sweep"
    finally:
        proc.kill()
        for pid in spawned:
            with contextlib.suppress(ProcessLookupError, PermissionError):
                if alive(pid):
                    os.kill(pid, signal.SIGKILL)


def test_the_resource_tracker_holds_only_its_pipe_and_warns_nothing_at_exit(tmp_path):
    """The tracker a sweep starts (in a session of its own) keeps none of the starting process's
    other descriptors open (a pipe of the caller's, kept open, outlived the sweep), and nothing of
    it is said at the starting process's exit (a subprocess.Popen held for it warned "subprocess ...
    is still running" at the end of every test session)."""
    code = ("import json, os\n"
            "from multiprocessing import resource_tracker\n"
            "from cosim.sweep.backends import _start_resource_tracker\n"
            "_start_resource_tracker()\n"
            "pid = resource_tracker._resource_tracker._pid\n"
            "held = sorted(os.readlink(f'/proc/{pid}/fd/{fd}') for fd in os.listdir(f'/proc/{pid}/fd'))\n"
            "print(json.dumps([os.getsid(pid) != os.getsid(0), held]))\n")
    read, write = os.pipe()  # inheritable in the child: a descriptor of the caller's, as a shell's may be
    try:
        done = subprocess.run([sys.executable, "-X", "dev", "-c", code], capture_output=True, text=True,
                              env={**os.environ, "PYTHONPATH": str(ROOT)}, pass_fds=(write,), timeout=WAIT_S)
    finally:
        os.close(read)
        os.close(write)
    assert done.returncode == 0 and done.stderr == "", done.stderr
    own_session, held = json.loads(done.stdout)
    assert own_session
    assert held[:3] == [os.devnull] * 3 and len(held) == 4 and held[3].startswith("pipe:")  # its streams, its pipe
