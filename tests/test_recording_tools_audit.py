"""What the recording tools say and leave when a run, a restart or a figure goes wrong: a failed
restart says why on stderr, a plot cut short leaves its folder as it was, a recording without its
body's channels is told apart from a run without a body, render names the time that is out of the
recording, and a record block that names no channel is bad input."""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from mcap.reader import make_reader

from components.analysis import plot
from cosim.cli import main
from cosim.codec import state_proto
from cosim.codec.json_codec import plain_state
from cosim.record.recorder import CHECKPOINT_TOPIC
from cosim.runner import run_scene
from cosim.scenario import ScenarioError, load, loads
from tests.cli_toys import one_error_line
from tests.recording_copies import copy_recording
from tests.viewer_toys import record_skip

SCENES = Path(__file__).resolve().parent.parent / "scenarios"


@pytest.fixture(scope="module")
def skip_path(tmp_path_factory):
    path = tmp_path_factory.mktemp("tools") / "skip.mcap"
    record_skip(path, ["record.visual_rate=0"])
    return path


def test_a_restart_that_fails_says_why_on_stderr(tmp_path, capsys, monkeypatch):
    """A restart whose run fails (here its stage monitor, made to fail from 30 ms on) exits 1 with the
    reason on stderr as `cosim run` gives it (it was only in the summary, stderr empty)."""
    from components.stages import StageMonitor

    first = tmp_path / "run.mcap"
    assert main(["run", str(SCENES / "held_skip.yaml"), "-q", "--until", "0.1", "--set",
                 "record.checkpoint_every=0.01", "-o", str(first)]) == 0
    capsys.readouterr()
    step = StageMonitor._step_impl

    def failing(self, t, dt, inputs):
        if t + dt > 0.03:
            raise ValueError("the monitor's test failure")
        return step(self, t, dt, inputs)

    monkeypatch.setattr(StageMonitor, "_step_impl", failing)
    assert main(["replay", str(first), "--from", "0.02", "-q", "-o", str(tmp_path / "again.mcap")]) == 1
    err = capsys.readouterr().err
    assert err == "error: component 'stages' failed at t = 0.03 s: ValueError: the monitor's test failure\n"


def test_a_plot_cut_short_leaves_its_folder_as_it_was(skip_path, tmp_path, monkeypatch):
    """Ctrl-C while the third figure is drawn: no figure of this plot is left, nor a temporary file,
    and a figure there before is kept whole (it left the first two, a set that looked finished)."""
    folder = tmp_path / "figs"
    folder.mkdir()
    (folder / "trajectory.png").write_bytes(b"the earlier picture")
    figures = dict(plot.FIGURES)
    third = list(figures)[2]

    def interrupted(run):
        raise KeyboardInterrupt

    monkeypatch.setitem(plot.FIGURES, third, interrupted)
    with pytest.raises(KeyboardInterrupt):
        plot.plot_run(skip_path, folder)
    assert sorted(p.name for p in folder.iterdir()) == ["trajectory.png"]
    assert (folder / "trajectory.png").read_bytes() == b"the earlier picture"
    monkeypatch.setattr(plot, "FIGURES", figures)
    written, _ = plot.plot_run(skip_path, folder)
    assert {p.name for p in written} <= {p.name for p in folder.iterdir()} and len(written) >= 3


def test_a_recording_without_its_bodys_channels_is_not_a_run_without_a_body(tmp_path, capsys):
    """The held skip recorded with only its water field: the plot says the body's channels were left
    out of the recording, not that the run had no body."""
    path = tmp_path / "water_only.mcap"
    assert main(["run", str(SCENES / "held_skip.yaml"), "-q", "--until", "0.2", "--record", "/pond/field",
                 "-o", str(path)]) == 0
    written, skipped = plot.plot_run(path, tmp_path / "figs")
    assert [p.name for p in written] == [plot.WATER_FIGURE]
    assert skipped[0][1] == "the recording holds no body's state (its channels were left out: --record)"


def test_render_names_the_time_outside_the_recording(skip_path, tmp_path, capsys):
    """--from after the recording's end names --from and the recorded span (it said that a --to,
    not given, was before it)."""
    assert main(["render", str(skip_path), "-o", str(tmp_path / "x.gif"), "--from", "50", "-q"]) == 2
    err = capsys.readouterr().err
    assert "--from 50 s is outside the recorded" in err and "--to" not in err
    assert main(["render", str(skip_path), "-o", str(tmp_path / "x.gif"), "--to", "50", "-q"]) == 2
    assert "--to 50 s is outside the recorded" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("channels", ["[]", "['  ']"])
def test_a_record_block_that_names_no_channel_is_refused(channels):
    """As `--record ,,` is: a recording of no exchange at all, said nowhere, was the run's result."""
    with pytest.raises(ScenarioError, match=r"record\.channels: names no channel"):
        load(SCENES / "held_skip.yaml", [f"record.channels={channels}"])


def test_render_refuses_a_follow_view_too_wide_to_show_the_stone(skip_path, tmp_path, capsys):
    """`--span 1e6` wrote a picture with nothing visible: a stone narrower than a pixel is bad input."""
    assert main(["render", str(skip_path), "-o", str(tmp_path / "x.png"), "--span", "1e6", "-q"]) == 2
    err = capsys.readouterr().err
    assert err == ("error: --span 1e+06 m: the stone (0.06 m across) would be narrower than a pixel of the 800 px "
                   "frame; give at most 48 m (or --view fixed)\n")
    assert list(tmp_path.iterdir()) == []


# --- a checkpoint that decodes but is not one ----------------------------------------------------

BODY = """
dt: 0.001
until: 0.05
components:
  stone: {type: RigidBody, shape: disk, radius: 0.03, thickness: 0.005}
record: {checkpoint_every: 0.01, visual_rate: 0}
"""


@pytest.fixture(scope="module")
def body_path(tmp_path_factory) -> Path:
    """A falling disk alone, 50 steps, a checkpoint every 10."""
    path = tmp_path_factory.mktemp("body") / "body.mcap"
    run_scene(loads(BODY), path, progress=False)
    return path


def _with_checkpoint(src: Path, dst: Path, time_ns: int, change: Callable[[dict], Any]) -> Path:
    """A copy of the recording ``src`` whose checkpoint at ``time_ns`` is ``change(checkpoint)``,
    encoded as the recorder encodes one (a valid payload, every CRC matching)."""
    def message(channel, msg) -> bytes:
        if channel.topic == CHECKPOINT_TOPIC and msg.log_time == time_ns:
            return state_proto.state_bytes(plain_state(change(state_proto.decode_checkpoint(msg.data))))
        return msg.data

    return copy_recording(src, dst, message=message)


def _with_stone_state(cp: dict, **state: Any) -> dict:
    stone = cp["components"]["stone"]
    return {**cp, "components": {**cp["components"], "stone": {**stone, "state": {**stone["state"], **state}}}}


@pytest.mark.parametrize(("change", "said"), [
    (lambda cp: [1, 2, 3], "it is a list [1, 2, 3], not a mapping of tick, dt_ns, components, slots and edges"),
    (lambda cp: "hello", "it is a text 'hello', not a mapping of tick, dt_ns, components, slots and edges"),
    (lambda cp: {**cp, "components": [1]}, "its components is a list [1], not a mapping of component names to "
                                           "their states"),
    (lambda cp: {**cp, "slots": {"stone.state": [[1, 2, 3]]}}, "its slots['stone.state'][0] is a list [1, 2, 3], "
                                                               "not [stamp, payload]"),
    (lambda cp: {**cp, "tick": 7}, "its time, tick 7 x dt_ns 1000000 = 0.007 s, is not the time it was recorded "
                                   "at, 0.02 s"),
    # the body's own state, said naming it
    (lambda cp: _with_stone_state(cp, orientation=5), "component 'stone' cannot take the state it holds: TypeError: "
                                                      "'int' object is not iterable"),
])
def test_a_checkpoint_of_the_wrong_form_is_bad_input_naming_what_is_wrong(body_path, tmp_path, capsys, change, said):
    """A valid payload holding a list, a text or `components: [1]` ended in an internal TypeError
    (exit 1) where the scheduler restored it: exit 2, one line naming the checkpoint and what is
    wrong with it, no file."""
    bad = _with_checkpoint(body_path, tmp_path / "bad.mcap", 20_000_000, change)
    assert main(["replay", str(bad), "--from", "0.02", "-q", "-o", str(tmp_path / "again.mcap")]) == 2
    line = one_error_line(capsys.readouterr().err)
    assert line == f"error: {bad}: cannot restart from the checkpoint at 0.02 s: {said}"
    assert [p.name for p in tmp_path.iterdir()] == ["bad.mcap"]


# --- a restart whose recording lost the checkpoint it started from --------------------------------

FULL_DISK = ("writing the recording failed (No space left on device); the recording was closed where it stopped, "
             "at t = 0 s, and what the run recorded after that was lost")


def _closed_where_the_disk_filled(path: Path) -> Path:
    """``path`` as a full disk leaves it: cut inside its first chunk (which holds the checkpoint a
    restart records first) and closed in place with the `failed` status the writer gives it."""
    from cosim.codec.json_codec import codec_for
    from cosim.record.recorder import STATUS_TOPIC, DerivedMessage, RunStatus
    from cosim.record.seal import seal

    with open(path, "rb") as f:
        first = min(c.chunk_start_offset for c in make_reader(f).get_summary().chunk_indexes)
    os.truncate(path, first + 10)
    codec = codec_for(RunStatus)
    status = DerivedMessage(STATUS_TOPIC, codec.schema_name, "jsonschema", codec.schema_bytes(), "json",
                            codec.encode(RunStatus("failed", FULL_DISK, 0, 0.0, 0)))
    seal(path, lambda end_ns: (0, status))
    return path


def test_a_restart_whose_checkpoint_the_full_disk_lost_says_so(body_path, tmp_path, capsys):
    """A restart recorded onto a full disk keeps no chunk, its checkpoint with them: replay said it
    was "recorded without the checkpoint it started from (record.checkpoint_every 0)", which it was
    not; it says the checkpoint is not in the file and why, from the recorded status."""
    restart = tmp_path / "from.mcap"
    assert main(["replay", str(body_path), "--from", "0.02", "-q", "-o", str(restart)]) == 0
    _closed_where_the_disk_filled(restart)
    capsys.readouterr()
    assert main(["replay", str(restart), "-q"]) == 2
    line = one_error_line(capsys.readouterr().err)
    assert line == (f"error: {restart}: cannot replay: a restart from t = 0.02 s, and the checkpoint it started from "
                    f"is not in the file (its run failed: {FULL_DISK}): replay the recording it was restarted from")
    assert main(["replay", str(restart), "--from", "0", "-q", "-o", str(tmp_path / "again.mcap")]) == 2
    assert one_error_line(capsys.readouterr().err).endswith(
        f"this recording is a restart from 0.02 s, and holds no checkpoint (its run failed: {FULL_DISK}): restart "
        "from the recording it came from")


def test_a_restart_recorded_without_checkpoints_says_so(body_path, tmp_path, capsys):
    """What the line said of every restart without its checkpoint is still said when it is true. And
    --from it at or after its start points to the recording it came from too, as before its start
    (it was told to "record with record.checkpoint_every > 0")."""
    restart = tmp_path / "from.mcap"
    assert main(["replay", str(body_path), "--from", "0.02", "-q", "-o", str(restart), "--set",
                 "record.checkpoint_every=0"]) == 0
    capsys.readouterr()
    assert main(["replay", str(restart), "-q"]) == 2
    assert one_error_line(capsys.readouterr().err) == (
        f"error: {restart}: cannot replay: a restart from t = 0.02 s, recorded without the checkpoint it started from "
        "(record.checkpoint_every 0): replay the recording it was restarted from")
    for at in ("0.01", "0.02", "0.03"):
        assert main(["replay", str(restart), "--from", at, "-q", "-o", str(tmp_path / "again.mcap")]) == 2
        assert one_error_line(capsys.readouterr().err).endswith(
            "this recording is a restart from 0.02 s, recorded without checkpoints: restart from the recording it "
            "came from")


def test_a_run_whose_checkpoints_the_full_disk_lost_is_not_told_to_record_them(body_path, tmp_path, capsys):
    """--from on a run from t = 0 whose every chunk the full disk took was told to "record with
    record.checkpoint_every > 0", which it had."""
    run = _closed_where_the_disk_filled(_written_copy(body_path, tmp_path / "run.mcap"))
    assert main(["replay", str(run), "--from", "0", "-q", "-o", str(tmp_path / "again.mcap")]) == 2
    assert one_error_line(capsys.readouterr().err) == (
        f"error: {run}: no checkpoint at or before t = 0 s (checkpoints at [s]: none); the recording holds none (its "
        f"run failed: {FULL_DISK})")


def _written_copy(src: Path, dst: Path) -> Path:
    dst.write_bytes(src.read_bytes())
    return dst


def test_replay_says_which_component_a_message_it_cannot_read_stops(tmp_path, capsys):
    """ground_bounce with the flat disk's states undecodable (valid CRCs, as another tool would write
    them): the disk and the floor that reads them each stop, and each line said the same words twice
    with no component named. Now each names the component it stops, exit 2."""
    recorded = tmp_path / "gb.mcap"
    run_scene(load(SCENES / "ground_bounce.yaml", ["until=0.05"]), recorded, progress=False)
    garbage = b"\xff\xff\xff\xff\x0f"
    bad = copy_recording(recorded, tmp_path / "bad.mcap",
                         message=lambda ch, msg: garbage if ch.topic == "/disk_flat/state" else msg.data)
    assert main(["replay", str(bad), "-q"]) == 2
    lines = [line for line in capsys.readouterr().err.splitlines() if line.startswith("error: ")]
    assert [line.split(":")[1].strip() for line in lines] == ["cannot replay 'disk_flat'", "cannot replay 'floor_flat'"]
    assert all("/disk_flat/state at 0 ns" in line for line in lines)
