"""Sweep files: axes become points with stable ids and overrides; every bad file gets a clear message."""

from __future__ import annotations

import itertools
import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from cosim.errors import ScenarioError
from cosim.sweep import plan
from cosim.sweep.plan import Expression, load_sweep, loads_sweep, plain, point_id, yaml_value
from tests.sweep_toys import BALL_SCENE, write_sweep

GRID = """
scene: ball.yaml
axes:
  components.ball.angle_deg: {linspace: [30, 60, 3]}
  components.ball.speed: [2, 4]
set: {components.ball.restitution: 0.5}
until: 2.0
"""


def test_grid_is_the_product_of_the_axes_in_order(tmp_path):
    """A grid runs every combination, the first axis slowest; each point's overrides are the fixed
    ones (set, until) followed by its axis values, exactly as --set strings."""
    sweep = load_sweep(write_sweep(tmp_path, GRID))
    assert [p.values for p in sweep.points] == [{"components.ball.angle_deg": a, "components.ball.speed": s}
                                                for a in (30.0, 45.0, 60.0) for s in (2, 4)]
    assert [p.index for p in sweep.points] == list(range(6))
    assert sweep.points[1].overrides == ("components.ball.restitution=0.5", "until=2.0",
                                         "components.ball.angle_deg=30.0", "components.ball.speed=4")
    assert sweep.describe() == ("sweep: 6 points (grid of 3 components.ball.angle_deg x "
                                "2 components.ball.speed)")
    assert sweep.columns == ["index", "point_id", "components.ball.angle_deg", "components.ball.speed",
                             "status", "reason", "error_type", "sim_time_s", "ticks", "ball.bounces",
                             "ball.distance", "ball.outcome", "ball.first_bounce_time", "wall_s"]


@pytest.mark.parametrize(("spec", "values"), [
    ("{linspace: [0, 1, 5]}", [0.0, 0.25, 0.5, 0.75, 1.0]),
    ("{logspace: [0.001, 0.1, 3]}", [0.001, 0.01, 0.1]),
    ("{range: [1, 7, 2]}", [1, 3, 5]),
    ("[true, false]", [True, False]),
])
def test_grid_axis_forms(spec, values):
    """linspace, logspace (from a to b, not exponents), range (integers, stop excluded) and lists."""
    text = ("scene: {dt: 0.001, until: 0.01, components: {t: {type: 'tests.toys:Source'}}}\n"
            f"axes:\n  v: {spec}\nderived: {{components.t.start: 'v * 0'}}\n")
    got = [p.values["v"] for p in loads_sweep(text).points]
    assert got == pytest.approx(values, rel=1e-12) and [type(v) for v in got] == [type(v) for v in values]


def test_point_ids_depend_only_on_axis_values(tmp_path):
    """A point's id is a hash of its axis names and values: the same whatever its index, so a longer
    axis keeps the ids of the points it already had, and any other value gives another id."""
    short = load_sweep(write_sweep(tmp_path, GRID))
    longer = load_sweep(write_sweep(tmp_path, GRID.replace("[2, 4]", "[2, 3, 4]"), name="b.yaml"))
    assert {p.point_id for p in short.points} < {p.point_id for p in longer.points}
    assert point_id({"a": 1.0, "b": 2}) == point_id({"b": 2, "a": 1.0}) != point_id({"a": 1.0, "b": 3})
    assert len(point_id({"a": 0.1})) == 12 and point_id({"a": 0.1}) != point_id({"a": 0.1 + 1e-16 * 2})


def test_random_samples_repeat_with_the_seed(tmp_path):
    """Random mode draws `samples` points from `seed`: the same seed gives the same points, more
    samples keep the first ones, and each value lies in its range or list."""
    body = """
scene: ball.yaml
mode: random
samples: {n}
seed: 7
axes:
  components.ball.angle_deg: {{uniform: [10, 80]}}
  components.ball.speed: {{loguniform: [1, 10]}}
  components.ball.restitution: [0.3, 0.6]
"""
    a = load_sweep(write_sweep(tmp_path, body.format(n=20)))
    b = load_sweep(write_sweep(tmp_path, body.format(n=30), name="b.yaml"))
    assert [p.values for p in a.points] == [p.values for p in b.points[:20]]
    for p in b.points:
        assert 10 <= p.values["components.ball.angle_deg"] <= 80
        assert 1 <= p.values["components.ball.speed"] <= 10
        assert p.values["components.ball.restitution"] in (0.3, 0.6)
    c = load_sweep(write_sweep(tmp_path, body.format(n=20).replace("seed: 7", "seed: 8"), name="c.yaml"))
    assert [p.values for p in c.points] != [p.values for p in a.points]


def test_derived_values_come_from_variable_axes(tmp_path):
    """An axis that is not a key of the scene is a variable: `derived` computes overrides from it."""
    body = """
scene: ball.yaml
axes:
  launch: [30, 60]
derived:
  components.ball.angle_deg: "launch"
  components.ball.speed: "2 * sqrt(launch / 30) + cos(radians(90))"
"""
    sweep = load_sweep(write_sweep(tmp_path, body))
    speed = 2 * math.sqrt(2) + math.cos(math.pi / 2)
    assert sweep.points[1].overrides == ("components.ball.angle_deg=60",
                                         f"components.ball.speed={yaml_value(speed)}")
    assert Expression("[s * cos(radians(b)), 0, -s * sin(radians(b))]")({"s": 2.0, "b": 90.0}) == \
        [2.0 * math.cos(math.pi / 2), 0, -2.0]


def test_a_command_line_set_of_a_key_an_axis_or_derived_value_sets_is_refused(tmp_path):
    """--set on a key an axis or a derived expression sets at every point: refused, naming both (the
    point's value was applied after it, so it did nothing, while --dry-run listed it as applied);
    a --set of a key the file's set: gives overrides it, as documented."""
    body = """
scene: ball.yaml
axes:
  components.ball.speed: [2, 3]
  launch: [30, 60]
derived:
  components.ball.angle_deg: "launch"
set:
  components.ball.restitution: 0.5
"""
    path = write_sweep(tmp_path, body)
    for key, setter in (("components.ball.speed", "axes.components.ball.speed"),
                        ("components.ball.angle_deg", "derived.components.ball.angle_deg")):
        with pytest.raises(ScenarioError) as info:
            load_sweep(path, overrides=[f"{key}=1"])
        assert info.value.problems == [f"--set {key}: {setter} sets it at every point; a value given here "
                                       "would be ignored (leave it out, or change the sweep file)"]
    sweep = load_sweep(path, overrides=["components.ball.restitution=0.7"])
    assert sweep.points[0].overrides[:2] == ("components.ball.restitution=0.5", "components.ball.restitution=0.7")


def test_a_derived_expression_that_cannot_be_read_does_not_also_call_its_axis_unused(tmp_path):
    """A misspelled name in a derived expression is the one problem said; the axis it meant to use
    was also called "not used in derived"."""
    body = """
scene: ball.yaml
axes:
  launch: [30, 60]
derived:
  components.ball.angle_deg: "lanch"
  components.ball.speed: "2 + len([1])"
"""
    with pytest.raises(ScenarioError) as info:
        load_sweep(write_sweep(tmp_path, body))
    assert len(info.value.problems) == 2, info.value.problems
    assert "unknown name 'lanch'" in info.value.problems[0] and "len" in info.value.problems[1]


@pytest.mark.parametrize(("text", "message"), [
    ("__import__('os')", "unknown function '__import__'"),
    ("x.real", "'x.real' is not allowed"),
    ("lambda: 1", "is not allowed"),
    ("x if x else 1", "is not allowed"),
])
def test_expressions_admit_arithmetic_only(text, message):
    """Derived expressions evaluate numbers, names, arithmetic and math functions, nothing else."""
    with pytest.raises(ValueError, match=message):
        Expression(text)


@pytest.mark.parametrize("text", ["[a] * 100000000", "[a] + [a]", "2 * [a, a]"])
def test_a_list_in_an_expression_is_a_value_never_repeated_or_joined(text):
    """A list's items are computed; repeating or joining lists is refused (a repetition by 10^8 took a
    minute and ended out of memory)."""
    with pytest.raises(ValueError, match="a list can only be a value"):
        Expression(text)({"a": 1.0})
    assert Expression("[a * 2, 0, -a]")({"a": 1.5}) == [3.0, 0, -1.5]


@pytest.mark.parametrize(("text", "message"), [
    ("'ab' * 50000000 * u", r"'ab' \* 50000000: a text can only be a value, not repeated or joined"),
    ("u + 'x'", r"u \+ 'x': a text can only be a value"),
    ("'%0999999999d' % u", r"a text can only be a value"),
    ("round(u, -100000000)", r"round\(u, -100000000\): round's digits must be within \+-400 \(got -1e\+08\)"),
    ("round(u * 1.5, 1000)", r"round's digits must be within \+-400 \(got 1000\)"),
])
def test_an_expression_that_would_run_for_minutes_is_refused_at_once(text, message):
    """A text repeated or joined by arithmetic, and round() to more digits than any float has, are
    refused naming the expression and the bound ('ab' * 50000000 * u and round(u, -100000000) each
    ran for minutes); round within the bound still rounds."""
    with pytest.raises(ValueError, match=message):
        Expression(text)({"u": 3})
    assert Expression("round(u, -1)")({"u": 37}) == 40 and Expression("round(u, 400)")({"u": 0.5}) == 0.5


@pytest.mark.parametrize(("text", "message"), [
    ("+".join(["a"] * 1000), r"has more than 100 operations inside one another \(a sum of 102 terms is one\)"),
    ("+".join(["a"] * 1001), r"the expression is 2001 characters long \(at most 2000\)"),
    ("-" * 1990 + "a", r"(has more than 100 operations inside one another|nested too deeply to read)"),
    ("a" + "**a" * 120, r"has more than 100 operations inside one another"),
])
def test_an_expression_too_long_or_too_deep_to_read_is_a_problem_not_a_crash(text, message):
    """Python's parser and the checks recurse once per operator: a chain of 1,000 '+' ended the sweep
    in RecursionError and 50,000 '-' in MemoryError (exit 1). Now each is a ValueError naming the
    bound, which the sweep reports as the derived value's problem (exit 2); a sum of 90 terms and 150
    parentheses deep still read."""
    with pytest.raises(ValueError, match=message):
        Expression(text)
    assert Expression("+".join(["a"] * 90))({"a": 1.0}) == 90.0
    assert Expression("(" * 150 + "a" + ")" * 150)({"a": 2.0}) == 2.0


def test_a_complex_derived_value_is_named_as_complex(tmp_path):
    """A negative number to a fractional power is complex: its point's problem says so, naming the
    expression (it was a RepresenterError from the YAML writer)."""
    body = "scene: ball.yaml\naxes: {v: [4, -4]}\nderived: {components.ball.speed: 'v ** 0.5'}\n"
    sweep = load_sweep(write_sweep(tmp_path, body))
    assert sweep.points[0].problem is None
    assert sweep.points[1].problem.startswith(
        "derived.components.ball.speed: cannot evaluate 'v ** 0.5': ValueError: v ** 0.5 is the complex number (")
    assert sweep.points[1].problem.endswith("j), not a real value")


@pytest.mark.parametrize(("line", "problem"), [
    ('name: "run\\0s"', r"name: must not hold a NUL character \(got 'run\\x00s'\)"),
    ('output: "runs/a\\0b.csv"', r"output: must not hold a NUL character \(got 'runs/a\\x00b\.csv'\)"),
])
def test_a_nul_character_in_the_name_or_output_is_refused(tmp_path, line, problem):
    """A NUL in `name:` (the default table is runs/NAME.csv) or `output:` is bad input naming the key
    (no file name can hold it: an internal "embedded null byte" ValueError, and --dry-run said ok)."""
    with pytest.raises(ScenarioError, match=problem):
        load_sweep(write_sweep(tmp_path, f"scene: ball.yaml\naxes: {{components.ball.speed: [1, 2]}}\n{line}\n"))


def test_a_derived_value_that_fails_fails_its_point_only(tmp_path):
    """A math error at one point (sqrt of a negative) marks that point, not the sweep."""
    body = "scene: ball.yaml\naxes: {v: [4, -4]}\nderived: {components.ball.speed: 'sqrt(v)'}\n"
    sweep = load_sweep(write_sweep(tmp_path, body))
    assert sweep.points[0].problem is None
    assert sweep.points[1].problem == ("derived.components.ball.speed: cannot evaluate 'sqrt(v)': "
                                       "ValueError: math domain error")


def test_every_problem_is_reported_at_once_with_its_path(tmp_path):
    """Unknown keys, bad axis forms, grid-only and random-only settings, unused variables, unknown
    names and metrics that match nothing all come in one ScenarioError, each with its path."""
    body = """
scene: ball.yaml
colour: red
samples: 4
axes:
  components.ball.speed: {uniform: [1, 2]}
  components.ball.angle_deg: 45
  components.bal.speed: [1]
  speed2: [1, 2]
  components.ball.restitution: [0.5, 0.5]
derived: {components.ball.gravity: "g * 2", components.ball.burn: 3}
metrics: 7
output: results.txt
"""
    with pytest.raises(ScenarioError) as info:
        load_sweep(write_sweep(tmp_path, body))
    problems = info.value.problems
    expected = [
        "colour: unknown key",
        "samples: only for mode: random",
        "axes.components.ball.speed.uniform: is for mode: random",
        "axes.components.ball.angle_deg: expected a list of values",
        "axes.components.bal.speed: the scene has no key 'components.bal' (known there: ball)",
        "axes.components.ball.restitution: repeats a value",
        "derived.components.ball.gravity: unknown name 'g'",
        "derived.components.ball.burn: must be an expression in quotes",
        "axes.speed2: not a key of the scene",
        "metrics: must be a list",
        "output: must be a .csv or .parquet file name",
    ]
    for line in expected:
        assert any(p.startswith(line) for p in problems), (line, problems)
    assert len(problems) == len(expected)


def test_the_first_point_is_validated_before_anything_runs(tmp_path):
    """A parameter the component does not have, or a value it rejects, is reported with the point."""
    with pytest.raises(ScenarioError, match=r"the first point \(components\.ball\.sped=1\): "
                                            r"components\.ball\.sped: unknown key; did you mean 'speed'\?"):
        load_sweep(write_sweep(tmp_path, "scene: ball.yaml\naxes: {components.ball.sped: [1, 2]}\n"))
    with pytest.raises(ScenarioError, match=r"components\.ball\.restitution: must be <= 1 \(got 1\.5\)"):
        load_sweep(write_sweep(tmp_path, "scene: ball.yaml\naxes: {components.ball.restitution: [1.5, 1]}\n"))


def test_an_invalid_value_of_an_override_axis_is_refused_wherever_it_is(tmp_path):
    """Each value of an override axis is loaded with the other axes at their first values: one that
    makes no scene is a problem of the sweep file naming the axis, wherever it stands (only the first
    point's was: `[0.5, 1.5]` ran, its second point a failed row, and the sweep exited 0); every such
    value is named at once."""
    body = ("scene: ball.yaml\naxes:\n  components.ball.speed: [2, -1]\n"
            "  components.ball.restitution: [0.5, 1.5, 0.6, 2]\n  components.ball.angle_deg: [30, 60]\n")
    with pytest.raises(ScenarioError) as refused:
        load_sweep(write_sweep(tmp_path, body))
    assert refused.value.problems == [
        "axes.components.ball.speed: -1 makes an invalid scene (the other axes at their first values): "
        "components.ball.speed: must be >= 0 m/s (got -1)",
        "axes.components.ball.restitution: 1.5 makes an invalid scene (the other axes at their first values): "
        "components.ball.restitution: must be <= 1 (got 1.5)",
        "axes.components.ball.restitution: 2 makes an invalid scene (the other axes at their first values): "
        "components.ball.restitution: must be <= 1 (got 2)"]
    # in random mode, the values its points drew
    random = "mode: random\nsamples: 6\nscene: ball.yaml\naxes:\n  components.ball.restitution: {uniform: [0.5, 1.2]}\n"
    with pytest.raises(ScenarioError, match=r"axes\.components\.ball\.restitution: [0-9.]+ makes an invalid scene: "
                                            r"components\.ball\.restitution: must be <= 1"):
        load_sweep(write_sweep(tmp_path, random))


def test_a_value_invalid_only_beside_another_axis_first_value_is_no_refusal(tmp_path):
    """A value refused only for what it does with another axis's first value (a ball stepping every 2
    base steps beside its ground's every 1) is valid beside that axis's other values (both at 2): the
    sweep runs, its invalid combinations failed rows. The check refused the whole sweep."""
    scene = Path(__file__).resolve().parents[1] / "scenarios" / "ground_bounce.yaml"
    body = (f"scene: {scene}\nuntil: 0.01\naxes:\n  components.sphere.every: [1, 2]\n"
            "  components.floor_sphere.every: [1, 2]\n")
    sweep = load_sweep(write_sweep(tmp_path, body))
    assert [p.problem is None for p in sweep.points] == [True, True, True, True]  # (judged as each runs)


def test_the_values_checked_are_bounded_and_take_each_axis_ends(tmp_path, monkeypatch):
    """The check loads one scene a value, not one a point, and at most VALUES_CHECKED in all (about 10
    ms each): an axis of more values than its share is checked at values spread over it, its ends
    among them, and the values of a short axis are all checked."""
    loaded = []
    loads = plan.loads
    monkeypatch.setattr(plan, "loads", lambda *args: loaded.append(args) or loads(*args))
    monkeypatch.setattr(plan, "VALUES_CHECKED", 10)
    body = ("scene: ball.yaml\naxes:\n  components.ball.speed: {linspace: [2, 3, 50]}\n"
            "  components.ball.angle_deg: {linspace: [30, 60, 40]}\n  components.ball.restitution: [0.5, 0.6, 1.5]\n")
    with pytest.raises(ScenarioError) as refused:
        load_sweep(write_sweep(tmp_path, body))
    assert len(loaded) == 1 + 10  # the first point's scene, then the values
    assert any(p.startswith("axes.components.ball.restitution: 1.5 makes") for p in refused.value.problems)
    speeds = {o for *_, overrides in loaded[1:] for o in overrides if o.startswith("components.ball.speed=")}
    assert {"components.ball.speed=3.0", "components.ball.speed=2.0"} <= speeds  # (2.0: the others' first value)
    assert plan._shares([2, 50, 39], 10) == [2, 4, 4]
    assert plan._spread([1, 2, 3, 4, 5, 6, 7], 3) == [1, 4, 7]


def test_an_axis_over_a_top_level_key_the_scene_leaves_out_is_an_override(tmp_path):
    """An axis over a top-level key of a scene that the base scene does not give (on_unstable, at its
    default) varies that key, as `set:` and `--set` do (it was refused as no key of the scene)."""
    sweep = load_sweep(write_sweep(tmp_path, "scene: ball.yaml\naxes:\n  on_unstable: [error, substep]\n"))
    assert [a.kind for a in sweep.axes] == ["override"]
    assert [p.overrides for p in sweep.points] == [("on_unstable=error",), ("on_unstable=substep",)]
    with pytest.raises(ScenarioError, match=r"axes\.on_unstable: 'sometimes' makes an invalid scene: "
                                            r"on_unstable: must be one of"):
        load_sweep(write_sweep(tmp_path, "scene: ball.yaml\naxes:\n  on_unstable: [error, sometimes]\n"))


def test_scene_file_and_sweep_file_problems(tmp_path):
    """A missing scene, a missing sweep file, an empty one and a YAML error are bad input too."""
    with pytest.raises(ScenarioError, match=r"scene: 'nowhere\.yaml': no such file") as missing:
        load_sweep(write_sweep(tmp_path, "scene: nowhere.yaml\naxes: {dt: [0.001]}\n"))
    # that alone: without the scene, an axis is not also said to be no key of it
    assert missing.value.problems == [f"scene: 'nowhere.yaml': no such file (looked for {tmp_path / 'nowhere.yaml'})"]
    with pytest.raises(ScenarioError, match=r"missing\.yaml: no such file"):
        load_sweep(tmp_path / "missing.yaml")
    # a device read whole filled the memory: refused unread, as a scene given to `cosim run` is
    with pytest.raises(ScenarioError) as device:
        load_sweep(write_sweep(tmp_path, "scene: /dev/zero\naxes: {dt: [0.001]}\n"))
    assert device.value.problems == ["scene: '/dev/zero': is not a regular file (a device, pipe or socket)"]
    itself = write_sweep(tmp_path, "scene: sweep.yaml\naxes: {dt: [0.001]}\n")  # a sweep naming itself
    assert itself.name == "sweep.yaml"
    with pytest.raises(ScenarioError, match=r"scene: 'sweep\.yaml' is a sweep file \(it has axes and no "
                                            r"components\), not the scene a sweep varies"):
        load_sweep(itself)
    with pytest.raises(ScenarioError, match=r"a sweep must be a mapping with at least 'scene' and 'axes' "
                                            r"\(got nothing\)"):
        loads_sweep("")
    with pytest.raises(ScenarioError, match=r"YAML syntax error: line 2, column 1"):
        loads_sweep("axes: [\n")
    with pytest.raises(ScenarioError, match=r"line 3: duplicate key 'axes'"):
        loads_sweep("scene: a.yaml\naxes: {dt: [1]}\naxes: {dt: [2]}\n")


def test_inline_scene_metrics_and_figure_defaults(tmp_path):
    """An inline scene mapping works like a file; metrics keep the patterns' matches in order; the
    default figure shows the first numeric metric over the first two axes."""
    text = (f"scene: {yaml.safe_load(BALL_SCENE)}\n"
            "axes: {components.ball.speed: [1, 2], dt: [0.001, 0.002]}\n"
            "metrics: ['ball.d*', 'ball.bounces']\n")
    sweep = loads_sweep(text, source="inline.yaml")
    assert sweep.scene_source == "inline.yaml:scene"
    assert sweep.metrics == ["ball.distance", "ball.bounces"]
    figure = sweep.figure
    assert (figure.metric, figure.x, figure.y) == ("ball.distance", "components.ball.speed", "dt")
    with pytest.raises(ScenarioError, match=r"metrics: 'stages\.\*' matches no metric of the scene "
                                            r"\(its components report: ball\.bounces, ball\.distance"):
        loads_sweep(text.replace("'ball.d*'", "'stages.*'"))
    with pytest.raises(ScenarioError, match=r"figure\.metric: 'ball\.outcome' is text, not a number"):
        loads_sweep(text.replace("metrics: ['ball.d*', 'ball.bounces']", "figure: {metric: ball.outcome}"))
    with pytest.raises(ScenarioError, match=r"figure\.y: 'speed' is not an axis "
                                            r"\(axes: components\.ball\.speed, dt\)"):
        loads_sweep(text + "figure: {y: speed}\n")


@pytest.mark.parametrize("value", [0.1, 1e-05, 1e16, -2.5e-07, 5, True, "yes", "a: b", "1.0", [1.0, 0, 3e-20],
                                   {"a": [1, 2]}, None, math.pi])
def test_override_values_round_trip(value):
    """Each value is written as one line of YAML that parses back to the very same value."""
    text = yaml_value(value)
    assert "\n" not in text and yaml.safe_load(text) == value
    assert yaml.safe_load(yaml_value(math.nan)) != yaml.safe_load(yaml_value(math.nan))  # still a NaN


@pytest.mark.parametrize("value", [0.1, 1e-05, 1e22, 1e16, -2.5e-07, 5e-324, 1.5e300, -0.0, 10 ** 30, True, None,
                                   math.inf, -math.inf, [1.0, 0, [3e-20, False]], [], np.float64(2.5),
                                   np.arange(3.0)])
def test_numbers_are_written_as_the_yaml_dumper_writes_them(value):
    """Numbers and lists of them are written without the YAML dumper (a plan writes one per axis and
    derived key at every point), as the very text it gives: scenes and tables read them alike."""
    dumped = yaml.safe_dump(plain(value), default_flow_style=True, width=math.inf).removesuffix("\n...\n").strip()
    assert yaml_value(value) == dumped


def test_a_scene_given_as_a_sweep_says_so_in_one_line(tmp_path):
    """`cosim sweep` on a scene file: one problem naming the mix-up and the command that runs it, not
    every scene key a sweep does not know."""
    with pytest.raises(ScenarioError) as info:
        loads_sweep(BALL_SCENE, "ball.yaml", tmp_path)
    assert info.value.problems == ["a scene, not a sweep (it has components: and no axes:); run it with "
                                   "`cosim run ball.yaml`, or name it in a sweep's scene: key"]


HUGE = 10**18  # values no machine could hold: a sweep that built them would fail at once, not pass


@pytest.mark.parametrize(("body", "message"), [
    (f"axes: {{components.ball.speed: {{range: [0, {HUGE}, 1]}}}}",
     rf"axes\.components\.ball\.speed\.range: {HUGE} values is more than the 1000000 points a sweep may "
     rf"have \(got \[0, {HUGE}, 1\]\); check the start, stop and step"),
    (f"axes: {{components.ball.speed: {{linspace: [1, 2, {HUGE}]}}}}",
     rf"axes\.components\.ball\.speed\.linspace: {HUGE} values is more than the 1000000 points"),
    (f"axes: {{components.ball.speed: {{logspace: [1, 2, {HUGE}]}}}}",
     rf"axes\.components\.ball\.speed\.logspace: {HUGE} values is more than the 1000000 points"),
    ("axes: {components.ball.speed: {linspace: [1, 2, 2000]}, components.ball.angle_deg: "
     "{linspace: [10, 80, 2000]}}",
     r"axes: 4000000 points is more than 1000000 \(a grid of 2000 components\.ball\.speed x "
     r"2000 components\.ball\.angle_deg\); check the axis counts"),
    (f"mode: random\nsamples: {HUGE}\naxes: {{components.ball.speed: {{uniform: [1, 2]}}}}",
     rf"samples: {HUGE} points is more than 1000000; check the count"),
])
def test_a_sweep_too_large_is_refused_before_its_points_are_built(tmp_path, monkeypatch, body, message):
    """A huge range, linspace or logspace, a grid whose axes multiply past the limit, or a huge random
    sample count is refused from the counts alone: no value and no point is built first."""
    def no_points(*args, **kwargs):
        raise AssertionError("the points were built before the sweep's size was checked")

    monkeypatch.setattr(plan, "_points", no_points)
    with pytest.raises(ScenarioError, match=message) as info:
        load_sweep(write_sweep(tmp_path, f"scene: ball.yaml\n{body}\n"))
    assert len(info.value.problems) == 1


def test_the_point_limit_is_exact_and_counts_ranges_like_python(tmp_path, monkeypatch):
    """A sweep of exactly MAX_POINTS points runs; one more is refused, whichever axis or count makes
    it; a range counts its values as Python's range does (any step, stop excluded)."""
    monkeypatch.setattr(plan, "MAX_POINTS", 6)
    grid = "scene: ball.yaml\naxes: {components.ball.speed: %s, components.ball.angle_deg: [10, 20]}\n"
    assert len(load_sweep(write_sweep(tmp_path, grid % "{range: [9, 0, -3]}")).points) == 6
    with pytest.raises(ScenarioError, match=r"axes: 8 points is more than 6 \(a grid of 4 components\.ball"
                                            r"\.speed x 2 components\.ball\.angle_deg\)"):
        load_sweep(write_sweep(tmp_path, grid % "{range: [1, 8, 2]}"))
    with pytest.raises(ScenarioError, match=r"axes\.components\.ball\.speed\.range: 7 values is more "
                                            r"than the 6 points"):
        load_sweep(write_sweep(tmp_path, grid % "{range: [1, 8]}"))
    random = "scene: ball.yaml\nmode: random\nsamples: %d\naxes: {components.ball.speed: {uniform: [1, 2]}}\n"
    assert len(load_sweep(write_sweep(tmp_path, random % 6)).points) == 6
    with pytest.raises(ScenarioError, match=r"samples: 7 points is more than 6; check the count"):
        load_sweep(write_sweep(tmp_path, random % 7))
    for args in itertools.product(range(-4, 5), range(-4, 5), (-3, -1, 1, 2)):
        assert plan._range_count(*args) == len(range(*args)), args


@pytest.mark.parametrize("ends", ["[1e308, -1e308, 3]", "[-1e308, 1e308, 2]"])
def test_a_linspace_whose_span_overflows_a_float_is_refused_naming_it(tmp_path, ends):
    """Two finite ends whose difference is beyond a float: said on the axis (numpy warned of an overflow,
    and the sweep then blamed a point of nan it had made itself)."""
    with pytest.raises(ScenarioError, match=r"axes\.components\.ball\.speed\.linspace: the span from .* is beyond "
                                            r"what a float holds") as info:
        load_sweep(write_sweep(tmp_path, f"scene: ball.yaml\naxes: {{components.ball.speed: {{linspace: {ends}}}}}\n"))
    assert len(info.value.problems) == 1
