"""Scene values refused in one line naming their key, the rule and the value (exit 2), where they
were an internal error or were silently changed: integers beyond a float's range, numbers read as
YAML 1.1 (base 60, ``0x``), a checkpoint interval between base steps, a delay of ``1.0``, a
description that is not text, a default scene name that is no safe file name, and messages that
did not say enough."""

from __future__ import annotations

import random
import re
from pathlib import Path

import pytest
import yaml

from cosim.cli import main
from cosim.errors import ScenarioError
from cosim.scenario import SCENE_NAME_RE, default_scene_name, loads, read_yaml, yaml_value
from cosim.sweep.plan import Expression, load_sweep
from tests.cli_toys import CHECKPOINTED_SCENE, one_error_line
from tests.sweep_toys import write_sweep

ROOT = Path(__file__).resolve().parents[1]
HUGE = 10**309  # one more digit than any float holds
DISK = """
dt: 0.001
until: 0.01
components:
  disk: {type: RigidBody, radius: 0.05}
"""


def problems(text: str, overrides: list[str] | None = None, source: str = "s.yaml") -> list[str]:
    with pytest.raises(ScenarioError) as caught:
        loads(text, source, overrides)
    return caught.value.problems


def problem(text: str, overrides: list[str] | None = None) -> str:
    found = problems(text, overrides)
    assert len(found) == 1, found
    return found[0]


# --- 1. an integer beyond a float's range --------------------------------------------------------

@pytest.mark.parametrize(("override", "expected"), [
    (f"components.g.gain={HUGE}",
     "components.g.gain: must be a number within a float's range, at most 1.8e+308 in size (got 1e+309)"),
    (f"components.g.gain={-HUGE}",
     "components.g.gain: must be a number within a float's range, at most 1.8e+308 in size (got -1e+309)"),
    (f"dt={HUGE}", "dt: must be between 1e-09 s and 9.22e+09 s (got 1e+309)"),
    (f"until={HUGE}", "until: must be between 1e-09 s and 9.22e+09 s (got 1e+309)"),
    (f"until={-HUGE}", "until: must be > 0 s (got -1e+309)"),
    (f"components.g.step={HUGE}", "components.g.step: must be between 1e-09 s and 9.22e+09 s (got 1e+309)"),
    (f"record.checkpoint_every={HUGE}",
     "record.checkpoint_every: must be 0 (no checkpoints) or between 1e-09 s and 9.22e+09 s (got 1e+309)"),
    (f"record.visual_rate={HUGE}",
     "record.visual_rate: must be between 0 and 1e+09 frames/s (a frame per nanosecond; got 1e+309)"),
    (f"record.every={HUGE}", "record.every: must be a 64-bit integer, below 2^63 in size (got 1e+309)"),
    (f"components.g.every={7 * HUGE}", "components.g.every: a step of 7e+309 x dt is longer than 9.22e+09 s"),
], ids=["gain", "-gain", "dt", "until", "-until", "step", "checkpoint_every", "visual_rate", "record.every", "every"])
def test_an_integer_beyond_a_floats_range_is_refused_naming_the_key_and_its_range(override, expected):
    """It was an internal OverflowError (int too large to convert to float) wherever a float was made."""
    assert problem(CHECKPOINTED_SCENE, [override]) == expected


def test_a_huge_parameter_says_its_declared_bounds_too(tmp_path, capsys):
    """`cosim validate` of a radius of 1 followed by 309 zeros: exit 2, one line, the radius's rule."""
    scene = tmp_path / "huge_radius.yaml"
    scene.write_text(DISK.replace("radius: 0.05", f"radius: {HUGE}"))
    assert main(["validate", str(scene)]) == 2
    assert one_error_line(capsys.readouterr().err) == (
        f"error: {scene}: components.disk.radius: must be a number > 0 m within a float's range, at most "
        "1.8e+308 in size (got 1e+309)")


def test_a_huge_record_every_on_the_command_line_is_bad_input(tmp_path, capsys):
    scene = tmp_path / "demo.yaml"
    scene.write_text(CHECKPOINTED_SCENE)
    code = main(["run", str(scene), "-q", "-o", str(tmp_path / "r.mcap"), "--record-every", str(HUGE)])
    line = one_error_line(capsys.readouterr().err)
    assert code == 2 and "record.every: must be a 64-bit integer, below 2^63 in size (got 1e+309)" in line
    assert not (tmp_path / "r.mcap").exists()


def test_a_huge_integer_in_a_delayed_edges_initial_value_names_its_field():
    """The codec's float() of it was an internal OverflowError. It is told the field's own rule, as a
    value a float holds is (at most 1e15), not the float's range."""
    edge = "{from: b.out, to: a.inp, delay: 1, initial: {value: VALUE}}"
    text = ("dt: 0.001\nuntil: 0.01\ncomponents:\n  a: {type: 'cosim.examples:Ping'}\n"
            "  b: {type: 'cosim.examples:Pong'}\nconnections:\n  - a.out -> b.inp\n  - " + edge + "\n")
    assert problem(text.replace("VALUE", str(HUGE))) == (
        "connections.1.initial.value: 1e+309 is beyond 1e+15 (too large for any start of a run)")
    assert problem(text.replace("VALUE", "2e15")) == (
        "connections.1.initial.value: 2e+15 is beyond 1e+15 (too large for any start of a run)")
    assert loads(text.replace("VALUE", "2")).connections[1].initial.value == 2.0


def test_a_huge_record_number_is_said_once_beside_the_other_record_problems():
    found = problems(CHECKPOINTED_SCENE.replace("checkpoint_every: 0.01", f"checkpoint_every: {HUGE}, "
                                                f"visual_rate: {HUGE}, every: 0"))
    assert found == [
        "record.every: must be >= 1 (got 0)",
        "record.visual_rate: must be between 0 and 1e+09 frames/s (a frame per nanosecond; got 1e+309)",
        "record.checkpoint_every: must be 0 (no checkpoints) or between 1e-09 s and 9.22e+09 s (got 1e+309)"]


def test_a_derived_value_beyond_a_floats_range_fails_its_point_naming_the_key(tmp_path):
    """`attack**1000` is an integer of 1001 digits: a point's failure fails that point, naming the
    derived key (it reached the scene: internal error), and is bad input when no point's derived
    values can be worked out."""
    body = "scene: ball.yaml\naxes: {v: [2, 10]}\nderived: {components.ball.speed: 'v**400'}\n"
    sweep = load_sweep(write_sweep(tmp_path, body))
    assert sweep.points[0].problem is None
    assert sweep.points[1].problem == (
        "derived.components.ball.speed: cannot evaluate 'v**400': ValueError: v ** 400 is 1e+400, beyond a "
        "float's range (at most 1.8e+308 in size)")
    assert [p.problem is None for p in load_sweep(write_sweep(tmp_path, body.replace("[2, 10]", "[10, 2]"))).points] \
        == [False, True]
    with pytest.raises(ScenarioError, match=r"the first point \(v=10\): derived\.components\.ball\.speed: "
                                            r"cannot evaluate 'v\*\*400': .* beyond a float's range"):
        load_sweep(write_sweep(tmp_path, body.replace("[2, 10]", "[10, 20]")))
    # each step is refused, so a tower of powers never builds an integer of millions of digits
    with pytest.raises(ValueError, match=r"^v \*\* 400 is 1e\+400, beyond a float's range"):
        Expression("(v**400)**1000 ** 1")({"v": 10})
    assert Expression("v**300")({"v": 10}) == 10**300  # a float's range holds it


@pytest.mark.parametrize(("body", "said"), [
    ("axes: {{components.ball.speed: {{linspace: [0, {big}, 3]}}}}\n",
     "axes.components.ball.speed.linspace: expected a list of 3 finite numbers (got [0, 1e+309, 3])"),
    ("axes: {{components.ball.speed: [2, 3]}}\nuntil: {big}\n", "until: must be a number of seconds > 0 (got 1e+309)"),
])
def test_a_huge_integer_in_a_sweeps_axis_or_its_end_is_bad_input(tmp_path, body, said):
    """An integer beyond a float's range in an axis's spec or the sweep's until: math.isfinite of it
    overflowed, an internal error."""
    path = write_sweep(tmp_path, "scene: ball.yaml\n" + body.format(big="1" + "0" * 309))
    with pytest.raises(ScenarioError, match=re.escape(said)):
        load_sweep(path)


# --- 2. numbers as YAML 1.2 reads them -------------------------------------------------------------

@pytest.mark.parametrize(("text", "value"), [
    ("0x10", 16), ("0o17", 15), ("0", 0), ("+12", 12), ("-3", -3),
    ("5e-4", 0.0005), ("1.", 1.0), (".5", 0.5), ("-.inf", float("-inf")), ("1e21", 1e21),
    ("1:30", "1:30"), ("12:30:00", "12:30:00"), ("0:0:1", "0:0:1"), ("1:30.5", "1:30.5"),  # 1.1: base 60
    ("1_000", "1_000"), ("1_0.5", "1_0.5"), ("0b101", "0b101"), ("-0x10", "-0x10"), ("+0o7", "+0o7"),
    ("true", True), ("null", None),
])
def test_numbers_are_read_as_yaml_1_2_reads_them(text, value):
    assert read_yaml(f"a: {text}", "s.yaml") == {"a": value}
    assert yaml_value(text) == value  # --set reads its value the same way


def test_a_time_in_base_60_is_refused_as_not_a_number_and_hex_and_octal_are_read_alike():
    """`until: 1:30` ran for 90 s and `12:30:00` for 45000 s (YAML 1.1), while `0:0:1` and `0o17`
    were refused."""
    text = CHECKPOINTED_SCENE.replace("until: 0.05", "until: %s")
    assert problem(text % "1:30") == ("until: must be a number of seconds (got '1:30'; YAML 1.2 reads a "
                                            "base-60 time as text: write it in seconds)")
    assert problem(text % "12:30:00").startswith("until: must be a number of seconds (got '12:30:00';")
    assert problem(CHECKPOINTED_SCENE, ["until=0:0:1"]).startswith("until: must be a number of seconds")
    assert loads(text % "0x10").until_ns == 16 * 10**9
    assert loads(text % "0o17").until_ns == 15 * 10**9
    # a leading zero is octal to YAML 1.1 and decimal to YAML 1.2: neither is taken without a word
    assert problem(text % "017") == ("YAML syntax error: line 4, column 8: '017': an integer with a leading zero is 17 "
                                     "in YAML 1.2 and 15 in YAML 1.1 (octal); write 17, or 0o17 for octal")
    assert problem(CHECKPOINTED_SCENE, ["until=09"]) == "until: must be a number of seconds (got '09')"


@pytest.mark.parametrize(("text", "said"), [
    ("a: !!int abc", "line 1, column 4: 'abc' is not an integer (YAML 1.2: decimal digits, 0o octal or 0x "
                     "hexadecimal)"),
    ("a: !!float abc", "line 1, column 4: 'abc' is not a number"),
    ("a: !!bool maybe", "line 1, column 4: cannot read 'maybe' as bool"),
    ("a:\n  b: 2024-13-45", "line 2, column 6: cannot read '2024-13-45' as timestamp (month must be in 1..12)"),
    ("a: [!!timestamp x]", "line 1, column 5: cannot read 'x' as timestamp"),
    ("a: 1" + "0" * 5000, "line 1, column 4: an integer of 5001 digits is too long to read"),
], ids=["int", "float", "bool", "date", "timestamp", "5001 digits"])
def test_a_value_yaml_cannot_build_is_a_yaml_error_with_its_line(text, said):
    """They escaped PyYAML as a ValueError, KeyError or AttributeError: an internal error."""
    with pytest.raises(ScenarioError) as caught:
        read_yaml(text, "s.yaml")
    assert caught.value.problems == [f"YAML syntax error: {said}"]
    assert yaml_value(text.partition(": ")[2]) == text.partition(": ")[2]  # --set keeps it as text


class _Yaml11WithExponents(yaml.SafeLoader):
    """How scenes were read before: YAML 1.1, plus floats with an exponent and no dot."""


_Yaml11WithExponents.add_implicit_resolver(
    "tag:yaml.org,2002:float", re.compile(r"^[-+]?(?:[0-9][0-9_]*(?:\.[0-9_]*)?|\.[0-9_]+)[eE][-+]?[0-9]+$"),
    list("-+0123456789."))


@pytest.mark.parametrize("path", sorted((ROOT / "scenarios").glob("**/*.yaml")), ids=lambda p: p.name)
def test_every_shipped_scene_and_sweep_reads_as_before(path):
    text = path.read_text()
    assert read_yaml(text, str(path)) == yaml.load(text, _Yaml11WithExponents)


# --- 3. a checkpoint interval between base steps -------------------------------------------------

def test_a_checkpoint_interval_that_is_no_whole_multiple_of_dt_is_refused_naming_the_nearest():
    """At dt 0.5 ms, 1.25 ms became 1 ms (the recorder rounds half to even)."""
    text = CHECKPOINTED_SCENE.replace("dt: 0.001", "dt: 0.0005")
    assert problem(text.replace("checkpoint_every: 0.01", "checkpoint_every: 0.00125")) == (
        "record.checkpoint_every: 0.00125 s is not a whole multiple of dt = 0.0005 s; checkpoints are taken at "
        "base steps: use 0.001 s or 0.0015 s")
    assert problem(CHECKPOINTED_SCENE, ["record.checkpoint_every=0.0010001"]) == (
        "record.checkpoint_every: 0.0010001 s is not a whole multiple of dt = 0.001 s; checkpoints are taken "
        "at base steps: use 0.001 s or 0.002 s")
    # (a tenth of a nanosecond off is off the clock's grid: said so, not rounded onto it)
    assert problem(CHECKPOINTED_SCENE, ["record.checkpoint_every=0.0010000001"]) == (
        "record.checkpoint_every: must be a whole number of nanoseconds (got 0.0010000001 s)")
    assert loads(text.replace("checkpoint_every: 0.01", "checkpoint_every: 0.0015")).record.checkpoint_every == 0.0015
    assert loads(text, overrides=["record.checkpoint_every=0"]).record.checkpoint_every == 0


def test_the_default_checkpoint_interval_takes_any_step():
    """The default (1 s) is not the user's to make a multiple of dt: a scene at dt = 24 ms, which
    does not divide it, loads (its checkpoints come every 42 steps, 1.008 s); given, 1 s is refused."""
    text = CHECKPOINTED_SCENE.replace("dt: 0.001", "dt: 0.024").replace("until: 0.05", "until: 0.048")
    text = text.replace("record: {checkpoint_every: 0.01}", "")
    scene = loads(text)
    assert scene.record.checkpoint_every == 1.0 and "record" not in scene.data
    assert round(scene.record.checkpoint_every * 1e9 / scene.dt_ns) == 42  # as the recorder takes it
    assert problem(text, ["record.checkpoint_every=1.0"]).startswith(
        "record.checkpoint_every: 1.0 s is not a whole multiple of dt = 0.024 s")


def test_a_checkpoint_interval_refused_as_no_number_is_not_also_refused_as_the_default():
    """`checkpoint_every: null` at a dt that does not divide 1 s was refused twice, the second time
    for the default the refused value left in its place ("1.0 s is not a whole multiple of dt");
    an integer given (1) was taken for the default and rounded without a word."""
    text = CHECKPOINTED_SCENE.replace("dt: 0.001", "dt: 0.024").replace("until: 0.05", "until: 0.048")
    with pytest.raises(ScenarioError) as refused:
        loads(text, overrides=["record.checkpoint_every=null"])
    assert refused.value.problems == ["record.checkpoint_every: must be a number (got None)"]
    assert problem(text, ["record.checkpoint_every=1"]).startswith(
        "record.checkpoint_every: 1.0 s is not a whole multiple of dt = 0.024 s")


# --- 4. a connection's delay ----------------------------------------------------------------------

@pytest.mark.parametrize("delay", ["1.0", "0.0", "true", "'1'"])
def test_a_delay_that_is_not_a_whole_number_is_refused_as_every_is(delay):
    """`delay: 1.0` was taken and kept as a float: refused, as any delay but the integers 0 and 1."""
    edge = "{from: src.out, to: g.x, delay: DELAY, initial: {value: 0.0}}".replace("DELAY", delay)
    text = CHECKPOINTED_SCENE.replace("  - src.out -> g.x", f"  - {edge}")
    shown = {"true": "True", "'1'": "'1'"}.get(delay, delay)
    rounded = "; a non-integer delay is not rounded" if "." in delay else ""  # (said of a number only)
    assert problem(text) == f"connections.0.delay: must be 0 or 1, a whole number of base steps (got {shown}){rounded}"
    assert loads(text.replace(f"delay: {delay}", "delay: 1")).connections[0].delay == 1


# --- 5. a description that is not text -------------------------------------------------------------

@pytest.mark.parametrize(("value", "shown"), [("null", "None"), ("{a: 1}", "{'a': 1}"), ("[x]", "['x']"),
                                              ("3", "3"), ("true", "True")])
def test_a_description_that_is_not_text_is_refused(value, shown):
    """`description: null` became the text 'None', a mapping its Python repr."""
    assert problem(CHECKPOINTED_SCENE + f"description: {value}\n") == f"description: must be text (got {shown})"


def test_a_description_left_out_is_empty_and_text_is_kept():
    assert loads(CHECKPOINTED_SCENE).description == ""
    assert loads(CHECKPOINTED_SCENE + "description: 'a: b'\n").description == "a: b"


# --- 6. the default scene name ---------------------------------------------------------------------

@pytest.mark.parametrize(("source", "name"), [
    ("/x/skip.yaml", "skip"), ("/x/ok_name-1.2.yaml", "ok_name-1.2"), ("rel/a.b.yaml", "a.b"),  # kept
    ("/x/my scene (copy).yaml", "my_scene__copy_"), ("/x/-dash.yaml", "_dash"), ("/x/.hidden.yaml", "_hidden"),
    ("/x/a..b.yaml", "a._b"), ("/x/a....b.yaml", "a._._b"), ("/x/ü.yaml", "_"), ("<string>", "_string_"),
    ("/x/" + "n" * 150 + ".yaml", "n" * 100), ("/x/" + "é" * 150 + ".yaml", "_" * 100),
], ids=lambda value: value if len(value) < 40 else f"{value[:10]}...")
def test_the_default_scene_name_is_made_a_safe_file_name(source, name):
    """The name without `name:` is the file's: it names the recording's file, so it obeys the rule a
    written name does (it was taken unchecked: `my scene (copy)`)."""
    assert loads(CHECKPOINTED_SCENE.replace("name: demo\n", ""), source).name == name


def test_any_default_scene_name_obeys_the_rule():
    rng = random.Random(5)
    alphabet = "aZ09_-. /\\:é\n\t.."
    for _ in range(2000):
        stem = "".join(rng.choice(alphabet) for _ in range(rng.randrange(1, 130)))
        name = default_scene_name(f"/x/{stem}.yaml")
        assert SCENE_NAME_RE.fullmatch(name) and ".." not in name, (stem, name)


# --- 7. messages that said too little --------------------------------------------------------------

def test_a_time_that_is_no_whole_number_of_nanoseconds_is_said_with_its_key():
    """It read `dt must be a whole number of nanoseconds (got 1.5e-09 s)`, without the `dt:` every
    other problem starts with."""
    assert problem(CHECKPOINTED_SCENE, ["dt=1.5e-9"]) == "dt: must be a whole number of nanoseconds (got 1.5e-09 s)"
    assert problem(CHECKPOINTED_SCENE, ["components.g.step=1.5e-9"]) == (
        "components.g.step: must be a whole number of nanoseconds (got 1.5e-09 s)")


def test_a_step_just_off_a_multiple_of_dt_is_said_in_enough_digits():
    """`step: 0.001000001` (a nanosecond over) was reported as '0.001 s is not a whole multiple of dt = 0.001 s
    (ratio 1)'."""
    assert problem(CHECKPOINTED_SCENE, ["components.g.step=0.001000001"]) == (
        "components.g.step: 0.001000001 s is not a whole multiple of dt = 0.001 s (ratio 1.000001); rates "
        "must divide exactly: use 0.001 s or 0.002 s")
    assert problem(CHECKPOINTED_SCENE, ["components.g.step=0.0005"]).endswith("(ratio 0.5); rates must divide "
                                                                             "exactly: use 0.001 s")
    assert loads(CHECKPOINTED_SCENE, overrides=["components.g.step=0.003"]).components["g"].every == 3


def test_a_set_past_the_end_of_a_list_names_the_lists_indices():
    """`--set connections.2.x=1` on a list of two said '(known there: none)'."""
    text = CHECKPOINTED_SCENE.replace("  - src.out -> g.x", "  - src.out -> g.x\n  - src.out -> g.x")
    assert problems(text, ["connections.2.x=1"])[0] == ("--set connections.2.x: no such key 'connections.2' "
                                                        "(a list of 2 items: indices 0 to 1)")
    assert problem(CHECKPOINTED_SCENE, ["connections.1.x=1"]) == ("--set connections.1.x: no such key 'connections.1' "
                                                                  "(a list of 1 item: index 0)")
    assert problems(text, ["connections.7=1"])[0] == ("--set connections.7: no such key 'connections.7' "
                                                      "(a list of 2 items: indices 0 to 1)")
    assert problem(CHECKPOINTED_SCENE, ["dt.x.y=1"]) == ("--set dt.x.y: no such key 'dt.x' (a number, which holds "
                                                         "no keys)")
    assert problem(CHECKPOINTED_SCENE, ["components.g.q=1"]) == "components.g.q: unknown key; known: gain"


def test_an_empty_scene_name_is_named_as_empty():
    """`cosim validate ''` said ".: is a folder, not a scene file": an empty name became the working folder."""
    from cosim.errors import ScenarioError
    from cosim.scenario import read_input

    with pytest.raises(ScenarioError, match="expected a scene file, got an empty name"):
        read_input("")
