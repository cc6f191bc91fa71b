"""A run whose recording the machine has no room for (a full disk, a quota, a file-size limit) keeps
what fitted: the recording's private file is closed where it was cut (cosim.record.seal), a valid
recording ending with a `failed` status, and the command says so in one line, exit 1.

The Foxglove SDK's MCAP writer does not raise when a write fails: it logs every message it then
cannot write ("error logging message: McapError(Io(... PyErr { ... traceback: Some("Traceback
...") }))") and goes on. Before, that flood (thousands of lines) went to the writer process's error
output, a temporary file under the same limit (or on the same full disk), so the writer's own line
naming the system's error could not be written; the failure was then taken for a crash, the
recording "salvaged" into a second full copy that failed on the same limit, and the run left no
file at all, its one error line quoting the SDK's Python traceback. Under limits of 1100 to 3000 KB
the held skip (2 s) lost its whole recording that way.
"""

from __future__ import annotations

import errno
import os
import resource
import subprocess
import sys
from pathlib import Path

import pytest

from cosim.cli import main
from cosim.record import writer
from cosim.record.reader import Recording
from cosim.record.writer import SinkError, _reason
from cosim.runner import run_scene
from cosim.scenario import loads
from cosim.scheduler import Simulation
from tests.cli_toys import one_error_line
from tests.test_reliability_salvage import messages

ROOT = Path(__file__).resolve().parents[1]
HELD_SKIP = ROOT / "scenarios" / "held_skip.yaml"  # 30 MB in 2 s: any of the limits below cuts it
UNTIL = "2"
WAIT_S = 60  # longest wait for a run to end (never a measured time)
LIMITS_KB = (1100, 1500, 2000, 3000)  # each cut the recording and lost it whole
REFERENCE_UNTIL = "0.8"  # an uninterrupted run this long holds what any of those limits keeps
TOO_LARGE = os.strerror(errno.EFBIG)  # "File too large"
NO_SPACE = os.strerror(errno.ENOSPC)  # "No space left on device"
SDK_WORDS = ("Traceback", "PyErr", "McapError", "error logging message")  # what the SDK's log carries

# run in a process of its own: `cosim` with a file-size limit, where the writer process's error
# output (a temporary file) is either recorded (to WRITER_SAID) or cannot be written at all (as on a
# full disk holding the temporary folder too)
DRIVER = """
import os, resource, sys, tempfile
limit = int(sys.argv[1]) << 10
resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))
from cosim.record import writer
if sys.argv[2] == "unwritable":
    start = writer._Writer.__init__
    def with_unwritable_errors(self, *args, **kwargs):
        real = tempfile.TemporaryFile
        tempfile.TemporaryFile = lambda *a, **k: open(os.devnull, "rb")  # every write refused
        try:
            start(self, *args, **kwargs)
        finally:
            tempfile.TemporaryFile = real
    writer._Writer.__init__ = with_unwritable_errors
else:
    said = writer._Writer.new_errors
    def kept(self):
        text = said(self)
        with open(sys.argv[2], "a") as f:
            f.write(text)
        return text
    writer._Writer.new_errors = kept
from cosim.cli import main
sys.exit(main(sys.argv[3:]))
"""


def _env() -> dict[str, str]:
    return {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")]))}


def _limited(kb: int):
    def limit() -> None:
        resource.setrlimit(resource.RLIMIT_FSIZE, (kb << 10, kb << 10))
    return limit


@pytest.fixture(scope="module")
def reference(tmp_path_factory) -> dict[str, list[tuple[int, bytes]]]:
    """The messages of the held skip recorded with room for all of them, to REFERENCE_UNTIL."""
    out = tmp_path_factory.mktemp("room") / "room.mcap"
    assert main(["run", str(HELD_SKIP), "--until", REFERENCE_UNTIL, "-q", "-o", str(out)]) == 0
    return messages(out)


def _assert_kept_what_fitted(out: Path, line: str, reason: str, reference: dict, limit_kb: int | None = None) -> None:
    """``out`` is a valid recording, the run's first messages exactly as a run with room records
    them, ending with a `failed` status giving ``reason`` as the command's ``line`` does; nothing
    else is left beside it."""
    assert not any(word in line for word in SDK_WORDS), line
    assert f"error: {out}: writing the recording failed ({reason}); the recording was closed where it stopped, " \
           "at t = " in line, line
    assert sorted(p.name for p in out.parent.iterdir() if p.name.startswith(out.name)) == [out.name]  # no .part
    if limit_kb is not None:
        assert out.stat().st_size <= limit_kb << 10
    rec = Recording(out)
    assert rec.end_ns > 0 and f"at t = {rec.end_ns / 1e9:g} s" in line
    status = rec.status()
    assert status.status == "failed" and f"writing the recording failed ({reason})" in status.reason
    assert "the recording was closed where it stopped, at t = " in status.reason
    kept = messages(out)
    assert sum(len(pairs) for pairs in kept.values()) > 100
    for topic, pairs in kept.items():
        assert pairs == reference[topic][:len(pairs)], topic
    assert pairs[-1][0] < int(float(REFERENCE_UNTIL) * 1e9)  # the reference reaches past what was kept
    inspect = subprocess.run([sys.executable, "-m", "cosim.cli", "inspect", str(out)], env=_env(), text=True,
                             capture_output=True, timeout=WAIT_S)
    assert inspect.returncode == 0, inspect.stderr
    assert "status: failed" in inspect.stdout and "closed where it stopped" in inspect.stdout


@pytest.mark.parametrize("limit_kb", LIMITS_KB)
def test_a_run_under_a_file_size_limit_keeps_what_fitted_and_says_so_in_one_line(tmp_path, reference, limit_kb):
    """`cosim run` under `ulimit -f` (a file-size limit stands in for a full disk): exit 1, one line
    naming the file and "File too large" (no traceback, no SDK text), and the recording closed where
    it was cut. Before: "the recording writer failed (error logging message: McapError(... PyErr ...
    Traceback ...)), and salvaging what it had recorded failed too ...; no file was left"."""
    out = tmp_path / "out" / "fs.mcap"
    proc = subprocess.run([sys.executable, "-m", "cosim.cli", "run", str(HELD_SKIP), "--until", UNTIL, "-q",
                           "-o", str(out)], cwd=tmp_path, env=_env(), text=True, capture_output=True,
                          timeout=WAIT_S, preexec_fn=_limited(limit_kb))
    assert proc.returncode == 1, proc.stderr
    _assert_kept_what_fitted(out, one_error_line(proc.stderr), TOO_LARGE, reference, limit_kb)


def test_a_restart_under_a_file_size_limit_keeps_what_fitted(tmp_path, reference):
    """`cosim replay --from -o` records through the same path: the same one line and recording."""
    recording = tmp_path / "hs.mcap"
    assert main(["run", str(HELD_SKIP), "--until", "0.05", "-q", "-o", str(recording)]) == 0
    out = tmp_path / "out" / "r.mcap"
    proc = subprocess.run([sys.executable, "-m", "cosim.cli", "replay", str(recording), "-q", "--from", "0",
                           "--until", UNTIL, "-o", str(out)], cwd=tmp_path, env=_env(), text=True,
                          capture_output=True, timeout=WAIT_S, preexec_fn=_limited(1500))
    assert proc.returncode == 1, proc.stderr
    line = proc.stderr.strip().splitlines()[-1]  # after the restart's own notice
    assert "Traceback" not in proc.stderr
    _assert_kept_what_fitted(out, line, TOO_LARGE, reference, 1500)


def _drive(tmp_path: Path, limit_kb: int, errors: str, out: Path) -> subprocess.CompletedProcess:
    driver = tmp_path / "driver.py"
    driver.write_text(DRIVER)
    return subprocess.run([sys.executable, str(driver), str(limit_kb), errors, "run", str(HELD_SKIP), "--until",
                           UNTIL, "-q", "-o", str(out)], cwd=tmp_path, env=_env(), text=True, capture_output=True,
                          timeout=WAIT_S)


def test_the_writer_stops_at_the_first_refused_write_and_says_it_in_one_line(tmp_path, reference):
    """The writer notices the first write refused (the SDK's writer only logs it, then logs every
    later message too) and stops: its error output holds one line in the system's words, not a
    line with a Python traceback for each message it could not write (4683 of them here before)."""
    said = tmp_path / "writer_said.txt"
    out = tmp_path / "out" / "fs.mcap"
    proc = _drive(tmp_path, 1500, str(said), out)
    assert proc.returncode == 1, proc.stderr
    _assert_kept_what_fitted(out, one_error_line(proc.stderr), TOO_LARGE, reference, 1500)
    assert said.read_text().splitlines() == [f"cannot write the file: [Errno {errno.EFBIG}] {TOO_LARGE}"]


def test_a_writer_that_cannot_write_its_error_output_is_still_understood(tmp_path, reference):
    """On a full disk that holds the temporary folder too, the writer's error output (a temporary
    file) refuses its line as well: its exit status says which write the system refused, and the
    recording is still closed where it was cut (it was taken for a crash, salvaged into a second
    copy that failed in turn, and no file was left)."""
    out = tmp_path / "out" / "fs.mcap"
    proc = _drive(tmp_path, 1500, "unwritable", out)
    assert proc.returncode == 1, proc.stderr
    _assert_kept_what_fitted(out, one_error_line(proc.stderr), TOO_LARGE, reference, 1500)


def test_a_salvage_with_no_room_for_a_second_copy_closes_the_writers_file_where_it_stopped(tmp_path, monkeypatch):
    """The writer killed, and the disk too full for the rebuilt copy (ENOSPC after 50 kB): the
    writer's own file is closed in place where it stopped, as for a full disk, rather than the run
    leaving no file ("salvaging what it had recorded failed too ...; no file was left")."""
    from tests.test_reliability_salvage import KILL_TICK, ON_DISK, SCENE, KillWriter

    room = 50_000
    write = writer._File.write

    def full_disk(self, data):
        if self.tell() + len(data) > room:
            exc = OSError(errno.ENOSPC, NO_SPACE)
            if self.failure is None:
                self.failure = exc
            raise exc
        return write(self, data)

    monkeypatch.setattr(writer._File, "write", full_disk)  # in this process only: the salvage's copy
    out = tmp_path / "k.mcap"
    scene = loads(SCENE)
    with pytest.raises(SinkError) as failure:
        run_scene(scene, out, progress=False,
                  simulation=Simulation(scene, observers=[KillWriter(KILL_TICK, ON_DISK)]))
    line = str(failure.value)
    assert line.startswith(f"{out}: the recording writer was killed (SIGKILL), and there was no room to salvage "
                           f"the rest ({NO_SPACE}); the recording was closed where it stopped, at t = "), line
    assert not list(tmp_path.glob("k.mcap.*.part"))
    rec = Recording(out)
    assert rec.end_ns > 0 and f"at t = {rec.end_ns / 1e9:g} s" in line
    status = rec.status()
    assert status.status == "failed" and "closed where it stopped" in status.reason
    assert rec.channels["/src/out"].count > 0


def test_the_sdks_words_for_a_refused_write_are_the_systems_reason():
    """The SDK's log line for a write the system refused gives the system's words, and any other
    line of its loses the traceback it carries."""
    sdk = ("error logging message: McapError(Io(Custom { kind: Other, error: PyErr { type: <class 'OSError'>, "
           "value: OSError(27, 'File too large'), traceback: Some(\"Traceback (most recent call last):\\n  File "
           "\\\"/work/main/cosim/record/writer.py\\\", line 113, in write\\n\") } }))")
    assert _reason(sdk) == TOO_LARGE
    other = ("error logging message: McapError(Io(Custom { kind: Other, error: PyErr { type: <class 'ValueError'>, "
             "value: ValueError('odd'), traceback: Some(\"Traceback (most recent call last):\\n\") } }))")
    assert "Traceback" not in _reason(other) and _reason(other).startswith("error logging message: McapError(")
    # a number first in another error's arguments is no errno: ValueError(3, ...) is not "No such process"
    numbered = other.replace("ValueError('odd')", "ValueError(3, 'odd')")
    assert _reason(numbered).startswith("error logging message: McapError(")
