"""A toy with metrics for sweep tests: a ball thrown over a floor, bouncing until it rests.

It knows nothing about stones or water; it gives a sweep something that depends on its parameters
(bounces and distance over speed and angle), can be made slow (``burn``), fail (``fail_at_bounce``),
kill its worker process (``die``) or find the disk full (``disk_full_while``).
"""

from __future__ import annotations

import errno
import math
import os
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass

from cosim.component import Component, Port
from cosim.params import param
from tests.toys import Scalar


class Ball(Component):
    """A point ball thrown at ``speed`` and ``angle_deg`` above a floor at z = 0, bouncing with
    restitution ``restitution`` until a bounce leaves slower than ``rest_speed`` (then it stops)."""

    @dataclass(frozen=True)
    class Params:
        speed: float = param(5.0, unit="m/s", ge=0)
        angle_deg: float = param(45.0, unit="deg")
        restitution: float = param(0.6, ge=0, le=1)
        gravity: float = param(9.81, unit="m/s^2", gt=0)
        rest_speed: float = param(0.5, unit="m/s", gt=0)
        burn: int = param(0, ge=0, doc="extra arithmetic per step, to make a run cost time")
        fail_at_bounce: int = param(0, ge=0, doc="raise at this bounce (0: never)")
        die: bool = param(False, doc="end the whole process at the first step")
        disk_full_while: str = param("", doc="while a file of this name exists, the first step's write "
                                         "is refused as by a full disk (OSError ENOSPC)")

    outputs = {"height": Port(Scalar)}

    def setup(self) -> None:
        p = self.params
        a = math.radians(p.angle_deg)
        self.x, self.z = 0.0, 0.0
        self.vx, self.vz = p.speed * math.cos(a), p.speed * math.sin(a)
        self.bounces = 0
        self.first_bounce = math.nan
        self.resting = False

    def _step_impl(self, t, dt, inputs):
        p = self.params
        if p.die:
            os._exit(70)
        if p.disk_full_while and os.path.exists(p.disk_full_while):
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), "ball.dat")
        acc = 0.0
        for i in range(p.burn):
            acc += i * 1e-9
        self.vz -= p.gravity * dt
        self.x += self.vx * dt
        self.z += self.vz * dt + acc * 0.0
        if self.z < 0.0 and self.vz < 0.0:
            self.z = 0.0
            self.vz = -p.restitution * self.vz
            self.bounces += 1
            if self.bounces == 1:
                self.first_bounce = t + dt
            if self.bounces == p.fail_at_bounce:
                raise RuntimeError(f"bounce {self.bounces} is forbidden")
            if self.vz < p.rest_speed:
                self.resting = True
                self.request_stop(f"at rest after {self.bounces} bounces")
        return {"height": Scalar(self.z)}

    def metrics(self):
        return {"bounces": self.bounces, "distance": self.x, "outcome": "rest" if self.resting else "flying",
                "first_bounce_time": self.first_bounce}


BALL_SCENE = """
name: ball
dt: 0.001
until: 3.0
components:
  ball: {type: "tests.sweep_toys:Ball"}
"""


@contextmanager
def running_pool(workers: int) -> Iterator:
    """A process pool of ``workers`` worker processes, started, closed on leaving (a module's tests share
    one: spawning costs about a second)."""
    from cosim.sweep.backends import ProcessBackend

    backend = ProcessBackend(workers)
    backend.start()
    try:
        yield backend
    finally:
        backend.close()


def write_sweep(folder, body: str, scene: str = BALL_SCENE, name: str = "sweep.yaml"):
    """Write the ball scene and a sweep file (``body``, whose ``scene: ball.yaml`` names it) into
    ``folder``; returns the sweep file's path."""
    (folder / "ball.yaml").write_text(scene)
    path = folder / name
    path.write_text(body)
    return path


def interrupt_sweep(sweep, out, options: list[str], rows: int, timeout: float) -> tuple[int, str, str]:
    """Run ``cosim sweep SWEEP -q -o OUT OPTIONS`` in a process group of its own, Ctrl-C the group
    once ``out`` holds ``rows`` lines (or ``timeout`` [s] has passed), and return its exit code,
    standard output and standard error."""
    import signal
    import subprocess
    import sys
    import time
    from pathlib import Path

    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[1])}
    proc = subprocess.Popen([sys.executable, "-m", "cosim.cli", "sweep", str(sweep), "-q", "-o", str(out), *options],
                            cwd=Path(sweep).parent, env=env, start_new_session=True, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline and proc.poll() is None:
        if out.exists() and len(out.read_text().splitlines()) >= rows:
            break
        time.sleep(0.02)
    os.killpg(proc.pid, signal.SIGINT)
    stdout, stderr = proc.communicate(timeout=timeout)
    return proc.returncode, stdout, stderr


def read_table(path, drop=("wall_s",)) -> list[list[str]]:
    """A results table as rows of text, without the columns that may differ between equal runs."""
    import csv

    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    keep = [i for i, name in enumerate(rows[0]) if name not in drop]
    return [[row[i] for i in keep] for row in rows]


def stubborn_task(seconds: float) -> int:
    """A pool task that ignores SIGTERM and then sleeps (a worker that will not leave when asked)."""
    import signal
    import time

    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    time.sleep(seconds)
    return os.getpid()


def dying_task(delay: float) -> None:
    """A pool task that ends its worker process after ``delay`` seconds (breaks the pool)."""
    import time

    time.sleep(delay)
    os._exit(70)
