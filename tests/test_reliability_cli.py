"""One error boundary for every command: whatever escapes a command (built in or added through the
``cosim.commands`` entry points) is one line on stderr and exit 1 or 2, never a traceback; --debug
shows it. Ctrl-C at start-up, a bad --live port and a missing optional extra are plain lines too."""

from __future__ import annotations

import importlib.metadata
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

import cosim.cli
from cosim.cli import main
from tests.cli_toys import DEMO_SCENE, one_error_line

ROOT = Path(__file__).resolve().parents[1]

SCENE = DEMO_SCENE


def run_cosim(*args: str, cwd: Path, pythonpath: tuple[str, ...] = ()) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([*pythonpath, str(ROOT)])}
    return subprocess.run([sys.executable, "-m", "cosim.cli", *args], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=120)


def test_an_unexpected_exception_is_one_line_and_debug_shows_the_traceback(scene, tmp_path, capsys, monkeypatch):
    """A bug inside a command: exit 1, one line naming the exception and where it happened; with
    --debug (before or after the command) the traceback too."""
    out = tmp_path / "r.mcap"
    assert main(["run", str(scene), "-o", str(out), "-q"]) == 0
    capsys.readouterr()

    def broken(rec):
        return 1 / 0

    monkeypatch.setattr("cosim.record.describe.describe_recording", broken)
    assert main(["inspect", str(out)]) == 1
    line = one_error_line(capsys.readouterr().err)
    assert "cosim inspect: internal error ZeroDivisionError: division by zero" in line
    assert "test_reliability_cli.py" in line and "in broken" in line
    for argv in (["--debug", "inspect", str(out)], ["inspect", str(out), "--debug"]):
        assert main(argv) == 1
        err = capsys.readouterr().err
        assert "Traceback (most recent call last)" in err and err.strip().endswith("--debug shows the traceback)")


def test_a_plugin_command_failing_is_one_line(tmp_path, capsys, monkeypatch):
    """A command registered through an entry point (sweep) raising anything: one line, exit 1."""
    sweep = tmp_path / "s.yaml"
    sweep.write_text("scene: demo.yaml\n")

    def explode(*args, **kwargs):
        raise RuntimeError("the plan fell over")

    monkeypatch.setattr("cosim.sweep.plan.load_sweep", explode)
    assert main(["sweep", str(sweep)]) == 1
    assert "cosim sweep: internal error RuntimeError: the plan fell over" in one_error_line(capsys.readouterr().err)


def test_a_plugin_that_cannot_load_leaves_the_other_commands_working(scene, tmp_path, capsys, monkeypatch):
    """An entry point that fails to import does not break `cosim`: other commands run, and the
    broken one says why in one line."""
    real = importlib.metadata.entry_points

    def with_a_broken_one(**kw):
        found = list(real(**kw))
        if kw.get("group") == cosim.cli.COMMANDS_GROUP:
            found.append(importlib.metadata.EntryPoint("wobble", "no_such_module_here:register", kw["group"]))
        return found

    monkeypatch.setattr(importlib.metadata, "entry_points", with_a_broken_one)
    assert main(["validate", str(scene)]) == 0
    capsys.readouterr()
    assert main(["wobble", "x", "--y"]) == 1
    line = one_error_line(capsys.readouterr().err)
    assert "cosim wobble is unavailable: cannot load no_such_module_here:register (ModuleNotFoundError" in line


def _caught(pid: int) -> int:
    """The mask of the signals process ``pid`` has a handler for (its /proc status, SigCgt: bit n - 1
    for signal n), 0 once it has ended."""
    try:
        status = Path(f"/proc/{pid}/status").read_text()
    except (FileNotFoundError, ProcessLookupError):
        return 0
    return next((int(line.split()[1], 16) for line in status.splitlines() if line.startswith("SigCgt:")), 0)


def _wait_command_started(proc: subprocess.Popen, deadline: float) -> None:
    """Until `cosim run` ``proc`` has started its recording's writer, a process of its own: the first
    thing the command does (``_prestart_writer``), after ``main`` has put its signal handlers in and
    well before the run's own ones; fails if it ends first or the deadline passes."""
    children = Path(f"/proc/{proc.pid}/task/{proc.pid}/children")
    while time.monotonic() < deadline and proc.poll() is None:
        if children.read_text().split():
            return
        time.sleep(0.005)
    proc.kill()
    raise AssertionError(f"the command never started its writer: {proc.communicate()[1]}")


@pytest.mark.skipif(not Path(f"/proc/{os.getpid()}/task/{os.getpid()}/children").exists(),
                    reason="watches the command through /proc")
@pytest.mark.parametrize(("signum", "delay"), [*((signal.SIGINT, d) for d in (0, 0.1, 0.35, 0.5)),
                                               *((signal.SIGTERM, d) for d in (0, 0.35)),
                                               *((signal.SIGHUP, d) for d in (0, 0.35))])
def test_ctrl_c_or_sigterm_in_the_first_half_second_is_one_line(tmp_path, signum, delay):
    """SIGINT, SIGTERM or SIGHUP while `cosim run` starts up (importing, building, starting the writer) or
    runs: exit 1 and one line naming the interruption, never a KeyboardInterrupt traceback (a SIGTERM
    before the run's own handler killed the process silently, exit 143). ``delay`` counts from when
    the command has begun (it has started its writer process, seen in /proc), not from a guess at
    the interpreter's start-up time, which a loaded machine outran: a signal while Python is still
    starting is Python's to report, before any of cosim runs. The signal is caught from then on (its
    bit in the command's /proc SigCgt), not only once the run's own handler is in."""
    long = tmp_path / "long.yaml"
    long.write_text(SCENE.replace("until: 0.05", "until: 100000"))
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    proc = subprocess.Popen([sys.executable, "-m", "cosim.cli", "run", str(long), "-o", str(tmp_path / "l.mcap"),
                             "-q"], cwd=tmp_path, env=env, text=True, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    _wait_command_started(proc, time.monotonic() + 60)
    assert _caught(proc.pid) & 1 << (signum - 1), f"{signal.Signals(signum).name} is not caught at start-up"
    time.sleep(delay)  # spreads where the signal lands in the start-up; the outcome is the same anywhere
    proc.send_signal(signum)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 1, err
    line = one_error_line(err)
    assert "interrupted" in line and (signum == signal.SIGINT or signal.Signals(signum).name in line)


def _wait_running(folder: Path, name: str, deadline: float) -> None:
    """Until the recording ``name`` in ``folder`` has taken batches of the run's messages (its private
    file past 64 KiB): the run's loop, and its own signal handlers, have begun (a signal before them
    is the command's, said as "interrupted (SIGHUP)")."""
    while time.monotonic() < deadline:
        parts = list(folder.glob(f"{name}.*.part"))
        if parts and parts[0].exists() and parts[0].stat().st_size > 64 * 1024:
            return
        time.sleep(0.02)
    raise AssertionError(f"{name}: the run did not start recording within its time")


def test_a_run_closing_its_terminal_ends_interrupted_with_its_recording(tmp_path):
    """SIGHUP (the terminal closed) mid-run ends it as SIGTERM does: one line, exit 1, the recording
    closed with the `interrupted` status (it died silently, exit 129, the recording without one);
    under nohup (SIGHUP ignored from the start) the run goes on to its end."""
    from cosim.record.reader import Recording

    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    long = tmp_path / "long.yaml"
    long.write_text(SCENE.replace("until: 0.05", "until: 100000"))
    out = tmp_path / "hup.mcap"
    proc = subprocess.Popen([sys.executable, "-m", "cosim.cli", "run", str(long), "-o", str(out), "-q"],
                            cwd=tmp_path, env=env, text=True, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    deadline = time.monotonic() + 60
    _wait_running(tmp_path, "hup.mcap", deadline)
    proc.send_signal(signal.SIGHUP)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 1, err
    assert "interrupted by SIGHUP" in one_error_line(err)
    status = Recording(out).status()
    assert status is not None and status.status == "interrupted"
    # started ignoring it, as nohup starts a command: the SIGHUP is not taken, the run goes on
    out = tmp_path / "nohup.mcap"
    proc = subprocess.Popen([sys.executable, "-m", "cosim.cli", "run", str(long), "-o", str(out), "-q"],
                            cwd=tmp_path, env=env, text=True, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            preexec_fn=lambda: signal.signal(signal.SIGHUP, signal.SIG_IGN))
    _wait_running(tmp_path, "nohup.mcap", deadline)
    proc.send_signal(signal.SIGHUP)
    time.sleep(0.5)
    assert proc.poll() is None  # still running
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 1 and "interrupted by SIGTERM" in one_error_line(err), err


def test_a_live_port_out_of_range_is_bad_input(scene, capsys):
    """--live 99999 exits 2 before anything runs."""
    with pytest.raises(SystemExit) as exit_:
        main(["run", str(scene), "--live", "99999", "--no-record", "-q"])
    assert exit_.value.code == 2
    assert "the port must be in 0..65535, got 99999" in one_error_line(capsys.readouterr().err)


def _without(folder: Path, *packages: str) -> str:
    """A folder whose packages stand in for ``packages`` and fail to import, as if not installed."""
    for name in packages:
        (folder / name).mkdir(parents=True)
        (folder / name / "__init__.py").write_text(
            f"raise ModuleNotFoundError(\"No module named '{name}'\", name={name!r})\n")
    return str(folder)


def test_plot_render_and_live_without_the_viz_extra_say_what_to_install(scene, tmp_path):
    """Without matplotlib or the Foxglove schemas: one line naming the extra, exit 2."""
    out = tmp_path / "r.mcap"
    assert main(["run", str(scene), "-o", str(out), "-q"]) == 0
    stubs = _without(tmp_path / "stubs", "matplotlib", "foxglove_schemas_protobuf")
    for args in (["plot", str(out)], ["render", str(out), "-o", str(tmp_path / "x.png")],
                 ["run", str(scene), "--live", "0", "--no-record", "-q"]):
        proc = run_cosim(*args, cwd=tmp_path, pythonpath=(stubs,))
        assert proc.returncode == 2, proc.stderr
        assert "pip install 'cosim[viz]'" in one_error_line(proc.stderr)


@pytest.mark.parametrize("argv", [["--until", "1e308"], ["--until", "inf"], ["--until", "nan"],
                                  ["--live-speed", "nan", "--live", "0"], ["--record-every", "0"],
                                  ["--live-speed", "1e-300", "--live", "0"]])
def test_command_line_numbers_out_of_range_are_bad_input(scene, capsys, argv):
    """Times beyond what a recording holds, non-finite numbers and a zero rate: exit 2, one line."""
    with pytest.raises(SystemExit) as exit_:
        main(["run", str(scene), "--no-record", "-q", *argv])
    assert exit_.value.code == 2
    one_error_line(capsys.readouterr().err)


def test_record_options_work_on_a_scene_without_a_record_block(tmp_path, capsys):
    """--record and --record-every set record.* on a scene that has no record block of its own."""
    scene = tmp_path / "bare.yaml"
    scene.write_text(SCENE)
    out = tmp_path / "bare.mcap"
    assert main(["run", str(scene), "-o", str(out), "-q", "--record", "/g/*", "--record-every", "5"]) == 0
    from cosim.record.reader import Recording

    channels = Recording(out).channels
    assert channels["/g/out"].count == 10 and "/src/out" not in channels  # 50 steps, every 5th


def test_an_import_cut_short_by_ctrl_c_is_told_as_the_interruption(monkeypatch, capsys):
    """A Ctrl-C that lands inside an import can come out as an ImportError (numpy turns an
    interrupted load of its core into one): after a Ctrl-C, the error is still 'interrupted', exit 1."""
    import cosim.cli as cli

    def interrupted_import(args):
        try:
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(1.0)
        except KeyboardInterrupt:
            raise ImportError("IMPORTANT: PLEASE READ THIS FOR ADVICE ON HOW TO SOLVE THIS ISSUE!") from None
        raise AssertionError("the signal did not arrive")

    monkeypatch.setattr(cli, "cmd_validate", interrupted_import)
    assert cli.main(["validate", "scene.yaml"]) == 1
    assert "interrupted" in one_error_line(capsys.readouterr().err)
    # and the next command, with no Ctrl-C, reports its own error again
    monkeypatch.setattr(cli, "cmd_validate", lambda args: (_ for _ in ()).throw(ImportError("plain")))
    assert cli.main(["validate", "scene.yaml"]) == 1
    assert "internal error ImportError: plain" in one_error_line(capsys.readouterr().err)


@pytest.mark.parametrize("output", ["", "  ", "new_folder/"])
def test_an_empty_output_or_one_naming_a_folder_is_bad_input(scene, tmp_path, capsys, monkeypatch, output):
    """-o '' would quietly mean the default file, and -o DIR/ a file named DIR: exit 2, one line,
    nothing written."""
    monkeypatch.chdir(tmp_path)
    with pytest.raises(SystemExit) as exit_:
        main(["run", str(scene), "-o", output, "-q"])
    assert exit_.value.code == 2
    line = one_error_line(capsys.readouterr().err)
    assert ("empty" in line) if not output.strip() else ("names a folder" in line)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["demo.yaml"]


def test_a_live_host_that_is_no_host_name_is_bad_input(scene, capsys):
    """--live 'no such host:80': exit 2 before anything runs (not a failure to start the server)."""
    with pytest.raises(SystemExit) as exit_:
        main(["run", str(scene), "--live", "no such host:80", "--no-record", "-q"])
    assert exit_.value.code == 2
    assert "'no such host' is not a host name or address" in one_error_line(capsys.readouterr().err)


@pytest.mark.parametrize("address", ["::1", "::1:8765", "fe80::1"])
def test_a_live_ipv6_address_without_brackets_is_bad_input_saying_how_to_write_it(scene, capsys, address):
    """--live ::1 read as host ':' and port 1, and the server then failed to resolve ':'."""
    with pytest.raises(SystemExit) as exit_:
        main(["run", str(scene), "--live", address, "--no-record", "-q"])
    assert exit_.value.code == 2
    assert "[ADDRESS]:PORT (e.g. [::1]:8765)" in one_error_line(capsys.readouterr().err)


@pytest.mark.parametrize("pattern", ["/gg/*", "nothing", "["])
def test_a_record_pattern_that_matches_no_channel_is_bad_input(scene, tmp_path, capsys, pattern):
    """A misspelt --record pattern would record none of the channels it meant: exit 2, naming it
    and the scene's channels, and no file."""
    out = tmp_path / "r.mcap"
    assert main(["run", str(scene), "-o", str(out), "-q", "--record", f"/g/*,{pattern}"]) == 2
    line = one_error_line(capsys.readouterr().err)
    assert f"record.channels: {pattern!r} matches no channel of this scene" in line and "/g/out" in line
    assert not out.exists()


def test_replay_until_before_from_is_bad_input(tmp_path, capsys):
    """replay --from 0.02 --until 0.01: exit 2 before anything is read or written."""
    from tests.cli_toys import CHECKPOINTED_SCENE

    scene = tmp_path / "c.yaml"
    scene.write_text(CHECKPOINTED_SCENE)
    rec = tmp_path / "c.mcap"
    assert main(["run", str(scene), "-o", str(rec), "-q"]) == 0
    capsys.readouterr()
    restarted = tmp_path / "again.mcap"
    assert main(["replay", str(rec), "--from", "0.02", "--until", "0.01", "-o", str(restarted), "-q"]) == 2
    assert "--until 0.01 s must be after --from 0.02 s" in one_error_line(capsys.readouterr().err)
    assert not restarted.exists()


def test_a_ctrl_c_that_python_drops_during_start_up_still_interrupts_the_run(scene, tmp_path, capsys, monkeypatch):
    """A Ctrl-C whose KeyboardInterrupt lands in a callback the interpreter runs itself (as
    importlib's module-lock callbacks do while modules load) is dropped by Python with an
    'Exception ignored' traceback, and the run went on to its end with exit 0. Now the interrupt is
    remembered: no traceback, and the run stops before its first step, exit 1."""
    import weakref

    import cosim.scenario

    real_load = cosim.scenario.load

    def load_then_ctrl_c_in_a_callback(*args, **kwargs):
        class Thing:
            pass

        def callback(ref):
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(1.0)  # the handler raises in here; the interpreter drops it

        thing = Thing()
        ref = weakref.ref(thing, callback)
        del thing  # the callback runs now
        assert ref() is None
        return real_load(*args, **kwargs)

    monkeypatch.setattr(cosim.scenario, "load", load_then_ctrl_c_in_a_callback)
    out = tmp_path / "r.mcap"
    assert main(["run", str(scene), "-o", str(out), "-q"]) == 1
    captured = capsys.readouterr()
    assert "interrupted" in one_error_line(captured.err)
    assert "reached" not in captured.out  # the run did not go on to its end


def test_an_example_component_without_its_input_is_refused_before_the_run(tmp_path, capsys):
    """Ping with nothing feeding its input: `validate` and `run` name the unconnected input, exit 2
    (it failed at t = 0 with an AttributeError, exit 1)."""
    scene = tmp_path / "unconnected.yaml"
    scene.write_text('name: x\ndt: 0.001\nuntil: 0.05\ncomponents:\n  ping: {type: "cosim.examples:Ping"}\n'
                     '  pong: {type: "cosim.examples:Pong"}\nconnections:\n  - ping.out -> pong.inp\n')
    for argv in (["validate", str(scene)], ["run", str(scene), "-o", str(tmp_path / "r.mcap"), "-q"]):
        assert main(argv) == 2
        assert "components.ping: required input 'inp' (Number) is not connected" in one_error_line(
            capsys.readouterr().err)
    assert not (tmp_path / "r.mcap").exists()


@pytest.mark.parametrize(("argv", "said"), [
    (["plot", "--dpi", "100000"], "argument --dpi: must be <= 1200, got 100000"),
    (["render", "--width", "100000"], "argument --width: must be <= 7680 px, got 100000"),
    (["render", "--fps", "1e6"], "argument --fps: must be <= 240, got 1e6"),
    (["render", "--speed", "1e-9"], "frames (0.1 s of the run at --speed 1e-09 and --fps 30), more than 100000"),
])
def test_pictures_too_large_to_make_are_bad_input(tmp_path, capsys, argv, said):
    """A resolution, width, frame rate or slow motion that would not fit in memory: exit 2 and one
    line naming the option and its bound (before: 'out of memory', exit 1, after minutes of work)."""
    from tests.viewer_toys import record_skip

    recording = tmp_path / "skip.mcap"
    record_skip(recording, ["until=0.1", "record.visual_rate=0"])
    out = tmp_path / ("figs" if argv[0] == "plot" else "skip.gif")
    command = [argv[0], str(recording), "-o", str(out), *argv[1:]] + (["-q"] if argv[0] == "render" else [])
    try:
        code = main(command)
    except SystemExit as exit_:
        code = exit_.code
    assert code == 2
    assert said in one_error_line(capsys.readouterr().err)
    assert not out.exists()


@pytest.mark.parametrize(("argv", "said"), [
    (["--record", ",,"], "error: cosim: --record ',,': names no channel"),
    (["--no-record", "-o", "f.mcap"], "error: cosim run: --no-record and -o f.mcap: a run either records"),
    # (a thousandth of a nanosecond is off the clock's grid, no longer taken for 0)
    (["--until", "1e-12"], "error: cosim run: argument --until: must be a whole number of nanoseconds, got 1e-12 s"),
    (["--until", "0"], "error: cosim run: argument --until: must be later than 0 s (a run of no time), got 0"),
    # one rule below 0 too (-1 was told "must be >= 0 s", a rule 0 then met and was refused by)
    (["--until", "-1"], "error: cosim run: argument --until: must be later than 0 s (a run of no time), got -1"),
    # a number as the scene's YAML and --set read one (Python's 1_0 ran for 10 s, where until=1_0 is refused)
    (["--until", "1_0"], "error: cosim run: argument --until: expected seconds, got '1_0'"),
    (["--record-every", "1_0"], "error: cosim run: argument --record-every: expected a whole number, got '1_0'"),
])
def test_run_options_that_would_do_nothing_are_bad_input(scene, tmp_path, capsys, monkeypatch, argv, said):
    """Options that silently did nothing (recorded no channel, ignored -o, ran 0 s): exit 2, one line."""
    monkeypatch.chdir(tmp_path)
    try:
        code = main(["run", str(scene), "-q", *argv])
    except SystemExit as exit_:  # argparse's
        code = exit_.code
    assert code == 2
    assert one_error_line(capsys.readouterr().err).startswith(said)
    assert not list(tmp_path.glob("**/*.mcap"))


def test_render_into_a_folder_says_it_is_a_folder(tmp_path, capsys):
    """render -o naming an existing folder: exit 2 and 'is a folder' (it said "unknown format '(none)'")."""
    from tests.viewer_toys import record_skip

    recording = tmp_path / "skip.mcap"
    record_skip(recording, ["until=0.05", "record.visual_rate=0"])
    (tmp_path / "outs").mkdir()
    assert main(["render", str(recording), "-o", str(tmp_path / "outs"), "-q"]) == 2
    assert one_error_line(capsys.readouterr().err).startswith(f"error: {tmp_path / 'outs'}: is a folder; render "
                                                              "writes one file")


def test_plot_and_render_never_write_over_the_recording_they_read(tmp_path, capsys):
    """A recording named like the figure plot writes into the folder it is in, or like render's -o
    (however spelled), or render -o ending in a slash: exit 2, the recording untouched (render and
    plot replaced it with a picture)."""
    from tests.viewer_toys import record_skip

    recording = tmp_path / "skip.mcap"
    record_skip(recording, ["until=0.05", "record.visual_rate=0"])
    data = recording.read_bytes()
    as_png = tmp_path / "frame.png"
    as_png.write_bytes(data)
    assert main(["render", str(as_png), "-o", str(tmp_path / "." / "frame.png"), "-q"]) == 2
    assert "is the recording rendered" in one_error_line(capsys.readouterr().err)
    figures = tmp_path / "figs"
    figures.mkdir()
    inside = figures / "energy.png"
    inside.write_bytes(data)
    assert main(["plot", str(inside), "-o", str(figures)]) == 2
    assert "is the recording plotted" in one_error_line(capsys.readouterr().err)
    assert main(["render", str(recording), "-o", str(tmp_path / "x.png") + "/", "-q"]) == 2
    assert "names a folder" in one_error_line(capsys.readouterr().err)
    assert as_png.read_bytes() == data and inside.read_bytes() == data
    assert sorted(p.name for p in figures.iterdir()) == ["energy.png"] and not (tmp_path / "x.png").exists()


def test_a_live_port_in_use_is_bad_input_and_leaves_no_recording(scene, tmp_path, capsys):
    """--live on a port another server holds: exit 2 (the --live given cannot be used; it was 1), one
    line with the system's reason, and no recording begun."""
    import socket

    pytest.importorskip("foxglove")
    with socket.socket() as held:
        held.bind(("127.0.0.1", 0))
        held.listen()
        port = held.getsockname()[1]
        out = tmp_path / "x.mcap"
        assert main(["run", str(scene), "--live", f"127.0.0.1:{port}", "-o", str(out), "-q"]) == 2
    line = one_error_line(capsys.readouterr().err)
    assert line.startswith(f"error: --live 127.0.0.1:{port}: cannot start the WebSocket server (")
    assert not list(tmp_path.glob("x.mcap*"))


def test_a_sigterm_that_python_drops_still_ends_the_command(monkeypatch, capsys):
    """A SIGTERM whose KeyboardInterrupt lands where Python drops it (a __del__, a callback) let the
    command run on and exit 0: it now ends as interrupted when the command returns, exit 1; and the
    handler is back to what it was."""
    import cosim.cli as cli

    def swallowed(args):
        try:
            os.kill(os.getpid(), signal.SIGTERM)
            time.sleep(1.0)
        except KeyboardInterrupt:
            pass  # as Python does with one raised inside a __del__
        return 0

    before = signal.getsignal(signal.SIGTERM)
    monkeypatch.setattr(cli, "cmd_validate", swallowed)
    assert cli.main(["validate", "scene.yaml"]) == 1
    assert one_error_line(capsys.readouterr().err) == "error: cosim validate: interrupted (SIGTERM)"
    assert signal.getsignal(signal.SIGTERM) is before


@pytest.mark.parametrize("option", [["--live-linger", "5"], ["--live-speed", "5"]])
def test_a_live_option_without_live_is_bad_input(scene, tmp_path, capsys, monkeypatch, option):
    """--live-linger or --live-speed without --live did nothing, silently: exit 2 saying so."""
    monkeypatch.chdir(tmp_path)
    assert main(["run", str(scene), "--no-record", "-q", *option]) == 2
    assert one_error_line(capsys.readouterr().err).startswith(f"error: cosim run: {option[0]} without --live: ")


def test_the_live_url_of_an_ipv6_host_is_bracketed():
    """ws://[::1]:8765, a URL a client can open (it printed ws://::1:8765)."""
    from types import SimpleNamespace

    from cosim.view.live import LiveView

    assert LiveView.url.fget(SimpleNamespace(host="::1", port=8765)) == "ws://[::1]:8765"
    assert LiveView.url.fget(SimpleNamespace(host="127.0.0.1", port=8765)) == "ws://127.0.0.1:8765"


def test_a_ctrl_c_as_the_process_ends_prints_no_traceback(tmp_path):
    """A Ctrl-C that lands as the process ends (a sweep's pool joining its threads at exit), or in a
    callback the interpreter runs itself (numba's cache notice in a sweep worker), cannot be passed on:
    Python printed it, "Exception ignored ... Traceback ... KeyboardInterrupt", after the command's own
    one line. Anything else so dropped is still printed."""
    from cosim.errors import quiet_interrupts

    seen = []
    hook = quiet_interrupts(seen.append)
    hook(type("U", (), {"exc_value": KeyboardInterrupt()})())
    hook(type("U", (), {"exc_value": ValueError("x")})())
    assert [type(u.exc_value) for u in seen] == [ValueError]
    script = ("import atexit, sys\n"
              "def late():\n    raise KeyboardInterrupt\n"
              "atexit.register(late)\n"
              "import cosim.cli\nsys.argv = ['cosim', 'components']\nraise SystemExit(cosim.cli.main())\n")
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    done = subprocess.run([sys.executable, "-c", script], cwd=tmp_path, env=env, text=True, capture_output=True,
                          timeout=60)
    assert done.returncode == 0 and "Traceback" not in done.stderr and "KeyboardInterrupt" not in done.stderr, \
        done.stderr


def test_a_signal_after_a_command_has_written_everything_leaves_its_exit_code(tmp_path):
    """`cosim plot` has written and said every figure; a SIGTERM in the interpreter's teardown that
    followed (0.3 s of freeing matplotlib's objects, the default handlers back) killed it: exit -15,
    though it had succeeded. Every command now ends as soon as it has returned, and a signal until
    then ends it with the code it decided."""
    recording = tmp_path / "held.mcap"
    scene = ROOT / "scenarios" / "held_skip.yaml"
    assert main(["run", str(scene), "-q", "--until", "0.2", "-o", str(recording)]) == 0
    env = {**os.environ, "PYTHONPATH": str(ROOT), "PYTHONUNBUFFERED": "1"}
    proc = subprocess.Popen([sys.executable, "-m", "cosim.cli", "plot", str(recording), "-o", str(tmp_path / "figs")],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    wrote = 0
    for line in proc.stdout:
        wrote += line.startswith("wrote ")
        if wrote == 4:
            time.sleep(0.1)
            proc.send_signal(signal.SIGTERM)
            break
    _, err = proc.communicate(timeout=60)
    assert wrote == 4 and proc.returncode == 0, err
    assert len(list((tmp_path / "figs").glob("*.png"))) == 4
