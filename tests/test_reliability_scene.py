"""Scene values a user can get wrong are refused when the scene loads, in one line with the rule:
times outside one tick .. 292 years, YAML 1.2 numbers, nesting, size, names that become channels
and file names, component modules a scene may import, and a component failing at t = 0."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

from cosim.cli import main
from cosim.errors import ScenarioError
from cosim.record.reader import Recording
from cosim.runner import run_scene
from cosim.scenario import MAX_SCENE_BYTES, load, loads
from tests.cli_toys import CHECKPOINTED_SCENE

SCENE = CHECKPOINTED_SCENE
ROOT = Path(__file__).resolve().parents[1]


def problem(text: str, overrides: list[str] | None = None) -> str:
    with pytest.raises(ScenarioError) as err:
        loads(text, "s.yaml", overrides)
    assert len(err.value.problems) == 1, err.value.problems
    return err.value.problems[0]


@pytest.mark.parametrize(("change", "expected"), [
    (("dt: 0.001", "dt: 1.0e-15"), "dt: must be between 1e-09 s and 9.22e+09 s (shorter than the clock's 1 ns tick)"),
    (("dt: 0.001", "dt: 1.0e308"), "dt: must be between 1e-09 s and 9.22e+09 s (got 1e+308)"),
    (("until: 0.05", "until: 1.0e308"), "until: must be between 1e-09 s and 9.22e+09 s (got 1e+308)"),
    (("until: 0.05", "until: 100000000000000000000000"), "until: must be between 1e-09 s and 9.22e+09 s"),
    (("checkpoint_every: 0.01", "checkpoint_every: 1.0e308"),
     "record.checkpoint_every: must be 0 (no checkpoints) or between 1e-09 s and 9.22e+09 s (got 1e+308)"),
    (("checkpoint_every: 0.01", "checkpoint_every: 0.0001"),
     "record.checkpoint_every: must be 0 (none) or at least dt"),
    (("checkpoint_every: 0.01", "visual_rate: 1.0e308"), "record.visual_rate: must be between 0 and 1e+09 frames/s"),
    (("{type: \"tests.toys:Gain\"}", "{type: \"tests.toys:Gain\", step: 1.0e308}"),
     "components.g.step: must be between 1e-09 s and 9.22e+09 s"),
])
def test_times_outside_the_clock_are_refused_with_the_range(change, expected):
    """dt below the 1 ns tick, and huge times (1e308) anywhere, are refused naming the range."""
    assert expected in problem(SCENE.replace(*change))


@pytest.mark.parametrize(("cell", "expected"), [
    ("1.0e-300", "components.pond.cell: must be >= 1e-06 m (got 1e-300)"),  # its square underflows to 0
    ("1.0e+160", "components.pond.cell: must be <= 10000 m (got 1e+160)"),  # its square overflows
])
def test_water_cells_whose_arithmetic_breaks_are_refused_with_the_range(cell, expected):
    """Before the rule, the water was built and failed with a division by zero or an overflow, not
    naming the cell."""
    text = (ROOT / "scenarios" / "wave_pulse.yaml").read_text()
    assert problem(text, [f"components.pond.cell={cell}"]) == expected


def test_set_with_a_huge_time_is_refused_cleanly(tmp_path, capsys):
    """`--set dt=1e21` (a YAML 1.2 float) is a range error, exit 2, one line."""
    scene = tmp_path / "s.yaml"
    scene.write_text(SCENE)
    assert main(["validate", str(scene), "--set", "dt=1e21"]) == 2
    err = capsys.readouterr().err.strip()
    assert err == f"error: {scene}: dt: must be between 1e-09 s and 9.22e+09 s (got 1e+21)"


def test_exponent_floats_without_a_dot_are_numbers():
    """`dt: 5e-4` (a string to YAML 1.1) is a number, as in YAML 1.2; so is `--set gain=2e0`."""
    scene = loads(SCENE.replace("dt: 0.001", "dt: 5e-4"), overrides=["components.g.gain=2e0"])
    assert scene.dt_ns == 500_000
    assert scene.components["g"].params.gain == 2.0
    assert loads(SCENE.replace("dt: 0.001", "dt: +5E-4")).dt_ns == 500_000


def test_deep_nesting_is_a_clear_error_not_a_recursion_error():
    """500 nested '[' is one ScenarioError, not a RecursionError."""
    assert "nested too deeply" in problem("dt: 0.001\nuntil: 1\ncomponents: " + "[" * 500)
    assert "nested more than 64 levels deep" in problem("dt: 0.001\nuntil: 1\ndescription: " + "[" * 80 + "]" * 80)


def test_alias_bombs_are_refused():
    """YAML aliases that expand to billions of values are refused, without expanding them."""
    lines = ["a0: &a0 [1, 1, 1, 1, 1, 1, 1, 1, 1, 1]"]
    lines += [f"a{i}: &a{i} [{', '.join([f'*a{i - 1}'] * 10)}]" for i in range(1, 10)]
    text = "dt: 0.001\nuntil: 1\ndescription:\n" + "\n".join("  " + line for line in lines)
    assert "holds more than 1,000,000 values" in problem(text)


def test_a_huge_scene_file_is_refused_by_its_size_before_reading(tmp_path):
    """A scene file of tens of MB (or a device) is refused up front."""
    big = tmp_path / "big.yaml"
    with open(big, "wb") as f:
        f.truncate(20 << 20)  # sparse: 20 MiB of nothing, never read
    with pytest.raises(ScenarioError, match=r"is 20\.0 MiB, more than the 4 MiB a scene may be"):
        load(big)
    with pytest.raises(ScenarioError, match="more than the 4 MiB"):
        loads("#" * (MAX_SCENE_BYTES + 1))
    with pytest.raises(ScenarioError, match="not a regular file"):
        load("/dev/zero")


@pytest.mark.parametrize("name", ["stone\\n", "a/b", "..", "../up", "/abs", ".hidden", "x" * 101, "a\\u0000b"])
def test_scene_names_that_are_not_safe_file_names_are_refused(name):
    """A scene name becomes the default recording's file name: no '/', '..', newline, absolute path."""
    assert problem(SCENE.replace("name: demo", f'name: "{name}"')).startswith("name: must be letters, digits")


@pytest.mark.parametrize("name", ["stone\\n", "a/b", "a.b", "x" * 65, "1st"])
def test_component_names_that_are_not_safe_channel_names_are_refused(name):
    """Component names become channel names (/name/port): identifiers only (a trailing newline too)."""
    text = SCENE.replace("  g: {type", f'  "{name}": {{type').replace("src.out -> g.x", "src.out -> src.out")
    with pytest.raises(ScenarioError) as err:
        loads(text)
    assert any("component names must be identifiers of at most 64 characters" in p for p in err.value.problems)


@pytest.mark.parametrize("name", ["cosim", "perf", "scene", "tf", "log"])
def test_a_component_named_as_the_frameworks_own_channels_is_refused(name):
    """/cosim/status, /cosim/checkpoint, /perf/tick, /scene/<body>, /tf and /log are the framework's
    and the viewer's: an FMU named cosim with a port status wrote onto the run's status and left a
    recording no command could read; a body named scene lost its looks mid-run."""
    text = SCENE.replace("  g: {type", f"  {name}: {{type").replace("g.x", f"{name}.x").replace("g.y", f"{name}.y")
    with pytest.raises(ScenarioError) as err:
        loads(text)
    said = f"components.{name}: {name!r} names the framework's or the viewer's own channels (/{name}...)"
    assert said in str(err.value)


def test_a_component_named_as_the_viewers_fixed_frame_is_refused():
    """A body's frame in /tf is named after it: one named world made /tf world -> world, and the trail,
    the arrows and the water, drawn in world, moved with it."""
    text = SCENE.replace("  g: {type", "  world: {type").replace("g.x", "world.x").replace("g.y", "world.y")
    with pytest.raises(ScenarioError) as err:
        loads(text)
    assert "components.world: 'world' names the viewer's fixed frame" in str(err.value)


def test_a_first_step_needing_more_substeps_than_the_limit_is_refused_at_load():
    """A 60 s step of a 64 x 64 pond under on_unstable: substep needs 14,557 substeps at its first
    step: validate said it was fine, and the run failed at t = 0."""
    text = """
dt: 60
until: 600
on_unstable: substep
components:
  pond: {type: WaterSurface, nx: 64, ny: 64, cell: 0.01, depth: 0.3}
record: {checkpoint_every: 0}
"""
    with pytest.raises(ScenarioError) as err:
        loads(text)
    assert ("components.pond: will need 14557 substeps of its step 60 s (stable step 0.00412 s from the start), "
            "more than the limit 10000") in str(err.value)


@pytest.mark.parametrize("char", ["\n", "\r", "\x00", "\x1c", "\x85", "\u2028", "\u2029"])
def test_error_lines_stay_lines_whatever_a_name_holds(char):
    """A name holding a line break or a control character is shown escaped: one line per problem."""
    text = SCENE.replace("  g: {type", f'  "g\\u{ord(char):04x}": {{type')  # a YAML escape of the character
    with pytest.raises(ScenarioError) as err:
        loads(text)
    assert len(str(err.value).splitlines()) == 1 + len(err.value.problems) > 2


def test_a_scene_cannot_import_an_arbitrary_module(tmp_path, monkeypatch):
    """`type: module:Class` imports only from allowed packages: another module is refused before it
    is imported (its code never runs); COSIM_COMPONENT_PACKAGES allows a package explicitly."""
    (tmp_path / "sideeffect_pkg").mkdir()
    marker = tmp_path / "imported"
    (tmp_path / "sideeffect_pkg" / "__init__.py").write_text(
        f"open({str(marker)!r}, 'w').close()\nfrom tests.toys import Source as Toy\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    text = 'dt: 0.001\nuntil: 0.01\ncomponents:\n  g: {type: "sideeffect_pkg:Toy"}\n'
    for bad in ("sideeffect_pkg:Toy", "os:system", "subprocess:Popen", ".toys:Gain"):
        msg = problem(text.replace("sideeffect_pkg:Toy", bad))
        assert "not in an allowed package" in msg or "expected 'package.module:Class'" in msg, msg
    assert not marker.exists() and "sideeffect_pkg" not in sys.modules
    monkeypatch.setenv("COSIM_COMPONENT_PACKAGES", "tests,sideeffect_pkg")
    assert loads(text).components["g"].type_name == "sideeffect_pkg:Toy"
    assert marker.exists()
    monkeypatch.delitem(sys.modules, "sideeffect_pkg")


def test_registered_types_and_the_framework_examples_need_no_permission(monkeypatch):
    """Entry-point names and modules of cosim and of the packages that register components load
    without COSIM_COMPONENT_PACKAGES."""
    monkeypatch.delenv("COSIM_COMPONENT_PACKAGES", raising=False)
    root = Path(__file__).resolve().parents[1]
    assert load(root / "scenarios" / "ping_pong.yaml").components
    with pytest.raises(ScenarioError, match="not in an allowed package"):
        loads(SCENE)


def test_a_component_failing_at_t0_is_a_simulation_error_with_a_status(tmp_path, capsys):
    """A component whose t = 0 outputs raise: exit 1, one line naming it, a recording with status."""
    scene = tmp_path / "t0.yaml"
    scene.write_text("dt: 0.001\nuntil: 0.01\ncomponents:\n"
                     '  bad: {type: "tests.test_reliability_scene:FailsAtStart"}\n')
    out = tmp_path / "t0.mcap"
    assert main(["run", str(scene), "-o", str(out), "-q"]) == 1
    err = capsys.readouterr().err.strip()
    assert err == "error: component 'bad' failed at t = 0 s: its outputs at t = 0: ValueError: no start"
    status = Recording(out).status()
    assert status.status == "failed" and "its outputs at t = 0" in status.reason
    outcome = run_scene(load(scene), None, progress=False)
    assert outcome.failed and outcome.result.error.component == "bad"


from tests.toys import Source  # noqa: E402  (the toy the t = 0 failure is built on)


class FailsAtStart(Source):
    """A source whose initial outputs raise."""

    def initial_outputs(self):
        raise ValueError("no start")


def test_a_class_a_module_does_not_have_is_named_with_the_classes_it_has():
    """`type: components.rigid_body:Rigidbody` (a typo) or `components:RigidBody` (the class is in a
    module below): the module has no such name, and the problem lists its component classes (it
    said only 'is not a Component class')."""
    msg = problem('dt: 0.001\nuntil: 0.01\ncomponents:\n  s: {type: "components.rigid_body:Rigidbody"}\n')
    assert ("component type 'components.rigid_body:Rigidbody': module 'components.rigid_body' has no 'Rigidbody' "
            "(its component classes: RigidBody)") in msg
    msg = problem('dt: 0.001\nuntil: 0.01\ncomponents:\n  s: {type: "components:RigidBody"}\n')
    assert ("module 'components' has no 'RigidBody' (its component classes: none; RigidBody is a registered "
            "type: write type: RigidBody)") in msg


def test_the_base_component_class_is_refused_at_load_not_at_its_first_step():
    """`type: cosim.component:Component` (the base every component builds on) has no step of its own:
    the scene is refused naming it (it passed `cosim validate`, and the run failed at t = 0 with
    NotImplementedError, exit 1)."""
    msg = problem('dt: 0.001\nuntil: 0.01\ncomponents:\n  a: {type: "cosim.component:Component"}\n')
    assert ("components.a.type: component type 'cosim.component:Component': 'cosim.component:Component' does "
            "not step (it has no _step_impl of its own)") in msg


SKIP = ROOT / "scenarios" / "skip.yaml"


@pytest.mark.parametrize(("override", "expected"), [
    # values that passed the scene and failed the run at t = 0 (or gave an internal error)
    ("components.stone.gravity=[0, 0, 1e308]", "components.stone.gravity: each component at most 10000 m/s^2"),
    ("components.pond.wave_length=1e-300", "components.pond.wave_length: must be at least two columns, 0.02 m"),
    ("components.coupler.rho=1e308", "components.coupler.rho: must be <= 100000 kg/m^3"),
    ("components.stone.position=[1e308, 0, 0.1]", "components.stone.position: must lie within 1000 km"),
    ("components.pond.origin_x=1e308", "components.pond.origin_x: must be <= 1e+06 m"),
    # passed the scene, and the run failed at its first contact with non-finite forces
    ("components.coupler.wet_ramp=1e308", "components.coupler.wet_ramp: must be <= 1000 m (got 1e+308)"),
    ("components.coupler.closure_depth=1e308", "components.coupler.closure_depth: must be <= 1000 m"),
    ("components.coupler.wave_allowance=1e308", "components.coupler.wave_allowance: must be <= 1000 m"),
    ("components.coupler.quiet_above=1e308", "components.coupler.quiet_above: must be <= 1000 m"),
    # and values whose error named another key
    ("components.stone.thickness=1e308", "components.stone.thickness: gives the body a mass of inf kg"),
    ("components.stone.angular_velocity=[1e200, 0, 0]", "components.stone.angular_velocity: makes the stone's "
                                                        "kinetic energy overflow"),
])
def test_values_that_can_only_fail_the_run_are_refused_naming_their_key(override, expected):
    with pytest.raises(ScenarioError) as err:
        load(SKIP, [override])
    assert len(err.value.problems) == 1 and err.value.problems[0].startswith(expected), err.value.problems


@pytest.mark.parametrize(("initial", "expected"), [
    ("{force: [.nan, 0, 0], torque: [0, 0, 0]}", "connections.2.initial.force: must be finite (got [nan, 0.0, 0.0])"),
    ("{force: [0, 0, 0], torque: [0, 1e308, 0]}",
     "connections.2.initial.torque: 1e+308 is beyond 1e+15 (too large for any start of a run)"),
])
def test_an_edge_initial_that_is_not_finite_or_too_large_is_refused(initial, expected):
    """A NaN or huge initial value of a delayed edge: refused when the scene loads (validate passed it;
    the run failed at t = 0 and replaced the recording at -o)."""
    text = SKIP.read_text().replace("initial: {force: [0, 0, 0], torque: [0, 0, 0]}", f"initial: {initial}")
    with pytest.raises(ScenarioError) as err:
        loads(text, str(SKIP))
    assert err.value.problems == [expected]


def test_a_mapping_key_that_is_a_list_is_a_yaml_error_with_its_line():
    """`? [a, b]` as a key: an error naming the line (it was an internal TypeError)."""
    with pytest.raises(ScenarioError, match=r"line 3, column 5: found a key that is a list, not a name"):
        loads("name: x\ncomponents:\n  ? [a, b]\n  : {type: RigidBody}\n", "s.yaml")


def test_every_record_problem_is_said_at_once():
    """A wrong record.channels with a record.every of 0 and a checkpoint shorter than dt: all three at
    once (the ranges were said only once the channels were mended)."""
    with pytest.raises(ScenarioError) as err:
        load(SKIP, ["record.channels=5", "record.every=0", "record.checkpoint_every=0.0001"])
    assert err.value.problems == [
        "record.channels: must be a list of strings (got 5)", "record.every: must be >= 1 (got 0)",
        "record.checkpoint_every: must be 0 (none) or at least dt = 0.0005 s (got 0.0001)"]
    with pytest.raises(ScenarioError) as err:  # a value already said to be wrong is not said twice
        load(SKIP, ["record.channels=5", "record.checkpoint_every=.nan"])
    assert err.value.problems == ["record.channels: must be a list of strings (got 5)",
                                  "record.checkpoint_every: must be finite (got nan)"]


def test_a_default_checkpoint_interval_under_dt_is_one_base_step():
    """A scene that sets no checkpoint interval and steps by 2 s takes the default (about a second) at
    the nearest whole number of base steps, at least one, as docs/scenes.md says: it was refused for
    the default it never set (record.checkpoint_every 1 under dt = 2 s), even with --no-record. One
    it sets itself under dt is still refused."""
    text = "dt: 0.001\nuntil: 4\ncomponents:\n  g: {type: \"tests.toys:Gain\"}\n"
    assert loads(text, "s.yaml", ["dt=2"]).record.checkpoint_every == 2.0
    assert loads(text, "s.yaml", ["dt=0.3"]).record.checkpoint_every == 1.0  # taken at 3 steps, 0.9 s
    with pytest.raises(ScenarioError) as err:
        loads(text, "s.yaml", ["dt=2", "record.checkpoint_every=1"])
    assert "record.checkpoint_every: must be 0 (none) or at least dt = 2 s (got 1)" in err.value.problems


def test_an_end_before_the_first_step_is_refused():
    """until 0.2 s with dt 0.5 s: the run's one whole step would take it to 0.5 s, 2.5 times the end asked
    for (it ran there, "ok - reached t = 0.5 s"); refused naming both."""
    msg = problem('dt: 0.5\nuntil: 0.2\ncomponents:\n  s: {type: RigidBody}\n')
    assert "until: must be at least one base step, dt = 0.5 s (got 0.2 s)" in msg


ALIASED = """
name: aliased
dt: 0.001
until: 0.002
components:
  src: {type: "tests.toys:Source"}
  g: &gain {type: "tests.toys:Gain", gain: 2.0}
  h: *gain
  k: {<<: *gain}
connections:
  - src.out -> g.x
  - src.out -> h.x
  - src.out -> k.x
"""


def test_an_override_of_one_component_leaves_the_ones_sharing_its_yaml_alone():
    """`b: *a` and `<<: *a` share one mapping in the parsed YAML: --set components.g.gain wrote into it
    and changed h and k too, while the recording listed only g's override."""
    scene = loads(ALIASED, "s.yaml", ["components.g.gain=3.0"])
    assert [scene.components[n].params.gain for n in ("g", "h", "k")] == [3.0, 2.0, 2.0]
    scene = loads(ALIASED, "s.yaml", ["components.k.gain=5.0"])
    assert [scene.components[n].params.gain for n in ("g", "h", "k")] == [2.0, 2.0, 5.0]


@pytest.mark.parametrize(("written", "read_as"), [("null", "null"), ("~", "null"), ("off", "false"),
                                                  ("yes", "true"), ("12", "12")])
def test_a_component_name_yaml_reads_as_a_value_is_refused_saying_to_quote_it(written, read_as):
    """`off:` is false to YAML: it was taken as a component named False (and `null:` as None, its
    channels /None/...), and a connection naming it then said 'unknown component off (known: False)'."""
    text = SCENE.replace("  g: {type", f"  {written}: {{type").replace("src.out -> g.x", "src.out -> src.out")
    with pytest.raises(ScenarioError) as err:
        loads(text)
    said = [p for p in err.value.problems if "not a name" in p]
    assert said == [f"components: a component is named {read_as}, not a name: YAML reads null, ~, yes/no, "
                    "on/off, true/false and numbers as values; quote the name (e.g. 'off')"]


def test_two_keys_yaml_reads_alike_are_named_as_written():
    """`on:` and `yes:` are both true to YAML: the duplicate is named as written, and what it reads as."""
    text = SCENE.replace("  g: {type", "  'on': {type").replace("connections:", "yes: 1\non: 2\nconnections:")
    with pytest.raises(ScenarioError, match=r"duplicate key 'on' \(read as True, as a key before it\)"):
        loads(text)


def test_a_character_yaml_does_not_allow_is_placed_by_line_and_column():
    assert problem(SCENE.replace("until: 0.05", "until: 0.05\x00")) == (
        "YAML syntax error: line 4, column 12: the character U+0000 is not allowed in YAML")


def test_connections_given_as_an_empty_mapping_are_no_list():
    assert problem(SCENE.replace("connections:\n  - src.out -> g.x", "connections: {}")) == (
        "connections: must be a list (got {})")


def test_recording_a_bodys_looks_without_the_transforms_that_place_them_is_said():
    """A body's looks (/scene/NAME) are drawn in its own frame, which /tf places: recorded without
    /tf, the body could not be drawn, and nothing said so. A notice says so (the run goes on); with
    /tf, or with every channel, there is none."""
    held = Path(__file__).resolve().parents[1] / "scenarios" / "held_skip.yaml"
    alone = load(held, ["record.channels=['/scene/*']"])
    assert alone.notices == ["record.channels: keeps viewer looks (/scene/...) but not /tf, whose transforms place "
                             "each body's looks in its frame: the viewer cannot draw the bodies; add '/tf'"]
    assert load(held, ["record.channels=['/scene/*', '/tf']"]).notices == []
    assert load(held).notices == []
