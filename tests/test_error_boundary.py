"""A component's own code failing in any way ends the run as a failure of that component: one line
naming it and the time, exit 1, and a recording with everything up to it and a ``failed`` status.
Before, sys.exit() in a step ended `cosim run` with exit 0 (or its own code) and nothing said, a bare
BaseException printed a traceback, and a step returning None, or a state for a checkpoint that
failed or was not plain data, was an "internal error" whose recording had no status."""

from __future__ import annotations

import pytest

from cosim.cli import main
from cosim.record.reader import Recording
from tests.cli_toys import one_error_line

SCENE = """
dt: 0.001
until: 0.05
components:
  src: {{type: "tests.toys:Source"}}
  bad: {{type: "tests.toys:Faulty", fail_at: 0.02, mode: {mode}}}
record: {{checkpoint_every: 0.01}}
"""


@pytest.mark.parametrize(("mode", "reason"), [
    ("exit", "SystemExit: 3"),
    ("base", "BaseException: base"),
    ("none", "its step returned NoneType, not a mapping of output port to message"),
    ("state", "its state for a checkpoint failed: RuntimeError: no state"),
    ("state_exit", "its state for a checkpoint failed: SystemExit: 4"),
    ("state_object", "its state for a checkpoint: state value of type object is not plain data"),
])
def test_a_component_failing_any_way_is_named_with_exit_1_and_a_failed_status(mode, reason, tmp_path, capsys):
    scene = tmp_path / "bad.yaml"
    scene.write_text(SCENE.format(mode=mode))
    out = tmp_path / "bad.mcap"
    assert main(["run", str(scene), "-q", "-o", str(out)]) == 1
    # the step at 0.02 s fails, or the state the checkpoint at 0.02 s asks for
    at = "0.02"
    assert one_error_line(capsys.readouterr().err) == f"error: component 'bad' failed at t = {at} s: {reason}"
    recording = Recording(out)
    status = recording.status()
    assert status.status == "failed" and status.reason == f"component 'bad' failed at t = {at} s: {reason}"
    assert recording.channels["/src/out"].count >= 20  # everything up to the failure is kept
    assert not list(tmp_path.glob("bad.mcap*.part"))


@pytest.mark.parametrize(("mode", "reason"), [
    ("start_exit", "its inputs at t = 0: SystemExit: 3"),
    ("start_base", "its inputs at t = 0: BaseException: base"),
    ("start_none", "its outputs at t = 0 are NoneType, not a mapping of output port to message"),
])
def test_a_component_failing_any_way_at_the_start_is_named_with_exit_1_and_a_failed_status(mode, reason, tmp_path,
                                                                                           capsys):
    """The hooks at t = 0 as the step: sys.exit() in start_inputs ended the run silently with its own
    exit code and no status, a BaseException printed a traceback, and initial outputs of None were an
    internal error."""
    scene = tmp_path / "bad.yaml"
    scene.write_text(SCENE.format(mode=mode))
    out = tmp_path / "bad.mcap"
    assert main(["run", str(scene), "-q", "-o", str(out)]) == 1
    assert one_error_line(capsys.readouterr().err) == f"error: component 'bad' failed at t = 0 s: {reason}"
    status = Recording(out).status()
    assert status.status == "failed" and status.reason == f"component 'bad' failed at t = 0 s: {reason}"


def test_a_state_that_is_not_a_mapping_is_refused_when_it_is_taken_not_when_restarting(tmp_path, capsys,
                                                                                   monkeypatch):
    """A get_state returning None was recorded, and only the restart from it refused it."""
    from tests import toys

    monkeypatch.setattr(toys.Faulty, "get_state", lambda self: None)
    scene = tmp_path / "bad.yaml"
    scene.write_text(SCENE.format(mode="raise").replace("fail_at: 0.02", "fail_at: 1.0"))
    assert main(["run", str(scene), "-q", "-o", str(tmp_path / "bad.mcap")]) == 1
    assert one_error_line(capsys.readouterr().err) == (
        "error: component 'bad' failed at t = 0 s: its state for a checkpoint is NoneType, not a mapping of "
        "names to plain data")


def test_a_reader_that_leaves_does_not_turn_a_failure_into_success(tmp_path):
    """`cosim run bad.yaml | head -0`: the summary finds the pipe closed. The pipe's error ended the
    command where it printed, with exit 0; now what is printed goes nowhere and the run's own exit
    code (1, a component failed) stands, its recording whole with the failed status."""
    import os
    import subprocess
    import sys
    from pathlib import Path

    scene = tmp_path / "bad.yaml"
    scene.write_text(SCENE.format(mode="raise"))
    out = tmp_path / "bad.mcap"
    read, write = os.pipe()
    os.close(read)  # the reader is gone before anything is printed
    try:
        done = subprocess.run([sys.executable, "-m", "cosim.cli", "run", str(scene), "-o", str(out)],
                              stdout=write, stderr=subprocess.PIPE, text=True,
                              cwd=Path(__file__).resolve().parents[1], timeout=300)
    finally:
        os.close(write)
    assert done.returncode == 1, done.stderr
    assert done.stderr.strip() == "error: component 'bad' failed at t = 0.02 s: RuntimeError: boom"
    assert Recording(out).status().status == "failed"


def test_a_reader_of_the_errors_that_leaves_keeps_the_exit_code_of_bad_input(tmp_path):
    """`cosim validate bad.yaml 2>&1 | head -1`: the error lines find stderr's pipe closed. The pipe's
    error turned exit 2 (bad input) into 1 (the run failed); now what is said goes nowhere and 2
    stands."""
    import os
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    read, write = os.pipe()
    os.close(read)  # the reader is gone before anything is said
    try:
        done = subprocess.run([sys.executable, "-m", "cosim.cli", "validate", "scenarios/ping_pong.yaml", "--set",
                               "connections=null"], stdout=subprocess.DEVNULL, stderr=write, cwd=root, timeout=300)
    finally:
        os.close(write)
    assert done.returncode == 2


def test_a_full_disk_under_stdout_is_said_of_stdout_not_of_the_recording(tmp_path):
    """`cosim run ... > /dev/full`: "cosim run: its output: cannot be written" read as the recording,
    which is whole; the line now names standard output."""
    import subprocess
    import sys
    from pathlib import Path

    scene = tmp_path / "ok.yaml"
    scene.write_text(SCENE.format(mode="raise").replace("fail_at: 0.02", "fail_at: 1.0"))
    out = tmp_path / "ok.mcap"
    with open("/dev/full", "w") as full:
        done = subprocess.run([sys.executable, "-m", "cosim.cli", "run", str(scene), "-o", str(out)],
                              stdout=full, stderr=subprocess.PIPE, text=True,
                              cwd=Path(__file__).resolve().parents[1], timeout=300)
    assert done.returncode == 1
    assert done.stderr.strip() == "error: standard output: cannot be written (No space left on device)"
    assert Recording(out).status().status == "ok"


def test_a_failures_reason_loses_a_terminals_colours_and_is_cut_to_a_readable_length():
    """A compiled kernel's typing error (numba's) held several kilobytes coloured for a terminal, and all
    of it became the run's error line, its recorded status and its summary. The reason keeps no colour
    codes and at most REASON_MOST characters, saying how many more there were."""
    from cosim.errors import REASON_MOST, SimulationError

    coloured = "\x1b[1m\x1b[1mFailed in nopython mode pipeline\x1b[0m: " + "x" * 5000
    error = SimulationError("coupler", 3_500_000, f"TypingError: {coloured}")
    assert "\x1b" not in str(error)
    plain = "TypingError: Failed in nopython mode pipeline: " + "x" * 5000
    kept, said = error.reason.split("... (")
    assert len(error.reason) <= REASON_MOST and plain.startswith(kept)
    assert said == f"{len(plain) - len(kept)} more characters)"
    assert SimulationError("c", 0, "short \x1b[31mred\x1b[0m").reason == "short red"


@pytest.mark.parametrize(("closed", "args", "code", "said"), [
    # stdout closed (`>&-`): said as a full disk under it is, exit 1; the scene is fine
    ("stdout", ["validate", "scenarios/ping_pong.yaml"], 1, "error: standard output: cannot be written (Bad file "
                                                           "descriptor)"),
    # stderr closed (`2>&-`) or read-only: nothing can be said, and a bad scene is still exit 2
    ("stderr", ["validate", "nonexist.yaml"], 2, ""),
    ("stderr-read-only", ["validate", "nonexist.yaml"], 2, ""),
])
def test_a_standard_stream_the_process_was_started_without(tmp_path, closed, args, code, said):
    """Started with stdout or stderr closed (Python makes it None) or open read-only (fd 2 another
    file's, as a shell may leave it), a command ended in an internal error, and a bad scene's exit 2
    became 1."""
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    code_text = ("import sys\nfrom cosim.cli import main\n"
                 + ("sys.stdout = None\n" if closed == "stdout" else "")
                 + ("sys.stderr = None\n" if closed == "stderr" else "")
                 + f"sys.exit(main({args!r}))\n")
    with open(tmp_path / "ro.txt", "w") as f:
        f.write("")
    stderr: object = subprocess.PIPE
    if closed == "stderr-read-only":
        stderr = open(tmp_path / "ro.txt")  # (a descriptor writes fail on: EBADF)
    try:
        done = subprocess.run([sys.executable, "-c", code_text], stdout=subprocess.DEVNULL, stderr=stderr,
                              text=True, cwd=root, timeout=300)
    finally:
        if closed == "stderr-read-only":
            stderr.close()  # type: ignore[union-attr]
    assert done.returncode == code
    if closed == "stdout":
        assert done.stderr.strip() == said


def test_a_progress_bar_is_made_only_for_a_terminal_and_before_the_run(monkeypatch):
    """The bar's tqdm (tens of ms with what it loads) was imported as the run began, and timed as the
    run: a 50 ms run said a real-time factor of 3 without -q and 170 with it, piped, where no bar is
    drawn. Not a terminal: no tqdm at all; a terminal: taken when the bar is made, before the run."""
    import io

    from cosim.progress import ProgressBar

    monkeypatch.setattr("sys.stderr", io.StringIO())
    assert ProgressBar(10**9)._tqdm is None

    class Terminal(io.StringIO):
        def isatty(self) -> bool:
            return True

    monkeypatch.setattr("sys.stderr", Terminal())
    assert ProgressBar(10**9)._tqdm is not None
