"""What the recording tools say and leave when a run, a restart or a figure goes wrong: a failed
restart says why on stderr, a plot cut short leaves its folder as it was, a recording without its
body's channels is told apart from a run without a body, render names the time that is out of the
recording, and a record block that names no channel is bad input."""

from __future__ import annotations

from pathlib import Path

import pytest

from components.analysis import plot
from cosim.cli import main
from cosim.scenario import ScenarioError, load
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
