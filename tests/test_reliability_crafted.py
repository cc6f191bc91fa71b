"""Recordings whose every CRC matches but whose content no cosim run writes (found by an audit): each
is one line naming what is wrong and where, exit 2, from every command that reads it.

- a message payload cut short (a water field, every height patch): plot and render decoded them
  outside the reader's error handling, and the decoder's ProtoError was an internal error, exit 1;
- a message logged at 2^63 ns or later (MCAP's log times go to 2^64 - 1, a cosim recording's,
  int64 nanoseconds, to 2^63 - 1): read as it was, inspect showed "time span: 1.84467e+10 s" and plot
  and render overflowed their int64 arrays (an internal OverflowError);
- the ``overrides`` key missing from the cosim metadata (the recorder has written it in every
  recording since its first): read as "no overrides", so replay of a run made with ``--set`` reported
  false divergences against its own scene.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from components.messages import Stage
from cosim.cli import main
from cosim.record.reader import Recording
from cosim.runner import run_scene
from cosim.scenario import MAX_TIME_NS, load
from tests.cli_toys import one_error_line
from tests.recording_copies import copy_recording

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def water_run(tmp_path_factory) -> Path:
    """The reference skip for 20 ms: a body, its water's field and patches, a stage monitor, a checkpoint.
    Read-only to the tests: they write changed copies of it."""
    out = tmp_path_factory.mktemp("crafted") / "skip.mcap"
    outcome = run_scene(load(ROOT / "scenarios" / "skip.yaml", overrides=["until=0.02"]), out, progress=False)
    assert outcome.result.status == "ok"
    return out


def _commands(recording: Path, folder: Path) -> dict[str, list[str]]:
    return {"inspect": ["inspect", str(recording)],
            "plot": ["plot", str(recording), "-o", str(folder / "figs")],
            "render": ["render", str(recording), "-o", str(folder / "frame.png"), "-q"],
            "replay": ["replay", str(recording)]}


def _payload_cut(topic: str, how):
    return lambda channel, msg: how(msg.data) if channel.topic == topic else msg.data


@pytest.mark.parametrize(("topic", "how", "commands"), [
    ("/pond/field", lambda data: data[:100], ("render",)),  # (plot draws no water field when a body is there)
    ("/pond/patch", lambda data: data[:len(data) // 2], ("plot", "render")),
])
def test_a_payload_cut_short_is_one_line_naming_its_channel_from_plot_and_render(water_run, tmp_path, capsys,
                                                                                 topic, how, commands):
    """A payload cut short, its CRCs made to match: exit 2, one line naming the recording, the channel
    and the message's time (it was "internal error: ProtoError", exit 1), and no picture or folder."""
    crafted = copy_recording(water_run, tmp_path / "cut_payload.mcap", message=_payload_cut(topic, how))
    stamps = [stamp for _, stamp, _ in Recording(crafted).raw([topic])]
    for command in commands:
        assert main(_commands(crafted, tmp_path)[command]) == 2, command
        line = one_error_line(capsys.readouterr().err)
        assert line.startswith(f"error: {crafted}: {topic} at {stamps[0]} ns: "), line
        assert "internal error" not in line
    assert sorted(p.name for p in tmp_path.iterdir()) == [crafted.name]


@pytest.mark.parametrize("log_time", [2**63, 2**64 - 1])
def test_a_message_logged_later_than_int64_nanoseconds_hold_is_refused_naming_its_channel_and_time(
        water_run, tmp_path, capsys, log_time):
    """The stage monitor's message logged at 2^63 ns or later (valid in MCAP): inspect, plot, render and
    replay refuse the recording in one line naming the channel, the time and the bound, exit 2 (inspect
    showed "time span: 1.84467e+10 s", plot and render failed with an internal OverflowError)."""
    crafted = copy_recording(water_run, tmp_path / "late.mcap",
                             log_time=lambda channel, msg: log_time if channel.topic == "/stages/stage"
                             else msg.log_time)
    for command, argv in _commands(crafted, tmp_path).items():
        assert main(argv) == 2, command
        line = one_error_line(capsys.readouterr().err)
        assert line == (f"error: {crafted}: /stages/stage: a message logged at {log_time} ns ({log_time / 1e9:.6g} "
                        f"s), later than a cosim recording's times reach (at most 2^63 - 1 = {MAX_TIME_NS} ns, "
                        "about 292 years: what int64 nanoseconds hold)"), command
    assert sorted(p.name for p in tmp_path.iterdir()) == [crafted.name]


def test_the_latest_time_int64_nanoseconds_hold_is_read(water_run, tmp_path):
    """2^63 - 1 ns, the last time a recording's times hold, is read as it is."""
    edge = copy_recording(water_run, tmp_path / "edge.mcap",
                          log_time=lambda channel, msg: MAX_TIME_NS if channel.topic == "/stages/stage"
                          else msg.log_time)
    rec = Recording(edge)
    assert rec.end_ns == MAX_TIME_NS
    assert [stamp for stamp, _ in rec.messages("/stages/stage", Stage)] == [MAX_TIME_NS]


def test_a_recording_without_its_overrides_is_refused_naming_the_key(water_run, tmp_path, capsys):
    """No ``overrides`` in the cosim metadata (the recorder always writes it, "[]" for none): exit 2
    naming the key, from inspect and replay (it was read as a run without overrides: replay of a run
    made with --set compared it with the scene as written and reported divergences, exit 1)."""
    assert json.loads(Recording(water_run).metadata["overrides"]) == ["until=0.02"]
    crafted = copy_recording(water_run, tmp_path / "no_overrides.mcap",
                             metadata=lambda name, fields: {k: v for k, v in fields.items() if k != "overrides"}
                             if name == "cosim" else fields)
    for command in ("inspect", "replay"):
        assert main([command, str(crafted)]) == 2, command
        assert one_error_line(capsys.readouterr().err) == (
            f"error: {crafted}: not a cosim recording (its metadata cannot be read: overrides, the run's changes "
            "to its scene (--set; [] for none), is missing)")
    none = copy_recording(water_run, tmp_path / "none.mcap",  # "[]": a run without overrides, read as one
                          metadata=lambda name, fields: {**fields, "overrides": "[]"} if name == "cosim" else fields)
    assert Recording(none).overrides == []
