"""`cosim plot`: figures drawn from a recording, checked against what was recorded."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

from pathlib import Path

import numpy as np
import pytest
from matplotlib.collections import LineCollection
from matplotlib.colors import to_rgb
from matplotlib.image import imread

from components.analysis.data import load_run
from components.analysis.plot import (
    contact_intervals,
    energy_terms,
    figure_contacts,
    figure_energy,
    figure_motion,
    figure_trajectory,
    plot_run,
)
from components.analysis.style import STAGE_COLORS
from components.messages import BodyState, StageId, WaterContact
from cosim.cli import main
from cosim.record.reader import Recording
from tests.viewer_toys import record_skip


@pytest.fixture(scope="module")
def skip_path(tmp_path_factory):
    path = tmp_path_factory.mktemp("plot") / "skip.mcap"
    record_skip(path, ["record.visual_rate=0"])
    return path


@pytest.fixture(scope="module")
def run(skip_path):
    return load_run(skip_path)


def test_trajectory_segments_are_the_recorded_positions_coloured_by_stage(run, skip_path):
    """The side view draws x-z of every recorded state, each segment in the colour of its stage."""
    fig = figure_trajectory(run)
    (lines,) = [c for c in fig.axes[0].collections if isinstance(c, LineCollection)]
    segments = lines.get_segments()
    states = Recording(skip_path).messages("/stone/state", BodyState)
    xz = np.array([[s.position[0], s.position[2]] for _, s in states])
    assert len(segments) == len(xz) - 1
    assert np.array_equal(np.array([seg[0] for seg in segments]), xz[:-1])
    colors = lines.get_colors()[:, :3]
    stages = run.stages.at(run.body.t[:-1])
    for stage in (StageId.APPROACH, StageId.HIT, StageId.SLIDE, StageId.FLY_AWAY):
        assert np.allclose(colors[stages == stage], to_rgb(STAGE_COLORS[stage]))
    assert any(line.get_ydata()[0] == 0.0 for line in fig.axes[0].lines)  # the water line


def test_motion_plots_speed_and_attack_angle_over_time(run):
    """Speed and attack angle are plotted against the recorded times."""
    fig = figure_motion(run)
    speed, angle = (ax.lines[0] for ax in fig.axes[:2])
    assert np.array_equal(speed.get_xdata(), run.body.t) and np.array_equal(speed.get_ydata(), run.body.speed)
    assert np.array_equal(angle.get_ydata(), run.body.attack_deg)


def test_energy_budget_sums_body_energy_and_what_the_water_dissipated(run, skip_path):
    """Total = kinetic + potential + energy dissipated by the water, held between its reports."""
    terms = energy_terms(run)
    water = [k for k in terms if k.startswith("dissipated by water")]
    assert water == ["dissipated by water (/coupler/contact)"]
    assert np.allclose(terms["total"], terms["kinetic"] + terms["potential"] + terms[water[0]])
    contacts = Recording(skip_path).messages("/coupler/contact", WaterContact)
    last_t, last = contacts[-1]
    assert terms[water[0]][-1] == last.dissipated_energy and run.body.t[-1] == last_t / 1e9


def test_one_force_panel_per_contact(run):
    """Each wetted span is one contact panel, with the water's forces over the time since touchdown."""
    spans = contact_intervals(run)
    assert len(spans) == 3 and all(0.02 < end - start < 0.06 for start, end in spans)
    fig = figure_contacts(run)
    visible = [ax for ax in fig.axes if ax.get_visible()]
    assert len(visible) == 3
    labels = {line.get_label() for line in visible[0].lines}
    assert {"pressure z", "friction along the motion", "/coupler/wrench z"} <= labels


def test_the_horizontal_forces_of_a_contact_are_drawn_along_the_motion(tmp_path):
    """The held skip thrown along +y: its contact panel draws the water's force along the motion as
    the same throw along +x does, a drag of about 13 N (drawn along x, it was flat at 0)."""
    from cosim.runner import run_scene
    from cosim.scenario import load
    from tests.turned_throw import ALONG_Y, HELD_SKIP

    along_x = ["until=0.3", "record.visual_rate=0"]
    drawn = []
    for sets, name in ((along_x, "x"), ([*along_x, *ALONG_Y], "y")):
        path = run_scene(load(HELD_SKIP, sets), tmp_path / f"{name}.mcap", progress=False).recording
        panel = figure_contacts(load_run(path)).axes[0]
        (line,) = [ln for ln in panel.lines if ln.get_label() == "/coupler/wrench along the motion"]
        drawn.append(np.asarray(line.get_ydata()))
    assert drawn[1] == pytest.approx(drawn[0], rel=1e-9, abs=1e-9)
    assert drawn[1].min() < -10.0


def test_a_restart_begun_in_a_contact_numbers_and_dates_it_as_the_run_did(tmp_path):
    """The held skip restarted at 1.0 s, in its glide after its fourth skip: the panel is that run's
    contact 5, from the touchdown the restored monitor holds, before the restart (it was "contact 1:
    t = 1.000 s", dated from the restart, the time axis said since touchdown)."""
    from cosim.cli import main

    scene = Path(__file__).resolve().parents[1] / "scenarios" / "held_skip.yaml"
    whole, restart = tmp_path / "held.mcap", tmp_path / "restart.mcap"
    assert main(["run", str(scene), "--until", "1.2", "-q", "-o", str(whole)]) == 0
    assert main(["replay", str(whole), "--from", "1.0", "--until", "1.1", "-q", "-o", str(restart)]) == 0
    full = load_run(whole)
    skips = len(full.skips)
    (touchdown,) = [start for start, end in contact_intervals(full) if start < 1.0 < end]
    panel = figure_contacts(load_run(restart)).axes[0]
    assert panel.get_title().startswith(
        f"contact {skips + 1}: touchdown t = {touchdown:.4f} s, restart t = 1.0000 s;\n")
    assert panel.get_title().endswith(" g after the restart")  # its samples' peak: the glide has no skip record
    assert panel.get_xlabel() == "time since the restart [ms]"


def test_a_restart_begun_in_a_skips_contact_is_dated_from_its_touchdown(tmp_path):
    """The held skip restarted at 0.36 s, 24 ms into the contact of its second skip: the panel says
    the restart's time (it gave the touchdown's, "before the restart at t = 0.336 s"), its time axis
    runs from the touchdown the skip record dates (it said "since the restart"), and the peak is the
    whole contact's, from that record (it said "after the restart" of a peak reached before it)."""
    from cosim.cli import main

    scene = Path(__file__).resolve().parents[1] / "scenarios" / "held_skip.yaml"
    whole, restart = tmp_path / "held.mcap", tmp_path / "restart.mcap"
    assert main(["run", str(scene), "--until", "0.5", "--set", "record.checkpoint_every=0.09", "-q",
                 "-o", str(whole)]) == 0
    assert main(["replay", str(whole), "--from", "0.36", "--until", "0.5", "-q", "-o", str(restart)]) == 0
    second = load_run(whole).skips[1]
    assert second.touchdown_time < 0.36 < second.touchdown_time + second.contact_time
    panel = figure_contacts(load_run(restart)).axes[0]
    assert panel.get_title() == (f"contact 2: touchdown t = {second.touchdown_time:.4f} s, restart t = 0.3600 s;\n"
                                 f"{second.contact_time * 1e3:.1f} ms, peak {second.peak_g:.1f} g")
    assert panel.get_xlabel() == "time since the touchdown [ms]"


def test_the_energy_figure_says_what_its_total_leaves_out(tmp_path):
    """A recording without the coupler's reports (its dissipation), a body moved by a script (its
    work): the energy figure's title says its total leaves them out (it drew a "total" falling or
    rising with no word); a whole recording of a free body says nothing."""
    from cosim.runner import run_scene
    from cosim.scenario import load

    root = Path(__file__).resolve().parents[1] / "scenarios"
    cases = ((root / "held_skip.yaml", ["record.channels=['/stone/*', '/stages/*']"],
              "the total leaves out coupler's dissipation (not recorded)"),
             (root / "scripted_skim.yaml", [], "the total leaves out the work of its script"),
             (root / "held_skip.yaml", [], None))
    for k, (scene, sets, said) in enumerate(cases):
        path = run_scene(load(scene, ["until=0.1", "record.visual_rate=0", *sets]), tmp_path / f"{k}.mcap",
                         progress=False).recording
        title = figure_energy(load_run(path)).axes[0].get_title()
        assert title.endswith(said) if said else "leaves out" not in title


def test_plot_writes_non_empty_pngs_showing_the_stages(skip_path, tmp_path, capsys):
    """`cosim plot` writes four PNGs; the side view contains the colour of every stage met."""
    assert main(["plot", str(skip_path), "-o", str(tmp_path / "figs"), "--dpi", "60"]) == 0
    out = capsys.readouterr().out
    names = sorted(p.name for p in (tmp_path / "figs").glob("*.png"))
    assert names == ["contacts.png", "energy.png", "motion.png", "trajectory.png"]
    assert out.count("wrote ") == 4
    image = imread(tmp_path / "figs" / "trajectory.png")[..., :3]
    assert image.shape[0] > 100 and image.std() > 0.05
    pixels = image.reshape(-1, 3)
    for stage in (StageId.APPROACH, StageId.HIT, StageId.SLIDE, StageId.FLY_AWAY):
        close = np.abs(pixels - np.array(to_rgb(STAGE_COLORS[stage]))).max(axis=1) < 0.03
        assert close.sum() > 20, stage


def test_plot_without_a_body_is_bad_input(tmp_path, capsys):
    """A recording without a BodyState channel exits 2 with a one-line reason."""
    from cosim.runner import run_scene
    from cosim.scenario import loads

    scene = loads("dt: 0.001\nuntil: 0.01\ncomponents:\n  src: {type: 'tests.toys:Source'}\n")
    path = run_scene(scene, tmp_path / "toy.mcap", progress=False).recording
    assert main(["plot", str(path), "-o", str(tmp_path / "figs")]) == 2
    assert "no BodyState channel" in capsys.readouterr().err


def test_water_alone_gets_its_crest_volume_and_energy_over_time(tmp_path, capsys):
    """A recording of water alone (the wave pulse in its closed basin) gets water.png: the crest
    falls from the pulse's 1 cm as it spreads, the volume does not change, the energy is the
    recorded one; the body's figures are named as skipped. Before, plot refused it."""
    from components.analysis.plot import figure_water
    from components.messages import WaterField
    from cosim.runner import run_scene
    from cosim.scenario import load

    scene = Path(__file__).resolve().parents[1] / "scenarios" / "wave_pulse.yaml"
    path = run_scene(load(scene, ["until=0.3"]), tmp_path / "pulse.mcap", progress=False).recording
    assert main(["plot", str(path), "-o", str(tmp_path / "figs"), "--dpi", "40"]) == 0
    out = capsys.readouterr().out
    assert "wrote" in out and "water.png" in out and "skipped trajectory.png" in out
    assert imread(tmp_path / "figs" / "water.png").shape[0] > 100
    rec = Recording(path)
    fields = [m for _, m in rec.messages("/pond/field", WaterField)]
    crest, volume, energy = figure_water(rec, "/pond/field").axes
    heights = crest.lines[0].get_ydata()
    assert heights[0] == pytest.approx(1000 * float(fields[0].height.max()))  # the 1 cm pulse, in mm
    assert heights[-1] < 0.5 * heights[0]
    assert np.abs(volume.lines[0].get_ydata()).max() < 1e-12
    assert list(energy.lines[0].get_ydata()) == [f.energy for f in fields]


def test_plot_skips_the_contact_figure_without_contacts(tmp_path, capsys):
    """A run without any contact writes three figures and says why the fourth is missing."""
    path = tmp_path / "flight.mcap"
    record_skip(path, ["until=0.05", "record.visual_rate=0"])
    written, skipped = plot_run(path, tmp_path / "figs", dpi=40)
    assert len(written) == 3 and skipped == [("contacts.png", "no contact in this run")]


def test_contact_panels_last_as_long_as_the_summary_says_and_show_only_their_contact(run):
    """The contacts figure's durations are the stage monitor's (those the run's summary prints), and
    no panel's window reaches into the contact before or after it."""
    spans = contact_intervals(run)
    for skip, (start, end) in zip(sorted(run.skips, key=lambda s: s.index), spans, strict=False):
        assert start == pytest.approx(skip.touchdown_time)
        assert end - start == pytest.approx(skip.contact_time)
    fig = figure_contacts(run)
    visible = [ax for ax in fig.axes if ax.get_visible()]
    for k, ax in enumerate(visible[1:], start=1):
        lo_ms = ax.get_xlim()[0]
        assert spans[k][0] + lo_ms / 1e3 > spans[k - 1][1] - 1e-9


def test_the_attack_angle_panel_says_when_the_attitude_is_held(tmp_path):
    """A stone whose attitude is held gets an attack-angle panel that says so, rather than a flat
    line with no word why; a free one does not."""
    from cosim.runner import run_scene
    from cosim.scenario import load

    scene = Path(__file__).resolve().parents[1] / "scenarios" / "skip.yaml"
    held, free = tmp_path / "held.mcap", tmp_path / "free.mcap"
    for path, locked in ((held, "true"), (free, "false")):
        sets = ["record.visual_rate=0", "until=0.05", f"components.stone.lock_attitude={locked}"]
        run_scene(load(scene, sets), path, progress=False)
    held_run = load_run(held)
    title = figure_motion(held_run).axes[1].get_title()
    assert "attitude held" in title and "keeps its tilt" in title
    assert np.ptp(held_run.body.attack_deg) < 1e-9  # what the title says: the curve is flat
    assert "attitude held" not in figure_motion(load_run(free)).axes[1].get_title()
    # a scripted attitude turns the face (scripted_skim: 15 deg, then flat from 1.6 s): said so, not
    # "held ... keeps its tilt" beside a curve going from 15 to 0 deg
    skim = run_scene(load(scene.with_name("scripted_skim.yaml"), ["record.visual_rate=0"]), tmp_path / "skim.mcap",
                     progress=False).recording
    skim_run = load_run(skim)
    title = figure_motion(skim_run).axes[1].get_title()
    assert title.startswith("attitude scripted (scripted_tilt_deg)") and "keeps its tilt" not in title
    assert np.ptp(skim_run.body.attack_deg) > 10.0


def test_a_bounce_in_place_without_water_is_drawn_as_height_over_time(tmp_path):
    """A disk dropped on a floor (no water, no stage monitor) gets its height over time, not a
    vertical line: no water line, no stage legend, and a mark at each ground contact."""
    from cosim.runner import run_scene
    from cosim.scenario import load

    scene = Path(__file__).resolve().parents[1] / "scenarios" / "ground_bounce.yaml"
    path = tmp_path / "bounce.mcap"
    run_scene(load(scene, ["until=0.4", "record.visual_rate=0"]), path, progress=False)
    run = load_run(path, "disk_flat")
    assert run.stages is None and not run.contacts
    ax = figure_trajectory(run).axes[0]
    assert ax.get_xlabel() == "time [s]" and "height over time" in ax.get_title()
    (lines,) = [c for c in ax.collections if isinstance(c, LineCollection)]
    starts = np.array([seg[0] for seg in lines.get_segments()])
    assert np.array_equal(starts[:, 0], run.body.t[:-1]) and np.array_equal(starts[:, 1], run.body.position[:-1, 2])
    from components.analysis.data import contact_spans

    g = run.grounds[0]
    touches = len(contact_spans(g.in_contact, g.t))
    assert touches >= 1  # a 10 cm drop lands after 0.14 s
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert labels == [f"ground contact ({touches})"]
    assert not any("water" in label or "unknown" in label for label in labels)


def test_the_initial_state_is_in_the_first_stage_not_an_unknown_one(run):
    """The stone's first recorded state, before the monitor's first message (published at the end of
    its first step), is drawn in the first stage, which the message dates from the run's start: the
    legend names only real stages."""
    from components.analysis.plot import stage_per_sample

    assert run.body.t[0] == run.stages.t[0] == 0.0
    assert stage_per_sample(run)[0] == run.stages.stage[0]
    labels = [t.get_text() for t in figure_trajectory(run).axes[0].get_legend().get_texts()]
    assert labels and "before the first stage" not in labels and "unknown" not in labels


def test_plot_into_something_that_is_not_a_folder_is_bad_input(skip_path, tmp_path, capsys):
    """-o naming a file: exit 2 with the reason, and the file is left as it was."""
    target = tmp_path / "figs"
    target.write_text("not a folder\n")
    assert main(["plot", str(skip_path), "-o", str(target)]) == 2
    assert "not a folder" in capsys.readouterr().err
    assert target.read_text() == "not a folder\n"


def test_a_path_that_curves_sideways_is_also_drawn_from_above(run, tmp_path):
    """The reference skip, spun, curves to the left: its trajectory figure has a second panel with
    the recorded x-y of every state and a mark at each skip's touchdown; the scripted straight
    throw has the side view alone."""
    from cosim.runner import run_scene
    from cosim.scenario import load

    scene = Path(__file__).resolve().parents[1] / "scenarios" / "skip.yaml"
    path = tmp_path / "curving.mcap"
    run_scene(load(scene, ["record.visual_rate=0", "record.checkpoint_every=0", "until=1.2"]), path, progress=False)
    curving = load_run(path)
    assert np.ptp(curving.body.position[:, 1]) > 0.05
    fig = figure_trajectory(curving)
    assert len(fig.axes) == 2
    above = fig.axes[1]
    (lines,) = [c for c in above.collections if isinstance(c, LineCollection)]
    starts = np.array([seg[0] for seg in lines.get_segments()])
    assert np.array_equal(starts, curving.body.position[:-1, :2])
    marks = [line for line in above.lines if line.get_marker() == "o"]
    assert [float(m.get_xdata()[0]) for m in marks] == [s.touchdown_x for s in curving.skips]
    assert len(figure_trajectory(run).axes) == 1


def test_each_contact_panel_gives_its_peak_against_the_bounce_level(run):
    """Each contact panel is titled with the contact's peak, the water's largest vertical force over
    the stone's weight (the stage monitor's SkipRecord.peak_g, within 1%), and draws the 4 M g level
    above which a disk bounces (Tang et al. 2021)."""
    import re

    fig = figure_contacts(run)
    visible = [ax for ax in fig.axes if ax.get_visible()]
    for ax, skip in zip(visible, sorted(run.skips, key=lambda s: s.index), strict=True):
        shown = float(re.search(r"peak ([0-9.]+) g", ax.get_title()).group(1))
        assert shown == pytest.approx(skip.peak_g, rel=0.01, abs=0.05)
        levels = [line for line in ax.lines if line.get_label().startswith("4 M g")]
        assert len(levels) == 1 and levels[0].get_ydata()[0] == pytest.approx(4.0 * run.body.mass * 9.81)


@pytest.mark.parametrize("kept", ["/stone/*", "/stone/*,/stages/*"])
def test_a_recording_without_contact_channels_says_so_rather_than_that_nothing_touched(tmp_path, capsys, kept):
    """A run recorded with only the stone's channels (--record '/stone/*') did touch the water: the
    contacts figure is skipped because the channels are not in the recording, and plot says that
    (it said 'no contact in this run'); with the monitor's skip records kept too, it drew a figure
    of empty panels."""
    scene = Path(__file__).resolve().parents[1] / "scenarios" / "skip.yaml"
    out = tmp_path / "part.mcap"
    assert main(["run", str(scene), "--until", "0.1", "-o", str(out), "--record", kept, "-q"]) == 0
    capsys.readouterr()
    assert main(["plot", str(out), "-o", str(tmp_path / "figs")]) == 0
    said = capsys.readouterr().out
    assert "skipped contacts.png: the recording holds no contact channel (WaterContact or GroundContact)" in said
    assert "no contact in this run" not in said


def test_a_thinned_recordings_contact_peaks_are_the_monitors(tmp_path):
    """With one message in ten recorded, the contacts' own samples miss their peaks: each skip's
    panel is titled with the peak its skip record gives (the monitor saw every step), as the run's
    summary says (it said 13.8 g for 14.3)."""
    from components.analysis.plot import figure_contacts

    path = tmp_path / "thin.mcap"
    record_skip(path, ["record.visual_rate=0", "record.every=10"])
    thinned = load_run(path)
    assert thinned.skips
    titles = [ax.get_title() for ax in figure_contacts(thinned).axes if ax.get_visible()]
    for record, title in zip(thinned.skips, titles, strict=False):
        assert title.endswith(f", peak {record.peak_g:.1f} g"), (title, record.peak_g)


def test_a_thinned_recordings_last_contact_going_on_at_the_end_is_said_to(tmp_path):
    """The reference skip recorded one message in ten: the glide it ends in (sinking) still goes on
    at the end, though the coupler's last kept report comes before the stone's last kept state; it
    was titled as a contact that ended there ("1035.5 ms", where the whole recording says
    "1039.5 ms+ (to the run's end)")."""
    from components.analysis.plot import figure_contacts
    from cosim.runner import run_scene
    from cosim.scenario import load

    path = tmp_path / "thin.mcap"
    scene = load(Path(__file__).resolve().parents[1] / "scenarios" / "skip.yaml",
                 overrides=["record.visual_rate=0", "record.every=10", "record.checkpoint_every=0"])
    assert run_scene(scene, path, progress=False).result.status == "stopped"
    thinned = load_run(path)
    assert thinned.contacts[0].t[-1] < thinned.body.t[-1] and thinned.contacts[0].wetted[-1]
    titles = [ax.get_title() for ax in figure_contacts(thinned).axes if ax.get_visible()]
    assert len(titles) == len(thinned.skips) + 1 and "ms+ (to the run's end)" in titles[-1]
    assert not any("+" in title for title in titles[:-1])


def test_the_energy_budget_of_ground_bounces_closes_at_every_impact(tmp_path):
    """The ground's impulse reaches the body a step later, over a delayed edge: the energy the ground
    reports as dissipated is counted from the body's next state, and the total stays put through each
    bounce (it jumped by half at every impact, the loss counted a step before the body lost it),
    also in a recording that keeps one message in ten."""
    from components.analysis.plot import energy_terms
    from cosim.runner import run_scene
    from cosim.scenario import load

    for kept in ("record.every=1", "record.every=10"):  # every state, and one message in ten
        scene = load(Path(__file__).resolve().parents[1] / "scenarios" / "ground_bounce.yaml",
                     ["until=0.6", "record.visual_rate=0", kept])
        run_scene(scene, tmp_path / "bounce.mcap", progress=False)
        run = load_run(tmp_path / "bounce.mcap")
        terms = energy_terms(run)
        assert any(name.startswith("dissipated by ground") and values[-1] > 0.01 for name, values in terms.items())
        total = terms["total"]
        assert np.ptp(total) < 0.01 * total[0], kept


def test_the_energy_budget_takes_off_the_work_of_a_wrench_that_is_no_waters(tmp_path):
    """A push from outside the water (a gust's wrench) does work on the body that no dissipation
    counts: it is a term of its own, and the total stays put (it fell by 12% over the gust skip)."""
    from components.analysis.plot import energy_terms
    from cosim.runner import run_scene
    from cosim.scenario import load

    pytest.importorskip("fmpy")
    scene = load(Path(__file__).resolve().parents[1] / "scenarios" / "gust_skip.yaml", ["record.visual_rate=0"])
    run_scene(scene, tmp_path / "gust.mcap", progress=False)
    terms = energy_terms(load_run(tmp_path / "gust.mcap"))
    assert abs(terms["work done on it by /gust/wrench, taken off"][-1]) > 0.1  # [J]
    total = terms["total"]
    assert np.ptp(total) < 0.02 * total[0]


def test_a_scene_with_nothing_to_touch_is_said_so_not_that_its_recording_left_contacts_out(tmp_path, capsys):
    scene = Path(__file__).resolve().parents[1] / "scenarios" / "spinning_disk.yaml"
    assert main(["run", str(scene), "--until", "0.05", "-o", str(tmp_path / "spin.mcap"), "-q"]) == 0
    capsys.readouterr()
    assert main(["plot", str(tmp_path / "spin.mcap"), "-o", str(tmp_path / "figs")]) == 0
    assert "skipped contacts.png: the scene has neither water nor ground to touch" in capsys.readouterr().out


def test_a_restarts_first_states_are_in_the_stage_its_checkpoint_held(tmp_path):
    """A restart's monitor is restored, not started, so it publishes no stage until the next change:
    the states from the checkpoint to that change are in the stage the checkpoint held (fly-away at
    0.2 s here), not in the change's (approach at 0.221 s). (Plots and rendered frames read them alike.)"""
    from components.analysis.plot import stage_per_sample

    original = tmp_path / "run.mcap"
    record_skip(original, ["record.visual_rate=0", "record.checkpoint_every=0.1"])
    whole = load_run(original)
    assert main(["replay", str(original), "--from", "0.2", "-o", str(tmp_path / "restart.mcap"), "-q"]) == 0
    restart = load_run(tmp_path / "restart.mcap")
    assert restart.stages.t[0] == 0.2 and restart.stages.label[0] == "fly-away"
    early = restart.body.t < 0.221
    assert early.sum() == 20
    assert np.all(stage_per_sample(restart)[early] == StageId.FLY_AWAY)
    assert np.array_equal(stage_per_sample(restart), whole.stages.at(restart.body.t))


def test_a_path_along_y_is_seen_from_its_side_and_a_ground_impact_lasts_its_step(tmp_path):
    """A tilted disk dropped on a floor slides off along y (some 8 cm) and never moves in x: its side
    view is y-z, not a vertical line over a constant x, and the view from above is not added. A
    ground impact reported in one step is a contact of that step (0.5 ms), not of 0 ms."""
    from components.analysis.plot import figure_contacts, from_above
    from cosim.runner import run_scene
    from cosim.scenario import load

    scene = Path(__file__).resolve().parents[1] / "scenarios" / "ground_bounce.yaml"
    path = tmp_path / "bounce.mcap"
    run_scene(load(scene, ["until=0.4", "record.visual_rate=0"]), path, progress=False)
    tilted = load_run(path, "disk_tilted")
    assert np.ptp(tilted.body.position[:, 0]) == 0.0 and np.ptp(tilted.body.position[:, 1]) > 0.05
    ax = figure_trajectory(tilted).axes[0]
    assert ax.get_xlabel() == "y [m]" and not from_above(tilted)
    (lines,) = [c for c in ax.collections if isinstance(c, LineCollection)]
    starts = np.array([seg[0] for seg in lines.get_segments()])
    assert np.array_equal(starts, tilted.body.position[:-1][:, [1, 2]])
    flat = load_run(path, "disk_flat")
    titles = [a.get_title() for a in figure_contacts(flat).axes if a.get_visible()]
    assert titles and all(t.endswith(", 0.5 ms") for t in titles), titles


def test_a_restarts_contacts_are_numbered_as_its_skips(tmp_path):
    """A restart after the first skip: its first contact panel is that of skip 2, as the trajectory's
    marks and the summary number it (it said contact 1)."""
    from components.analysis.plot import figure_contacts

    original = tmp_path / "run.mcap"
    record_skip(original, ["record.visual_rate=0", "record.checkpoint_every=0.1"])
    assert main(["replay", str(original), "--from", "0.2", "-o", str(tmp_path / "restart.mcap"), "-q"]) == 0
    restart = load_run(tmp_path / "restart.mcap")
    assert [r.index for r in restart.skips] == [2, 3]
    titles = [a.get_title() for a in figure_contacts(restart).axes if a.get_visible()]
    assert titles[0].startswith("contact 2: t = 0.3120 s") and titles[1].startswith("contact 3: t = 0.4900 s")


RAISED_PINE = ["until=0.05", "record.visual_rate=0", "components.pine_pond.rest_level=0.5",
               "components.pine_water.water_level=0.5", "components.pine.position=[0,0,0.53]"]


def test_the_water_line_is_the_level_of_the_bodys_own_water(tmp_path):
    """Two ponds at two levels (float_sphere with the pine's pond raised to z = 0.5 m): each body's
    water line is its own pond's level. Before, every body got the first pond's by name
    (/granite_pond/patch, z = 0), and the pine's water line was drawn 0.5 m under its water."""
    from cosim.runner import run_scene
    from cosim.scenario import load

    scene = Path(__file__).resolve().parents[1] / "scenarios" / "float_sphere.yaml"
    path = run_scene(load(scene, RAISED_PINE), tmp_path / "raised.mcap", progress=False).recording
    pine, granite = load_run(path, "pine"), load_run(path, "granite")
    assert (pine.rest_level, granite.rest_level) == (0.5, 0.0)
    (water_line,) = [line for line in figure_trajectory(pine).axes[0].lines if line.get_label() == "water level"]
    assert list(water_line.get_ydata()) == [0.5, 0.5]


def test_the_water_level_is_the_scenes_when_the_patches_were_not_recorded(tmp_path):
    """A --record leaving out the ponds' patches: each level is what the recorded scene gives that
    water (the pine's pond at 0.5 m; a water alone at 0.5 m), not 0 (the water line was drawn half a
    metre under the pine's water, and a water-alone frame said "crest +501.46 mm")."""
    from components.analysis.data import rest_level, water_rest_level
    from cosim.record.reader import Recording
    from cosim.runner import run_scene
    from cosim.scenario import load, loads

    scene = Path(__file__).resolve().parents[1] / "scenarios" / "float_sphere.yaml"
    path = run_scene(load(scene, [*RAISED_PINE, "until=0.05", "record.channels=['/pine/*', '/granite/*', "
                                  "'/pine_pond/field']"]), tmp_path / "raised.mcap", progress=False).recording
    rec = Recording(path)
    assert not any(topic.endswith("/patch") for topic in rec.channels)
    assert (rest_level(rec, "pine"), rest_level(rec, "granite"), water_rest_level(rec, "/pine_pond/field")) == \
        (0.5, 0.0, 0.5)
    alone = loads("dt: 0.001\nuntil: 0.01\ncomponents:\n  pond: {type: WaterSurface, nx: 8, ny: 8, rest_level: 0.5, "
                  "field_rate: 1000}\nrecord: {channels: ['/pond/field']}\n")
    rec = Recording(run_scene(alone, tmp_path / "alone.mcap", progress=False).recording)
    assert (rest_level(rec), water_rest_level(rec, "/pond/field")) == (0.5, 0.5)


def test_contacts_after_the_last_skip_are_the_monitors_not_each_wetted_span(run):
    """After the last skip, wetted spans split only by a dry moment in which the stage monitor never
    had the stone airborne (approach, fly-away) are one contact, as the monitor counts it: the glide
    at the end of a throw is one long contact (docs/stages.md). Before, held_skip's final glide was
    drawn as two contacts, 78 ms from 0.758 s and 1392 ms from 0.847 s."""
    import dataclasses

    from components.analysis.data import ContactTrack, StageTrack

    last = max(run.skips, key=lambda s: s.index)
    t0 = float(last.touchdown_time + last.contact_time)  # the last fly-away
    t = t0 + 0.001 * np.arange(400)
    wetted = np.zeros(len(t), dtype=bool)
    glide, flicker, hop = (100, 150), (153, 220), (300, 320)  # (first, past the last) sample of each
    for a, b in (glide, flicker, hop):
        wetted[a:b] = True
    zeros = np.zeros((len(t), 3))
    contact = ContactTrack("/coupler/contact", t, wetted, wetted.astype(float), zeros, zeros, zeros, zeros,
                           np.zeros(len(t)), np.zeros(len(t)))
    # fly-away, approach, hit at the glide, slide through its dry flicker, fly-away and approach
    # before the hop, hit at the hop
    changes = [(t0, StageId.FLY_AWAY), (t[50], StageId.APPROACH), (t[100], StageId.HIT), (t[130], StageId.SLIDE),
               (t[160], StageId.HIT), (t[240], StageId.FLY_AWAY), (t[270], StageId.APPROACH), (t[300], StageId.HIT)]
    stages = StageTrack("/stages/stage", np.array([c for c, _ in changes]), np.array([int(s) for _, s in changes]),
                        [s.name for _, s in changes], np.zeros(len(changes), dtype=int))
    glided = dataclasses.replace(run, contacts=[contact], stages=stages)
    after = contact_intervals(glided)[len(run.skips):]
    assert after == [(t[glide[0]], t[flicker[1]]), (t[hop[0]], t[hop[1]])]
    # without a stage monitor, every wetted span is a contact
    assert len(contact_intervals(dataclasses.replace(glided, stages=None))[len(run.skips):]) == 3


def test_a_figure_name_taken_by_a_folder_is_bad_input_and_writes_nothing(skip_path, tmp_path, capsys):
    """`cosim plot -o DIR` where DIR/trajectory.png is a folder: exit 2, one line naming it, and no
    figure written. Before, it failed as 'Is a directory' after motion.png and energy.png were
    written, a partial set."""
    out = tmp_path / "pdir"
    (out / "trajectory.png").mkdir(parents=True)
    assert main(["plot", str(skip_path), "-o", str(out), "--dpi", "30"]) == 2
    err = capsys.readouterr().err.strip()
    assert err == (f"error: {out / 'trajectory.png'}: is a folder, where cosim plot writes its figure "
                   "trajectory.png (remove it or choose another folder, -o DIR)")
    assert [p.name for p in out.iterdir()] == ["trajectory.png"]


def test_figures_are_put_in_place_all_or_none(skip_path, tmp_path):
    """A figure that cannot be put in place (its name taken by a folder) takes back those already
    moved: the figures of an earlier plot are as they were, no new one is left, nor any temporary
    file. Before, the figures moved before the failing one stayed, a set that looked finished."""
    out = tmp_path / "figs"
    out.mkdir()
    for name in ("motion.png", "contacts.png"):  # one moved before the failing figure, one after
        (out / name).write_bytes(b"an earlier plot's")
    (out / "energy.png").mkdir()
    with pytest.raises(IsADirectoryError) as failed:
        plot_run(skip_path, out, dpi=30)
    assert failed.value.filename == str(out / "energy.png")
    assert sorted(p.name for p in out.iterdir()) == ["contacts.png", "energy.png", "motion.png"]
    assert (out / "motion.png").read_bytes() == (out / "contacts.png").read_bytes() == b"an earlier plot's"
    (out / "energy.png").rmdir()
    written, _ = plot_run(skip_path, out, dpi=30)
    assert sorted(p.name for p in out.iterdir()) == sorted(p.name for p in written) == [
        "contacts.png", "energy.png", "motion.png", "trajectory.png"]
    assert (out / "motion.png").read_bytes()[:4] == b"\x89PNG"


def test_a_figure_this_plot_does_not_draw_is_not_left_from_an_earlier_one(skip_path, tmp_path):
    """The same folder plotted from a recording with contacts, then from one holding only the
    stone's state (--record): its contacts figure is skipped, and the earlier recording's, left
    beside the new set, looked part of it. It is removed, and said."""
    from cosim.runner import run_scene
    from cosim.scenario import loads
    from tests.viewer_toys import SKIP_SCENE

    out = tmp_path / "figs"
    plot_run(skip_path, out, dpi=30)
    assert (out / "contacts.png").is_file()
    stone_only = tmp_path / "stone_only.mcap"
    run_scene(loads(SKIP_SCENE, overrides=["record.visual_rate=0", "record.channels=['/stone/*']"]), stone_only,
              progress=False)
    written, skipped = plot_run(stone_only, out, dpi=30)
    assert sorted(p.name for p in out.iterdir()) == sorted(p.name for p in written) == [
        "energy.png", "motion.png", "trajectory.png"]
    assert skipped == [("contacts.png", "the recording holds no contact channel (WaterContact or GroundContact); "
                                        "the contacts.png there from an earlier plot removed")]
    # one made read-only is left, and said (as a figure drawn is not put over it); a water-alone
    # recording's figure is another recording's too
    import stat
    (out / "contacts.png").write_bytes(b"mine")
    (out / "contacts.png").chmod(stat.S_IRUSR)
    (out / "water.png").write_bytes(b"an earlier plot's")
    _, skipped = plot_run(stone_only, out, dpi=30)
    assert skipped == [
        ("contacts.png", "the recording holds no contact channel (WaterContact or GroundContact); the "
                         "contacts.png (read-only) there from before left as it is"),
        ("water.png", "drawn for a recording of water alone; the water.png there from an earlier plot removed")]
    assert (out / "contacts.png").read_bytes() == b"mine" and not (out / "water.png").exists()

def test_the_attack_angle_is_measured_along_the_motion_nose_up_positive():
    """A disk tilted 20 deg about y (its leading edge up when it moves along +x): +20 moving along +x,
    -20 moving along -x (nose down), about 0 moving along y (the lean across the path) where the
    recorded tilt says 20; straight down, and for a sphere, the recorded tilt."""
    from components.analysis.data import attack_along_motion

    half = np.radians(-20.0) / 2  # about y, negative: the axis leans back, towards -x
    q = np.array([[np.cos(half), 0.0, np.sin(half), 0.0]] * 5)
    v = np.array([[3.0, 0.0, -1.0], [-3.0, 0.0, -1.0], [0.0, 3.0, -1.0], [0.0, 0.0, -1.0], [3.0, 0.0, 0.0]])
    tilt = np.array([20.0, 20.0, 20.0, 20.0, 0.0])
    assert np.allclose(attack_along_motion(q, v, tilt), [20.0, -20.0, 0.0, 20.0, 0.0], atol=1e-9)
    # the same face upside down (turned 160 deg about y: its axis points down and forward): alike
    flip = np.radians(160.0) / 2
    upside_down = np.array([[np.cos(flip), 0.0, np.sin(flip), 0.0]] * 5)
    assert np.allclose(attack_along_motion(upside_down, v, tilt), [20.0, -20.0, 0.0, 20.0, 0.0], atol=1e-9)


def test_a_contact_the_recording_ends_in_is_titled_as_lasting_at_least_that(run, tmp_path, monkeypatch):
    """A run that ends (or is cut off) inside a contact: that contact's length is only where the
    recording stops, and its title says so (a killed run's last contact read as a 444 ms contact).
    A recording without a final status is warned of."""
    import dataclasses

    start = contact_intervals(run)[1][0]
    path = tmp_path / "short.mcap"
    record_skip(path, ["record.visual_rate=0", f"until={round(start + 0.01, 3)}"])
    short = load_run(path)
    titles = [ax.get_title() for ax in figure_contacts(short).axes if ax.get_visible()]
    assert len(titles) == 2 and "+" not in titles[0] and "ms+ (to the run's end)" in titles[1]
    cut = dataclasses.replace(short, cut_off=True)
    assert "ms+ (cut off)" in [ax.get_title() for ax in figure_contacts(cut).axes if ax.get_visible()][1]
    monkeypatch.setattr(Recording, "status", lambda self: None)
    cut_off = "the recording is incomplete: its run was cut off"
    with pytest.warns(UserWarning, match=f"{cut_off}.* the figures end") as caught:
        plot_run(path, tmp_path / "figs", dpi=40)
    assert {w.filename for w in caught} == {__file__}  # named where plot_run was called
    from components.analysis.render import RenderOptions, render

    with pytest.warns(UserWarning, match=f"{cut_off}.* the frames end") as caught:
        render(path, tmp_path / "frame.png", RenderOptions(at=0.1, width=200, progress=False))
    assert __file__ in {w.filename for w in caught}  # named where render was called


@pytest.mark.parametrize(("status", "said"), [("interrupted", "its run was interrupted at t = 0.05 s"),
                                              ("failed", "its run failed at t = 0.05 s")])
def test_figures_and_frames_of_a_run_ended_early_say_so(skip_path, tmp_path, monkeypatch, status, said):
    """Only a recording with no final status was warned of: the figures of an interrupted (Ctrl-C)
    or failed run carried no mark that the run ended before its scene did."""
    from components.analysis.render import RenderOptions, render
    from cosim.record.recorder import RunStatus

    monkeypatch.setattr(Recording, "status", lambda self: RunStatus(status, "why", 100, 0.05, 300))
    with pytest.warns(UserWarning, match=f"{said} \\(why\\), and the figures end there") as caught:
        plot_run(skip_path, tmp_path / "figs", dpi=40)
    assert __file__ in {w.filename for w in caught}  # named where plot_run was called
    with pytest.warns(UserWarning, match=f"{said} \\(why\\), and the frames end there"):
        render(skip_path, tmp_path / "frame.png", RenderOptions(at=0.1, width=200, progress=False))


def test_the_trajectorys_legend_names_the_water_level_beside_the_stages(run):
    """With a stage monitor the legend was the stages' alone: the dashed water line (and a ground's
    contact markers) went unexplained."""
    labels = [t.get_text() for t in figure_trajectory(run).axes[0].get_legend().get_texts()]
    assert "water level" in labels and "approach" in labels


def test_a_turn_too_small_to_show_is_plus_zero_in_the_view_from_above(run):
    """The run's summary rounds a heading before its sign (+0.0 deg); the view from above printed the
    gust skip's first, -0.04 deg, as -0.0 deg."""
    import dataclasses
    import warnings

    from matplotlib.figure import Figure

    from components.analysis.plot import _draw_from_above

    turned = dataclasses.replace(run, skips=[dataclasses.replace(run.skips[0], heading_deg=-0.04)])
    ax = Figure().add_subplot()
    with warnings.catch_warnings():  # this straight throw has no sideways spread to scale y to
        warnings.simplefilter("ignore", UserWarning)
        _draw_from_above(ax, turned, "0.5")
    assert [t.get_text() for t in ax.texts] == ["+0.0 deg"]


def test_the_contacts_legend_is_below_the_panels_not_over_a_force_peak(run):
    """In the first panel (loc="best") the legend hid the reference skip's 79 N peak."""
    fig = figure_contacts(run)
    assert fig.axes[0].get_legend() is None
    assert len(fig.legends) == 1 and "pressure z" in [t.get_text() for t in fig.legends[0].get_texts()]


def test_stages_are_dated_when_they_began_and_never_run_backwards():
    """Each stage from its message's since (rest 20 ms before its publication), else the message's
    time; a restart's restored stage, dated at its checkpoint (40 ms), is followed by a rest whose spell
    began at 33 ms: dated 40 ms, not before the change ahead of it (plot's spans came out negative)."""
    import math

    from components.analysis.data import stage_times
    from components.messages import Stage, StageId

    pairs = [(40_000_000, Stage(StageId.GROUND, "ground", 0, 0.0, 0.0)),
             (53_000_000, Stage(StageId.REST, "rest", 0, 0.0, 0.0, 0.033))]
    assert stage_times(pairs).tolist() == [0.04, 0.04]
    pairs = [(500_000, Stage(StageId.APPROACH, "approach", 0, 0.0, 0.0, 0.0)),
             (700_000_000, Stage(StageId.REST, "rest", 0, 0.0, 0.0, 0.68)),
             (800_000_000, Stage(StageId.SINK, "sink", 0, 0.0))]
    assert stage_times(pairs).tolist() == [0.0, 0.68, 0.8] and math.isnan(pairs[2][1].since)


MARS = ["components.stone.gravity=[0,0,-3.71]", "components.coupler.g=3.71", "components.stages.gravity=3.71"]


def test_a_contacts_peak_and_bounce_level_are_in_the_bodys_own_gravity(tmp_path):
    """The held skip on Mars (g = 3.71 m/s^2) to 0.11 s, in its first contact (no skip record yet):
    the bounce level is 4 M g at the body's gravity (1.85 N, not 4.90 N at 9.81) and the peak in the
    title is the water's largest vertical force over that weight. A scripted body, which tells no
    gravity, takes its stage monitor's."""
    import re

    from cosim.runner import run_scene
    from cosim.scenario import load

    scene = Path(__file__).resolve().parents[1] / "scenarios" / "held_skip.yaml"
    path = run_scene(load(scene, ["until=0.11", "record.visual_rate=0", *MARS]), tmp_path / "mars.mcap",
                     progress=False).recording
    mars = load_run(path)
    assert not mars.skips
    panel = figure_contacts(mars).axes[0]
    (level,) = [line for line in panel.lines if line.get_label().startswith("4 M g")]
    weight = mars.body.mass * 3.71  # [N]
    assert level.get_ydata()[0] == pytest.approx(4.0 * weight, rel=1e-12)
    (start, end), c = contact_intervals(mars)[0], mars.contacts[0]
    during = (c.t >= start) & (c.t <= end)
    peak = float((c.buoyancy + c.pressure + c.friction + c.wave_drag)[during, 2].max()) / weight
    assert panel.get_title().endswith(f", peak {peak:.1f} g")
    assert float(re.search(r"peak ([0-9.]+) g", panel.get_title()).group(1)) > 20.0  # (about 22.7 at 9.81)
    record_skip(tmp_path / "toy.mcap", ["record.visual_rate=0", "until=0.15", "components.stages.gravity=3.71"])
    assert load_run(tmp_path / "toy.mcap").gravity == 3.71


def test_the_energy_figure_does_not_say_it_leaves_out_what_a_recorded_wrench_books(tmp_path):
    """The held skip recorded without its coupler's reports but with its wrench: the total books that
    wrench's work on the stone, the coupler's dissipation, and the title says nothing is left out (it
    said "the total leaves out coupler's dissipation (not recorded)")."""
    from cosim.runner import run_scene
    from cosim.scenario import load

    scene = Path(__file__).resolve().parents[1] / "scenarios" / "held_skip.yaml"
    kept = "record.channels=['/stone/*', '/stages/*', '/coupler/wrench']"
    path = run_scene(load(scene, ["until=0.11", "record.visual_rate=0", kept]), tmp_path / "wrench.mcap",
                     progress=False).recording
    run = load_run(path)
    assert "work done on it by /coupler/wrench, taken off" in energy_terms(run)
    assert run.unbooked == []
    assert "leaves out" not in figure_energy(run).axes[0].get_title()


TO_THE_FOURTH_CONTACT = ["record.visual_rate=0", "until=0.66"]  # the run ends in a contact after the last skip


def test_contacts_after_the_last_skip_are_drawn_without_the_couplers_reports(tmp_path):
    """The toy skip ending in a contact after its third (last) skip, recorded without the coupler's
    reports: contacts.png has that contact as the stage monitor's hit and slide say it, from its hit
    (it drew the three skips alone, without a word of the fourth)."""
    kept = "record.channels=['/stone/*', '/stages/*', '/coupler/wrench']"
    record_skip(tmp_path / "whole.mcap", TO_THE_FOURTH_CONTACT)
    record_skip(tmp_path / "part.mcap", [*TO_THE_FOURTH_CONTACT, kept])
    whole, part = load_run(tmp_path / "whole.mcap"), load_run(tmp_path / "part.mcap")
    assert not part.contacts and len(part.skips) == 3
    assert contact_intervals(part) == contact_intervals(whole) and len(contact_intervals(part)) == 4
    hit = float(part.stages.t[part.stages.stage == StageId.HIT][-1])
    assert contact_intervals(part)[3][0] == hit
    visible = [ax for ax in figure_contacts(part).axes if ax.get_visible()]
    assert len(visible) == 4 and visible[3].get_title().startswith(f"contact 4: t = {hit:.4f} s")


def test_a_thinned_recordings_contact_begins_at_the_monitors_hit(tmp_path):
    """With one message in ten kept, the contact after the last skip (no skip record dates it) began
    at the stage monitor's hit, kept whole (0.636 s), not at its first kept wetted report (0.641 s),
    as a whole recording dates it; without the monitor's stages, at that first wetted report."""
    import dataclasses

    record_skip(tmp_path / "thin.mcap", [*TO_THE_FOURTH_CONTACT, "record.every=10"])
    record_skip(tmp_path / "whole.mcap", TO_THE_FOURTH_CONTACT)
    thin, whole = load_run(tmp_path / "thin.mcap"), load_run(tmp_path / "whole.mcap")
    hit = float(thin.stages.t[thin.stages.stage == StageId.HIT][-1])
    c = thin.contacts[0]
    first_wet = float(c.t[(c.t > hit) & c.wetted][0])
    assert first_wet > hit  # (the case: the hit fell between two kept reports)
    assert contact_intervals(thin)[3][0] == hit == contact_intervals(whole)[3][0]
    assert contact_intervals(dataclasses.replace(thin, stages=None))[3][0] == first_wet
