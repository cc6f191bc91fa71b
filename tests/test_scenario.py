"""Scene loading: valid scenes become typed config; every malformed scene gets a clear message."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
import yaml

from cosim.errors import ScenarioError
from cosim.scenario import load, loads

GOOD = """
name: good
dt: 0.001
until: 0.01
components:
  src: {type: "tests.toys:Source"}
  g: {type: "tests.toys:Gain", gain: 3}
  acc: {type: "tests.toys:Accumulator"}
connections:
  - src.out -> g.x
  - {from: g.out, to: acc.x}
"""


def test_valid_scene_is_typed():
    """A valid scene yields integer-ns times, typed parameters and the execution order."""
    scene = loads(GOOD)
    assert scene.dt_ns == 1_000_000 and scene.until_ns == 10_000_000
    assert scene.components["g"].params.gain == 3.0
    assert isinstance(scene.components["g"].params.gain, float)
    assert scene.order == ["src", "g", "acc"]


def test_overrides_apply_before_validation():
    """--set values are parsed as YAML and validated like the file."""
    scene = loads(GOOD, overrides=["components.g.gain=5", "dt=0.002"])
    assert scene.components["g"].params.gain == 5.0 and scene.dt_ns == 2_000_000
    with pytest.raises(ScenarioError, match=r"--set components\.gg\.gain: no such key 'components\.gg'"):
        loads(GOOD, overrides=["components.gg.gain=5"])
    with pytest.raises(ScenarioError, match=r"components\.g\.gain: must be a number \(got 'abc'\)"):
        loads(GOOD, overrides=["components.g.gain=abc"])


def test_an_input_as_old_as_its_component_allows_is_taken():
    """A source stepping exactly as often as its target can bridge loads (the bound is inclusive)."""
    text = scene_with('g: {type: "tests.toys:Gain", every: 3}\nacc: {type: "tests.toys:Accumulator", '
                      'max_age: 0.003}', "[g.out -> acc.x]")
    assert loads(text).components["g"].every == 3


def scene_with(components: str, connections: str = "[]", extra: str = "") -> str:
    """A small scene around the given component lines (one per line) and connections."""
    body = "\n".join(f"  {line}" for line in components.strip().splitlines())
    return f"dt: 0.001\nuntil: 0.01\n{extra}\ncomponents:\n{body}\nconnections: {connections}\n"


MALFORMED = {
    "unknown key": (
        scene_with('a: {type: "tests.toys:Gain", gian: 2}'),
        r"components\.a\.gian: unknown key; did you mean 'gain'\?"),
    "a component key misspelled (every)": (  # the component's own keys are offered with its parameters
        scene_with('a: {type: "tests.toys:Gain", evry: 2}'),
        r"components\.a\.evry: unknown key; did you mean 'every'\?"),
    "unknown top-level key": (
        GOOD + "speed: 3\n", r"speed: unknown key \(known: components, connections"),
    "wrong type": (
        scene_with('a: {type: "tests.toys:Gain", gain: fast}'),
        r"components\.a\.gain: must be a number \(got 'fast'\)"),
    "missing field": (
        "until: 1\ncomponents:\n  a: {type: \"tests.toys:Gain\"}\n", r"dt: missing \(required, seconds\)"),
    "missing type": (
        scene_with("a: {gain: 2}"), r"components\.a\.type: missing \(required, a component type name\)"),
    "unknown component type": (
        scene_with("a: {type: Rocket}"), r"components\.a\.type: unknown component type 'Rocket' \(known: "),
    "unknown port": (
        scene_with('a: {type: "tests.toys:Source"}\nb: {type: "tests.toys:Gain"}', "[a.out -> b.y]"),
        r"connections\.0\.to: b \(tests\.toys:Gain\) has no input port 'y' \(inputs: x\)"),
    "unknown component in edge": (
        scene_with('a: {type: "tests.toys:Source"}', "[a.out -> c.x]"),
        r"connections\.0\.to: unknown component 'c' \(known: a\)"),
    "port type mismatch": (
        scene_with('a: {type: "tests.toys:Source"}\nb: {type: "tests.toys:Summer"}', "[a.out -> b.label]"),
        r"connections\.0: type mismatch: a\.out sends Scalar but b\.label takes Text"),
    "duplicate name": (
        scene_with('a: {type: "tests.toys:Source"}\na: {type: "tests.toys:Gain"}'),
        r"line \d+: duplicate key 'a'"),
    "non-integer rate ratio": (
        scene_with('a: {type: "tests.toys:Gain", step: 0.0025}'),
        r"components\.a\.step: 0\.0025 s is not a whole multiple of dt = 0\.001 s \(ratio 2\.5\)"),
    "non-integer every": (
        scene_with('a: {type: "tests.toys:Gain", every: 2.5}'),
        r"components\.a\.every: must be a whole number of base steps \(got 2\.5\)"),
    "zero step": (
        GOOD.replace("dt: 0.001", "dt: 0"), r"dt: must be > 0 s \(got 0\)"),
    "negative step": (
        GOOD.replace("dt: 0.001", "dt: -0.001"), r"dt: must be > 0 s \(got -0\.001\)"),
    "cycle without delay": (
        scene_with('g: {type: "tests.toys:Gain"}\nacc: {type: "tests.toys:Accumulator"}',
                   "[g.out -> acc.x, acc.total -> g.x]"),
        r"connections: cycle without a delayed edge: g -> acc -> g"),
    "cycle without delay, a component waiting on it declared first": (
        # the component fed by the loop is not on it: the loop is found all the same
        scene_with('late: {type: "tests.toys:Gain"}\ng: {type: "tests.toys:Gain"}\n'
                   'acc: {type: "tests.toys:Accumulator"}',
                   "[g.out -> late.x, g.out -> acc.x, acc.total -> g.x]"),
        r"connections: cycle without a delayed edge: g -> acc -> g"),
    "delayed edge without initial": (
        scene_with('g: {type: "tests.toys:Gain"}\nacc: {type: "tests.toys:Accumulator"}',
                   "[g.out -> acc.x, {from: acc.total, to: g.x, delay: 1}]"),
        r"connections\.1\.initial: a delayed edge needs an initial value \(fields of Scalar: value\)"),
    "bad initial": (
        scene_with('g: {type: "tests.toys:Gain"}\nacc: {type: "tests.toys:Accumulator"}',
                   "[g.out -> acc.x, {from: acc.total, to: g.x, delay: 1, initial: {valu: 1}}]"),
        r"connections\.1\.initial\.valu: unknown key \(fields of Scalar: value\)\n.*connections\.1\.initial: missing "
        r"value \(fields of Scalar: value\)"),
    "input connected twice where not additive": (
        scene_with('a: {type: "tests.toys:Source"}\nb: {type: "tests.toys:Source"}\ng: {type: "tests.toys:Gain"}',
                   "[a.out -> g.x, b.out -> g.x]"),
        r"connections: input g\.x is connected 2 times .* but Scalar is not additive"),
    "input older than its component can use": (
        scene_with('g: {type: "tests.toys:Gain", every: 4}\nacc: {type: "tests.toys:Accumulator", max_age: 0.003}',
                   "[g.out -> acc.x]"),
        r"components\.acc: its input 'x' comes from g every 0\.004 s, longer than the 0\.003 s it can bridge "
        r"\(max_age\); use components\.g\.every at most 3, or components\.acc\.max_age of at least 0\.004 s"),
    "input older than its component can use, over a delayed edge": (
        scene_with('g: {type: "tests.toys:Gain", every: 3}\nacc: {type: "tests.toys:Accumulator", max_age: 0.003}',
                   "[{from: g.out, to: acc.x, delay: 1, initial: {value: 0}}]"),
        r"components\.acc: its input 'x' comes from g every 0\.004 s, .* use components\.g\.every at most 2,"),
    "input older than its component can use at any every": (
        scene_with('g: {type: "tests.toys:Gain"}\nacc: {type: "tests.toys:Accumulator", max_age: 0.0005}',
                   "[g.out -> acc.x]"),
        r"components\.acc: its input 'x' comes from g every 0\.001 s, .* use a base step dt of at most 0\.0005 s,"),
    "unstable step with on_unstable error": (
        scene_with('acc: {type: "tests.toys:Accumulator", stable_step: 0.0005}'),
        r"components\.acc: step 0\.001 s exceeds its stable step 0\.0005 s \(on_unstable: error\)"),
    "bad bound": (
        scene_with('acc: {type: "tests.toys:Accumulator", stable_step: 0}'),
        r"components\.acc\.stable_step: must be > 0 s \(got 0\)"),
    "bad on_unstable": (
        GOOD.replace("name: good", "on_unstable: explode"),
        r"on_unstable: must be one of 'error', 'substep' \(got 'explode'\)"),
    "yaml syntax error": (
        "dt: 0.001\ncomponents: {a: [\n", r"YAML syntax error: line \d+, column \d+"),
    "empty file": ("", r"the scene is empty"),
    "not a mapping": ("- 1\n- 2\n", r"the scene must be a mapping \(got a list\)"),
    "malformed edge": (
        scene_with('a: {type: "tests.toys:Source"}', "[a.out => b.x]"),
        r"connections\.0: expected 'source\.port -> target\.port' \(got 'a\.out => b\.x'\)"),
}


@pytest.mark.parametrize("case", sorted(MALFORMED))
def test_malformed_scene_is_reported_with_its_path(case):
    """Each malformed scene raises one ScenarioError whose text names the YAML path and the rule."""
    text, pattern = MALFORMED[case]
    with pytest.raises(ScenarioError, match=pattern):
        loads(text, source="scene.yaml")


def test_all_problems_are_reported_at_once():
    """Several problems in one scene come back together, one line each."""
    text = scene_with('a: {type: "tests.toys:Gain", gain: x}\nb: {type: Nope}', "[a.out -> z.x]",
                      extra="on_unstable: maybe")
    with pytest.raises(ScenarioError) as info:
        loads(text, source="s.yaml")
    assert len(info.value.problems) == 4
    assert str(info.value).startswith("s.yaml: 4 problems")


def test_missing_file_is_bad_input(tmp_path):
    """A scene path that does not exist is a ScenarioError naming the path."""
    with pytest.raises(ScenarioError, match=r"nope\.yaml: no such file"):
        load(tmp_path / "nope.yaml")


@pytest.mark.parametrize("components", ["[1, 2]", "{}"])
def test_components_that_are_not_a_mapping_is_the_one_problem_named(components):
    """With no usable components, the connections are not checked against them: the error is the one
    line that says what is wrong, not one more per connection end that names an unknown component."""
    text = (f"dt: 0.001\nuntil: 1\ncomponents: {components}\n"
            "connections:\n  - a.out -> b.in\n  - b.out -> a.in\n")
    with pytest.raises(ScenarioError) as info:
        loads(text)
    assert info.value.problems == [f"components: must be a non-empty mapping (got {yaml.safe_load(components)!r})"]


def test_a_parameter_given_to_a_component_that_takes_none_says_so():
    """A key under a component without parameters: the error says it takes none (it ended in an
    empty 'known: ' list)."""
    text = ('name: x\ndt: 0.001\nuntil: 0.01\ncomponents:\n  ping: {type: "cosim.examples:Ping", gain: 3}\n'
            '  pong: {type: "cosim.examples:Pong"}\nconnections:\n  - ping.out -> pong.inp\n'
            '  - {from: pong.out, to: ping.inp, delay: 1, initial: {value: 1.0}}\n')
    with pytest.raises(ScenarioError) as err:
        loads(text)
    assert "components.ping.gain: unknown key (components.ping takes no parameters)" in str(err.value)


def test_a_value_that_is_no_finite_number_is_one_problem_not_also_out_of_bounds():
    """radius: .nan was said twice ('must be finite' and 'must be > 0 m'): once is the problem."""
    with pytest.raises(ScenarioError) as err:
        load("scenarios/skip.yaml", overrides=["components.stone.radius=.nan"])
    assert err.value.problems == ["components.stone.radius: must be finite (got nan)"]


@pytest.mark.parametrize(("change", "problem"), [
    (("ping.out -> pong.inp", "ping.outt -> pong.inp"),
     "connections.0.from: ping (cosim.examples:Ping) has no output port 'outt' (outputs: out)"),
    (('ping: {type: "cosim.examples:Ping"}', 'ping: {type: "NoSuchType"}'),
     "components.ping.type: unknown component type 'NoSuchType'"),
])
def test_a_refused_connection_is_not_also_said_to_leave_its_input_unconnected(change, problem):
    """A connection refused for its source (a misspelled port, an unknown type) is the one problem:
    the input it feeds is connected in the scene, so 'required input ... is not connected' is not said
    of it (it was, after every such mistake)."""
    from pathlib import Path

    text = (Path(__file__).resolve().parents[1] / "scenarios" / "ping_pong.yaml").read_text()
    with pytest.raises(ScenarioError) as info:
        loads(text.replace(*change))
    assert len(info.value.problems) == 1 and info.value.problems[0].startswith(problem)


@pytest.mark.parametrize(("override", "said"), [
    ("connections.5.initial.x_max=abc", "connections.5.initial.x_max: expected a number, got string 'abc'"),
    ("connections.3.initial.radial=null", "connections.3.initial.radial: expected a number, got null"),
    # a key that is no text, said on its path as the file wrote it (it was an internal error, exit 1)
    ("connections.3.initial={5: 0}", "connections.3.initial.5: unknown key (fields of AddedMass: "),
    ("connections.3.initial={~: 0}", "connections.3.initial.null: unknown key (fields of AddedMass: "),
    ("connections.3.initial=7", "connections.3.initial: expected a mapping of the message's fields (fields of "
                                "AddedMass: "),
])
def test_a_wrong_scalar_in_a_connections_initial_value_is_named_by_its_field(override, said):
    """A delayed edge's initial message with a scalar field of the wrong type: the error names the field
    (it said 'connections.5.initial: expected a number, got string' of any of a request's four)."""
    with pytest.raises(ScenarioError, match=re.escape(said)):
        load(Path(__file__).resolve().parent.parent / "scenarios" / "ball_wake.yaml", [override])


@pytest.mark.parametrize("written", ["2.0", "2e0"])
def test_a_whole_every_written_as_a_float_is_that_whole_number(written):
    """`every: 2.0` was refused as "a non-integer rate ratio": a whole number, however YAML reads it."""
    scene = loads(scene_with(f'a: {{type: "tests.toys:Gain", every: {written}}}'))
    assert scene.components["a"].every == 2 and isinstance(scene.components["a"].every, int)


@pytest.mark.parametrize(("written", "said"), [
    ("1.0e+19", r"components\.a\.every: a step of 10000000000000000000 x dt is longer than 9\.22e\+09 s$"),
    (".inf", r"components\.a\.every: must be a whole number of base steps \(got inf\)$"),
])
def test_a_whole_every_beyond_the_range_is_said_out_of_range_not_a_fraction(written, said):
    """1.0e+19 is a whole number too: its range is what is wrong with it (it was said to be "a
    non-integer rate ratio", which is not rounded); an infinite one is no number of steps at all."""
    with pytest.raises(ScenarioError) as info:
        loads(scene_with(f'a: {{type: "tests.toys:Gain", every: {written}}}'))
    assert len(info.value.problems) == 1 and re.search(said, info.value.problems[0]), info.value.problems


def test_a_whole_count_written_as_a_float_is_that_whole_number():
    """record.every: 2.0 is 2, and so is a component's count (a pond's nx: 20.0), as a component's
    every: 2.0 is (each was "must be an integer (got 2.0)"); 2.5 is still refused."""
    text = scene_with('a: {type: "tests.toys:Gain"}')
    assert loads(text + "record: {every: 2.0}\n").record.every == 2
    with pytest.raises(ScenarioError) as info:
        loads(text + "record: {every: 2.5}\n")
    assert info.value.problems == ["record.every: must be an integer (got 2.5)"]
    pond = scene_with("pond: {type: WaterSurface, nx: 20.0, ny: 1.2e+1}")
    params = loads(pond).components["pond"].params
    assert (params.nx, params.ny) == (20, 12) and isinstance(params.nx, int)
    with pytest.raises(ScenarioError) as info:
        loads(pond.replace("20.0", "20.5"))
    assert info.value.problems == ["components.pond.nx: must be an integer (got 20.5)"]


@pytest.mark.parametrize(("rows", "why"), [
    ("[[1, 2], [3]]", "bad array (its nested lists are not all of one length)"),
    ("[[1, 2], [3, x]]", "bad array (its values must be float64 numbers)"),
    ("[1, 2]", "shape (2,) does not match (None, None)"),  # an array, of the wrong shape: said as such
])
def test_an_initial_array_that_is_no_array_is_said_in_the_scenes_words(rows, why):
    """An edge's initial array of ragged rows, or of a word: said as the rule (it quoted numpy: "setting
    an array element with a sequence. The requested array has an inhomogeneous shape ...")."""
    text = (Path(__file__).resolve().parents[1] / "scenarios" / "skip.yaml").read_text()
    assert "initial: {i0: 0, j0: 0, b: []}" in text
    with pytest.raises(ScenarioError) as info:
        loads(text.replace("initial: {i0: 0, j0: 0, b: []}", f"initial: {{i0: 0, j0: 0, b: {rows}}}"))
    assert info.value.problems == [f"connections.4.initial: field 'b': {why}"]


@pytest.mark.parametrize(("component", "said"), [
    ("b: {type: RigidBody, density: 1000001}", "components.b.density: must be <= 1e+06 kg/m^3 (got 1000001)"),
    ("pond: {type: WaterSurface, depth: 100000.4}", "components.pond.depth: must be <= 100000 m (got 100000.4)"),
    ("b: {type: RigidBody, density: 0}", "components.b.density: must be > 0 kg/m^3 (got 0)"),
])
def test_a_value_beside_its_bound_is_said_as_written(component, said):
    """:g wrote 1000001 as 1e+06, the very bound it was refused for ("must be <= 1e+06 kg/m^3 (got
    1e+06)"); a value :g writes exactly is written so."""
    with pytest.raises(ScenarioError) as info:
        loads(scene_with(component))
    assert said in info.value.problems


def test_validate_and_the_run_summary_give_the_step_with_every_digit(tmp_path, capsys):
    """dt = 0.001234567 s was "0.00123457 s" in validate (its until was exact beside it) and "steps
    of 1.23457 ms" in the run's summary."""
    from cosim.cli import main

    scene = tmp_path / "s.yaml"
    scene.write_text(scene_with('a: {type: "tests.toys:Gain", every: 2}').replace("dt: 0.001", "dt: 0.001234567"))
    assert main(["validate", str(scene)]) == 0
    said = capsys.readouterr().out
    assert "dt = 0.001234567 s" in said and "a: tests.toys:Gain, every 2 (0.002469134 s)" in said
    assert main(["run", str(scene), "--no-record", "--until", "0.01"]) == 0
    assert " steps of 1.234567 ms " in capsys.readouterr().out
