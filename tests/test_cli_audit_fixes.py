"""What a command-line audit found: YAML merge keys, a restart past the scene's until, options that were
dropped or took an empty value, and messages untrue to their rule. Each is bad input said in one line
(exit 2, nothing written) or now works as asked."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
import yaml

from cosim.cli import main
from cosim.errors import ScenarioError
from cosim.scenario import load, loads, read_yaml
from tests.cli_toys import CHECKPOINTED_SCENE, DEMO_SCENE, one_error_line


def exit_code(argv: list[str]) -> int:
    """main's exit code, argparse's SystemExit included."""
    try:
        return main(argv)
    except SystemExit as exit_:
        return int(exit_.code or 0)


# --- 1. YAML merge keys ------------------------------------------------------------------------------

MERGES = """
fd: &fd {type: SolidGround, restitution: 0.7}
floor: {<<: *fd, mu_static: 0.6, restitution: 0.5}
two: {<<: [*fd, {type: X, z: 1}], a: 1}
nested: &n {<<: *fd, restitution: 0.1}
deeper: {<<: *n}
listed: [&q {<<: *fd, restitution: 0.2}]
from_list: {<<: *q}
"""


def test_merge_keys_read_as_the_yaml_merge_type_says():
    """`<<: *a` and `<<: [*a, *b]` merge (the first listed winning, as the YAML merge type has it:
    "keys in mapping nodes earlier in the sequence override keys specified in later mapping nodes"),
    a key written beside a merge overrides the merged one, and a mapping that merged and overrode is
    itself merged unchanged. PyYAML's safe loader reads the single merges alike; of a list of an alias
    and a mapping written in place, its 6.0.4 lets the last win (6.0.3 the first), so the list's case
    is held to the merge type itself, not to whichever PyYAML is installed."""
    data = read_yaml(MERGES, "m.yaml")
    single = {key: value for key, value in yaml.safe_load(MERGES).items() if key != "two"}
    assert {key: value for key, value in data.items() if key != "two"} == single
    assert data["floor"] == {"type": "SolidGround", "restitution": 0.5, "mu_static": 0.6}
    assert data["two"] == {"type": "SolidGround", "restitution": 0.7, "z": 1, "a": 1}
    assert data["deeper"] == {"type": "SolidGround", "restitution": 0.1}
    assert data["from_list"] == {"type": "SolidGround", "restitution": 0.2}


@pytest.mark.parametrize(("text", "said"), [
    ("a: {x: 1, x: 2}", "line 1: duplicate key 'x'"),
    ("a: &a {x: 1}\nb: {<<: *a, y: 1, y: 2}", "line 2: duplicate key 'y'"),
    ("a: &a {x: 1}\nb: {<<: *a, <<: *a}", "line 2: duplicate key '<<'"),
    ("a: {<<: 3}", "a merge (<<) takes a mapping or a list of mappings, found a scalar"),
])
def test_true_duplicates_and_bad_merges_are_still_refused(text, said):
    """A key written twice in one mapping (`<<` too) is a duplicate; a merge of no mapping is an error."""
    with pytest.raises(ScenarioError, match=re.escape(said)):
        read_yaml(text, "m.yaml")


def test_a_scene_shares_a_components_settings_through_a_merge_key():
    """A component written as `{<<: *g, gain: 3}` has the anchored one's type and its own gain."""
    scene = loads(DEMO_SCENE.replace('g: {type: "tests.toys:Gain"}', 'g: &g {type: "tests.toys:Gain", gain: 2}\n'
                                     '  g2: {<<: *g, gain: 3}'), source="merge.yaml")
    assert scene.components["g2"].type_name == scene.components["g"].type_name
    assert scene.components["g2"].params.gain == 3 and scene.components["g"].params.gain == 2


# --- 2. a restart after the scene's until ------------------------------------------------------------

@pytest.fixture
def demo(tmp_path):
    path = tmp_path / "demo.yaml"
    path.write_text(CHECKPOINTED_SCENE)  # until 0.05 s, a checkpoint every 0.01 s
    return path


def test_a_restart_after_the_scenes_until_runs_to_the_recorded_runs_end(demo, tmp_path, capsys):
    """A run made with --until 0.08 of a scene whose until is 0.05 s keeps its end with the recording:
    `replay --from 0.06` runs on to t = 0.08 s, not 0 s from 0.06."""
    rec = tmp_path / "long.mcap"
    assert main(["run", str(demo), "--until", "0.08", "-o", str(rec), "-q"]) == 0
    capsys.readouterr()
    assert main(["replay", str(rec), "--from", "0.06", "-o", str(tmp_path / "r.mcap"), "-q"]) == 0
    out = capsys.readouterr().out
    assert "demo: ok - reached t = 0.08 s" in out and "simulated 0.02 s from t = 0.06 s in 20 steps" in out
    # a restart's own --until is kept with its recording too
    assert main(["replay", str(rec), "--from", "0.06", "--until", "0.075", "-o", str(tmp_path / "r2.mcap"), "-q"]) == 0
    capsys.readouterr()
    assert main(["replay", str(tmp_path / "r2.mcap"), "--from", "0.07", "-o", str(tmp_path / "r3.mcap"), "-q"]) == 0
    assert "demo: ok - reached t = 0.075 s" in capsys.readouterr().out


def test_a_restart_of_no_time_is_refused_naming_both_times_and_writes_nothing(demo, tmp_path, capsys):
    """A recording that does not hold its run's --until (one made before it was kept, here by
    run_scene alone) restarted after the scene's until would simulate nothing: exit 2, one line naming
    --from and the end, no file."""
    from cosim.runner import run_scene

    rec = tmp_path / "old.mcap"
    run_scene(load(demo), rec, until_ns=80_000_000, progress=False)
    capsys.readouterr()
    assert main(["replay", str(rec), "--from", "0.06", "-q"]) == 2
    line = one_error_line(capsys.readouterr().err)
    assert "--from 0.06 s is not before the restarted run's end, the scene's until = 0.05 s" in line
    assert "went on to t = 0.08 s" in line and "give --until" in line
    assert sorted(p.name for p in tmp_path.iterdir()) == ["demo.yaml", "old.mcap"]


# --- 3. components --markdown ------------------------------------------------------------------------

@pytest.mark.parametrize(("target", "said"), [("", "got an empty one"), ("scene.yaml", "is not a .md file")])
def test_markdown_needs_a_md_file(tmp_path, capsys, monkeypatch, target, said):
    """--markdown '' crashed (internal error), and --markdown scene.yaml replaced the scene: exit 2, one line."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "scene.yaml").write_text(DEMO_SCENE)
    assert exit_code(["components", "--markdown", target]) == 2
    assert said in one_error_line(capsys.readouterr().err)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["scene.yaml"]
    assert (tmp_path / "scene.yaml").read_text() == DEMO_SCENE


def test_markdown_of_one_type_says_one_type(tmp_path, capsys):
    """`cosim components RigidBody --markdown F.md` says "1 component type", not "1 component types"."""
    page = tmp_path / "one.md"
    assert main(["components", "RigidBody", "--markdown", str(page)]) == 0
    assert capsys.readouterr().out.strip() == f"wrote {page}: 1 component type"


# --- 4. --no-record with the options of a recording --------------------------------------------------

@pytest.mark.parametrize("option", [["--record", "/g/*"], ["--record-every", "3"], ["--perf"]])
def test_no_record_with_an_option_of_the_recording_is_bad_input(demo, tmp_path, capsys, monkeypatch, option):
    """--no-record dropped --record, --record-every and --perf without a word: exit 2 naming both."""
    monkeypatch.chdir(tmp_path)
    assert exit_code(["run", str(demo), "--no-record", "-q", *option]) == 2
    line = one_error_line(capsys.readouterr().err)
    assert line.startswith(f"error: cosim run: --no-record and {' '.join(option)}: a run either records or does not")
    assert not list(tmp_path.glob("**/*.mcap"))


# --- 5. empty values ---------------------------------------------------------------------------------

@pytest.mark.parametrize("argv", [["plot", "{rec}", "-o", ""], ["bench", "accuracy", "{scene}", "-o", ""],
                                  ["replay", "{rec}", "--component", ""]])
def test_an_empty_option_value_is_bad_input(demo, tmp_path, capsys, monkeypatch, argv):
    """plot -o '' (the default folder), bench accuracy -o '' (the working folder) and replay
    --component '' (every component) took the empty text for something else: exit 2, one line."""
    rec = tmp_path / "demo.mcap"
    assert main(["run", str(demo), "-o", str(rec), "-q"]) == 0
    capsys.readouterr()
    monkeypatch.chdir(tmp_path)
    before = sorted(p.name for p in tmp_path.iterdir())
    assert exit_code([a.format(rec=rec, scene=demo) for a in argv]) == 2
    assert "expected a value, got an empty one" in one_error_line(capsys.readouterr().err)
    assert sorted(p.name for p in tmp_path.iterdir()) == before


# --- 6. record.checkpoint_every < 0 ------------------------------------------------------------------

def test_a_negative_checkpoint_interval_is_told_the_rule_that_allows_zero():
    """checkpoint_every: -1 is refused with the rule as it is (>= 0, 0 meaning none), not '> 0'."""
    with pytest.raises(ScenarioError, match=r"record\.checkpoint_every: must be >= 0 s \(0: no checkpoints\) "
                                            r"\(got -1\)"):
        loads(DEMO_SCENE + "record: {checkpoint_every: -1}\n")


# --- 7. bench accuracy without a skip ----------------------------------------------------------------

def test_the_accuracy_figure_of_a_study_without_skips_draws_no_empty_legend(tmp_path):
    """No run made a skip (no skip distance to plot): the figure has no legend, and matplotlib's "No
    artists with labels" warning (an error under this suite's filterwarnings) is not raised."""
    pytest.importorskip("matplotlib")
    from components.analysis.accuracy import Row, Study, Trace, Variant, figure

    t = np.linspace(0.0, 0.01, 5)
    trace = Trace(t, np.zeros((5, 3)), np.ones(5), 0, [], "approach", "ok", "", 0.01, [], [1.0])
    rows = [Row(Variant("reference", "reference"), trace, wall_ratio=2.0, trajectory=0.0, energy=0.0),
            Row(Variant("base step", "verlet, dt = 1 ms"), trace, wall_ratio=1.0, trajectory=1e-5, energy=1e-3)]
    assert all(math.isnan(r.distance) for r in rows)
    path = figure(Study("held.yaml", True, rows), tmp_path / "accuracy.png")
    assert path.stat().st_size > 0


def test_the_quick_help_says_the_scenes_until_bounds_it(capsys):
    """--quick runs min(0.4 s, the scene's until): its help says so, not a flat 0.4 s."""
    assert exit_code(["bench", "accuracy", "--help"]) == 0
    text = " ".join(capsys.readouterr().out.split())
    assert "smoke test: the first 0.4 s (or the scene's until, if sooner)" in text

