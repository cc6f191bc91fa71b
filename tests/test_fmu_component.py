"""The FMU component: an FMU's variables on typed ports, checked when the scene loads; doStep at its
rate; its failures, state and replay.

    stone.state --> gust.body        gust.wrench -(delay)-> stone.wrench

The gust is the example model (scenarios/models/wind_gust.py), built with pythonfmu on first use.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("fmpy")
pytest.importorskip("pythonfmu")

from components.messages import BodyState, Wrench
from cosim.cli import main
from cosim.errors import RecordingError, ScenarioError
from cosim.examples import Number
from cosim.fmi.build import build_fmu
from cosim.record.reader import Recording
from cosim.replay import replay_component, restart_simulation
from cosim.runner import run_scene
from cosim.scenario import load, loads
from tests.cli_toys import one_error_line
from tests.fmu_toys import GUST_MODEL, fmu_cache, gust_scene  # noqa: F401

pytestmark = pytest.mark.usefixtures("fmu_cache")

RHO, CDA = 1.2, 0.004  # the model's default air density [kg/m^3] and drag area [m^2]


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    """The gust scene, run and recorded once for the module."""
    folder = tmp_path_factory.mktemp("gust")
    path = folder / "gust.yaml"
    path.write_text(gust_scene())
    outcome = run_scene(load(path), folder / "gust.mcap", progress=False)
    assert outcome.result.status == "ok", outcome.result.reason
    return outcome.recording


def test_the_scene_mapping_becomes_typed_ports():
    scene = loads(gust_scene())
    cls = scene.components["gust"].cls
    assert cls.inputs["body"].type is BodyState
    assert cls.outputs["wrench"].type is Wrench


def test_the_first_step_feels_still_air_drag_on_the_stone(recorded):
    """Before the gust the FMU's force is the drag of still air on the stone's 8 m/s, -1/2 rho CdA |v| v,
    and it adds onto the stone's wrench (the stone slows)."""
    rec = Recording(recorded)
    wrenches = rec.messages("/gust/wrench", Wrench)
    assert wrenches[0] == (0, wrenches[0][1]) and not wrenches[0][1].force.any()  # exact start values at t = 0
    stamp, first = wrenches[1]
    assert stamp == 2_000_000  # every: 2 of 1 ms
    # the stone has fallen for 1 ms when the gust's first step starts: |v| is 8 m/s to 1e-6
    assert first.force[0] == pytest.approx(-0.5 * RHO * CDA * 8.0 * 8.0, rel=1e-5)
    states = dict(rec.messages("/stone/state", BodyState))
    assert states[50_000_000].velocity[0] < 8.0


def test_the_crosswind_gust_pushes_the_stone_sideways_while_it_blows(recorded):
    """The gust blows from 0.05 s to 0.15 s; after it, still air brakes the sideways motion it left."""
    rec = Recording(recorded)
    lateral = {t: w.force[1] for t, w in rec.messages("/gust/wrench", Wrench)}
    assert lateral[50_000_000] == 0.0  # before the gust: no sideways motion, no sideways force
    assert lateral[100_000_000] > 0.1  # at its peak of 8 m/s: about 1/2 rho CdA 8^2 sideways
    assert lateral[200_000_000] < 0.0
    states = dict(rec.messages("/stone/state", BodyState))
    assert states[200_000_000].velocity[1] > 0.05  # about half the peak force over 0.1 s on 0.125 kg


def test_the_fmus_pythonfmu_binary_releases_python_at_pythons_exit(recorded):
    """The gust FMU's pythonfmu binary, hosted by the run, is let go of Python at Python's exit,
    before the C exit handlers that would release its state a second time into freed memory
    (cosim.fmi.pythonfmu_exit)."""
    from cosim.fmi import pythonfmu_exit

    assert any(Path(p).name == "WindGust.so" for p in pythonfmu_exit._guarded)


def test_replay_re_runs_the_fmu_alone_bit_for_bit(recorded):
    report = replay_component(Recording(recorded), "gust")
    assert report.ok, str(report)
    assert report.steps == 100 and report.messages_compared == 101


def test_a_restart_from_a_checkpoint_restores_the_fmu_state_and_repeats_the_run(recorded, tmp_path):
    rec = Recording(recorded)
    sim, stamp = restart_simulation(rec, 100_000_000)
    assert stamp == 100_000_000
    outcome = run_scene(sim.scene, tmp_path / "again.mcap", simulation=sim, progress=False)
    assert outcome.result.status == "ok"
    again = dict(Recording(outcome.recording).messages("/gust/wrench", Wrench))
    first = dict(rec.messages("/gust/wrench", Wrench))
    assert again[200_000_000].force.tobytes() == first[200_000_000].force.tobytes()


def test_an_fmu_without_state_serialization_is_refused_a_restart_with_the_reason(tmp_path):
    fmu = build_fmu(GUST_MODEL, tmp_path / "stateless.fmu", state=False)
    scene = tmp_path / "gust.yaml"
    scene.write_text(gust_scene(source="path: stateless.fmu"))
    outcome = run_scene(load(scene), tmp_path / "run.mcap", progress=False)
    assert outcome.result.status == "ok" and fmu.is_file()
    with pytest.raises(RecordingError, match=r"'stateless.fmu' cannot save and restore its state "
                                             r"\(canGetAndSetFMUstate false"):
        restart_simulation(Recording(outcome.recording), 100_000_000)


def test_an_fmu_error_stops_the_run_naming_the_fmu_the_time_and_its_log(tmp_path):
    """max_speed below the throw's 8 m/s: the model logs an Error and fails its first doStep; the
    recording still holds the t = 0 exchanges and the final status."""
    scene = tmp_path / "gust.yaml"
    scene.write_text(gust_scene(start="{max_speed: 5.0}"))
    outcome = run_scene(load(scene), tmp_path / "run.mcap", progress=False)
    assert outcome.result.status == "failed"
    reason = outcome.result.reason
    assert reason.startswith("component 'gust' failed at t = 0")
    assert "FMU 'wind_gust.py' doStep returned Fatal" in reason
    assert "relative air speed 8.00001 m/s at t = 0 s is above max_speed = 5 m/s" in reason
    rec = Recording(outcome.recording)
    assert rec.status().status == "failed"
    assert rec.messages("/stone/state", BodyState)[0][0] == 0
    # the failed doStep is counted ("0 doStep calls" said it was never called), and inspect says why
    # the recording runs past the failing tick: its stone stepped before the FMU failed
    assert any(line.endswith("1 doStep call (the last one failed)") for line in outcome.summary)
    from cosim.record.describe import describe_recording

    assert "the steps taken in the failing tick before its failure" in describe_recording(rec)


BAD_MAPPINGS = [
    ('"force[0]": Fx', '"force[0]": Fxx',
     r"components\.gust\.outputs\.wrench\.fields\.force\[0\]: FMU 'wind_gust\.py' has no variable 'Fxx' "
     r"\(outputs: Fx, Fy, Fz\)"),
    ('"force[0]": Fx', '"force[0]": vx',
     r"fields\.force\[0\]: variable 'vx' of FMU 'wind_gust\.py' has causality 'input'; a port's output must be "
     r"an output variable"),
    ('"velocity[0]": vx', 'attitude_locked: vx',
     r"inputs\.body\.fields\.attitude_locked: variable 'vx' of FMU 'wind_gust\.py' is Real, but "
     r"BodyState\.attitude_locked takes a boolean value"),
    ("start: {peak_speed: 8.0", "start: {peak_sped: 8.0",
     r"components\.gust\.start\.peak_sped: FMU 'wind_gust\.py' has no variable 'peak_sped' \(did you mean "
     r"'peak_speed'\?\)"),
    ("start: {peak_speed: 8.0", "start: {Fx: 8.0",
     r"start\.Fx: variable 'Fx' of FMU 'wind_gust\.py' is a continuous output; start values go to parameters"),
    ("start: {peak_speed: 8.0", "start: {peak_speed: fast",
     r"start\.peak_speed: variable 'peak_speed' of FMU 'wind_gust\.py' is Real; got 'fast'"),
    ('"force[0]": Fx', '"forces[0]": Fx', r"fields\.forces\[0\]: Wrench has no field 'forces\[0\]'"),
    # YAML reads an unquoted on, off, yes, no, ~ or a number as a value: said as such (it was "no variable True")
    ("start: {peak_speed: 8.0", "start: {on: 8.0",
     r"components\.gust\.start: a variable is named true, not a name: YAML reads null, ~, yes/no, on/off, "
     r"true/false and numbers as values; quote the name \(e\.g\. 'off'\)"),
    ('"force[0]": Fx', '"force[0]": off', r"fields\.force\[0\]: FMU 'wind_gust\.py' has no variable false "
     r"\(outputs: Fx, Fy, Fz\); false is a value, not a name: YAML reads null, ~, yes/no"),
    ('"force[0]": Fx', 'yes: Fx', r"outputs\.wrench\.fields: a field is named true, not a name: YAML reads null"),
    ("wrench: {type", "~: {type", r"outputs: port names must be identifiers \(they become channel names; got "
     r"null\); null is a value, not a name: YAML reads"),
    ('body: {type: BodyState, fields: {"velocity[0]": vx, "velocity[1]": vy, "velocity[2]": vz}}', "body: 12",
     r"inputs\.body: must be a variable name, or a mapping .* \(got 12\); 12 is a value, not a name"),
]


@pytest.mark.parametrize(("old", "new", "error"), BAD_MAPPINGS)
def test_a_mapping_that_does_not_fit_the_model_description_is_bad_input(old, new, error):
    text = gust_scene()
    assert old in text
    with pytest.raises(ScenarioError, match=error):
        loads(text.replace(old, new, 1))


def test_cosim_validate_says_it_in_one_line_naming_scene_fmu_and_variable(tmp_path, capsys):
    path = tmp_path / "gust.yaml"
    path.write_text(gust_scene().replace('"force[2]": Fz', '"force[2]": Fq'))
    assert main(["validate", str(path)]) == 2
    line = one_error_line(capsys.readouterr().err)
    assert line == (f"error: {path}: components.gust.outputs.wrench.fields.force[2]: FMU 'wind_gust.py' has no "
                    "variable 'Fq' (outputs: Fx, Fy, Fz)")


def test_a_missing_fmu_file_is_named_with_the_folder_it_was_looked_for_in(tmp_path):
    path = tmp_path / "gust.yaml"
    path.write_text(gust_scene(source="path: nowhere.fmu"))
    with pytest.raises(ScenarioError, match=r"components\.gust\.path: no such file 'nowhere\.fmu' \(looked in "):
        load(path)


def test_an_fmu_path_that_is_a_folder_is_said_to_be_no_file(tmp_path):
    """A folder (or a device, a pipe) at the FMU's path is there: "no such file" said otherwise."""
    (tmp_path / "gust.fmu").mkdir()
    path = tmp_path / "gust.yaml"
    path.write_text(gust_scene(source="path: gust.fmu"))
    with pytest.raises(ScenarioError, match=r"components\.gust\.path: not a file 'gust\.fmu' \(looked in "):
        load(path)


def test_a_scalar_output_is_a_number_port(tmp_path):
    text = gust_scene().replace(
        '      wrench: {type: Wrench, fields: {"force[0]": Fx, "force[1]": Fy, "force[2]": Fz}}',
        '      wrench: {type: Wrench, fields: {"force[0]": Fx, "force[1]": Fy, "force[2]": Fz}}\n      drag: Fx')
    scene = loads(text)
    comp = scene.instantiate()["gust"]
    out = comp.step(0, 2_000_000, {"body": None})
    assert out["drag"].value == out["wrench"].force[0]
    assert math.isfinite(out["drag"].value) and np.all(out["wrench"].torque == 0)


def test_a_pythonfmu_fmu_missing_its_model_module_is_refused_when_the_scene_loads(tmp_path):
    """An exported FMU whose model script was taken out of its resources: refused at load naming what
    is missing (its binary crashed the process, a segmentation fault with no word)."""
    import zipfile

    whole = build_fmu(GUST_MODEL, tmp_path / "whole.fmu")
    damaged = tmp_path / "damaged.fmu"
    with zipfile.ZipFile(whole) as src, zipfile.ZipFile(damaged, "w") as dst:
        for item in src.infolist():
            if item.filename != "resources/wind_gust.py":
                dst.writestr(item, src.read(item.filename))
    path = tmp_path / "gust.yaml"
    path.write_text(gust_scene(source=f"path: {damaged}"))
    with pytest.raises(ScenarioError, match=r"components\.gust: .*its model module 'wind_gust' is missing from its "
                                            r"resources \(no resources/wind_gust\.py\): the FMU is damaged"):
        load(path)


def test_a_start_value_that_is_not_finite_is_refused_when_the_scene_loads(tmp_path):
    """start: {peak_speed: .nan}: bad input naming the variable (it passed, and the run failed at its
    first output with a non-finite wrench)."""
    path = tmp_path / "gust.yaml"
    path.write_text(gust_scene(start="{peak_speed: .nan, start_time: 0.05, duration: 0.1}"))
    with pytest.raises(ScenarioError, match=r"components\.gust\.start\.peak_speed: must be finite \(got nan\)"):
        load(path)


def test_an_fmu_without_a_binary_for_this_platform_is_named_inside_the_fmu_file(tmp_path):
    """The missing library is named inside the FMU file ('damaged.fmu:binaries/linux64/...'), not in
    the temporary folder it was unpacked to and has already left."""
    import zipfile

    whole = build_fmu(GUST_MODEL, tmp_path / "whole.fmu")
    damaged = tmp_path / "damaged.fmu"
    with zipfile.ZipFile(whole) as src, zipfile.ZipFile(damaged, "w") as dst:
        for item in src.infolist():
            if not item.filename.startswith("binaries/"):
                dst.writestr(item, src.read(item.filename))
    path = tmp_path / "gust.yaml"
    path.write_text(gust_scene(source=f"path: {damaged}"))
    with pytest.raises(ScenarioError) as info:
        load(path)
    (problem,) = info.value.problems
    assert f"{damaged}:binaries/" in problem and "/tmp/tmp" not in problem


BOUNDED_MODEL = '''
from pythonfmu import Fmi2Causality, Fmi2Slave, Fmi2Variability, Integer, Real

globals().setdefault("_held_namespaces", []).append(globals())  # see scenarios/models/wind_gust.py


class Bounded(Fmi2Slave):
    """y = gain * count."""

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.count, self.gain, self.y = 1, 1.0, 0.0
        for variable in (Integer("count", causality=Fmi2Causality.parameter, variability=Fmi2Variability.tunable),
                         Real("gain", causality=Fmi2Causality.parameter, variability=Fmi2Variability.tunable),
                         Real("y", causality=Fmi2Causality.output)):
            self.register_variable(variable)

    def do_step(self, current_time, step_size):
        self.y = self.gain * self.count
        return True
'''

BOUNDED_SCENE = """
name: bounded
dt: 0.001
until: 0.01
components:
  scale:
    type: FMU
    path: bounded.fmu
    start: <START>
    outputs: {y: y}
"""


@pytest.fixture(scope="module")
def bounded_fmu(tmp_path_factory):
    """An FMU with an Integer parameter count (min 0, max 100) and a Real one, gain (max 30): the
    bounds written into its model description (pythonfmu writes none)."""
    import re
    import zipfile

    folder = tmp_path_factory.mktemp("bounded")
    (folder / "bounded.py").write_text(BOUNDED_MODEL)
    plain = build_fmu(folder / "bounded.py", folder / "plain.fmu")
    with zipfile.ZipFile(plain) as src, zipfile.ZipFile(folder / "bounded.fmu", "w") as dst:
        for item in src.infolist():
            data = src.read(item.filename)
            if item.filename == "modelDescription.xml":
                text = re.sub(r'(name="count"[^>]*>\s*<Integer)', r'\1 min="0" max="100"', data.decode())
                data = re.sub(r'(name="gain"[^>]*>\s*<Real)', r'\1 max="30"', text).encode()
            dst.writestr(item, data)
    return folder


@pytest.mark.parametrize(("start", "said"), [
    ("{count: 10000000000}", "components.scale.start.count: variable 'count' of FMU 'bounded.fmu' is Integer, a "
     "32-bit signed integer, from -2147483648 to 2147483647; got 10000000000"),
    ("{count: 101}", "components.scale.start.count: must be at most 100, the max of variable 'count' of FMU "
     "'bounded.fmu' (got 101)"),
    ("{count: -1}", "components.scale.start.count: must be at least 0, the min of variable 'count' of FMU "
     "'bounded.fmu' (got -1)"),
    ("{gain: 30.5}", "components.scale.start.gain: must be at most 30, the max of variable 'gain' of FMU "
     "'bounded.fmu' (got 30.5)"),
])
def test_a_start_value_outside_its_variables_range_is_refused_when_the_scene_loads(bounded_fmu, start, said):
    """An integer beyond its type's 32 bits, or a value beyond the min or max the model description
    gives: bad input naming the variable, the rule and the value (10000000000 was set as 1410065408,
    wrapped around, and the bounds were not read)."""
    path = bounded_fmu / "scene.yaml"
    path.write_text(BOUNDED_SCENE.replace("<START>", start))
    with pytest.raises(ScenarioError) as info:
        load(path)
    assert info.value.problems == [said]
    path.write_text(BOUNDED_SCENE.replace("<START>", "{count: 100, gain: 30.0}"))  # on the bounds: taken
    assert load(path).components["scale"].cls.start_values == {"count": 100, "gain": 30.0}


@pytest.mark.parametrize(("fmu_type", "version", "inside", "outside"), [
    ("Int8", "3.0", (-128, 127), (-129, 128)), ("UInt8", "3.0", (0, 255), (-1, 256)),
    ("Int16", "3.0", (-32768, 32767), (-32769, 32768)), ("UInt16", "3.0", (0, 65535), (-1, 65536)),
    ("Int32", "3.0", (-2**31, 2**31 - 1), (-2**31 - 1, 2**31)), ("UInt32", "3.0", (0, 2**32 - 1), (-1, 2**32)),
    ("Int64", "3.0", (-2**63, 2**63 - 1), (-2**63 - 1, 2**63)), ("UInt64", "3.0", (0, 2**64 - 1), (-1, 2**64)),
    ("Enumeration", "3.0", (-2**63, 2**63 - 1), (-2**63 - 1, 2**63)),
    ("Enumeration", "2.0", (-2**31, 2**31 - 1), (-2**31 - 1, 2**31)),
])
def test_each_integer_type_takes_the_start_values_its_width_holds(fmu_type, version, inside, outside):
    """FMI 3.0's Int8 ... UInt64 as their names say, an Enumeration as FMI 2.0's Integer or FMI 3.0's
    Int64: each end taken, one past it refused naming the type and the value."""
    from types import SimpleNamespace

    from components.fmu.mapping import parse_start

    var = SimpleNamespace(name="n", type=fmu_type, causality="parameter", variability="fixed", min=None, max=None,
                          declaredType=None)
    for value in inside:
        problems: list[str] = []
        assert parse_start({"n": value}, "'m.fmu'", {"n": var}, "components.m", problems, version) == {"n": value}
        assert problems == []
    for value in outside:
        problems = []
        assert parse_start({"n": value}, "'m.fmu'", {"n": var}, "components.m", problems, version) == {}
        (problem,) = problems
        assert problem.startswith(f"components.m.start.n: variable 'n' of FMU 'm.fmu' is {fmu_type}, a ")
        assert problem.endswith(f"; got {value}")


def test_a_declared_types_bounds_hold_where_the_variable_gives_none():
    """A variable with declaredType="Angle" (min -180, max 180) and a max of its own, 90: its own max
    and its type's min hold, as FMI reads them."""
    from types import SimpleNamespace

    from components.fmu.mapping import parse_start

    angle = SimpleNamespace(min="-180", max="180")
    var = SimpleNamespace(name="a", type="Real", causality="parameter", variability="fixed", min=None, max="90",
                          declaredType=angle)
    problems: list[str] = []
    assert parse_start({"a": -180.0}, "'m.fmu'", {"a": var}, "components.m", problems) == {"a": -180.0}
    assert parse_start({"a": -181.0}, "'m.fmu'", {"a": var}, "components.m", problems) == {}
    assert parse_start({"a": 91}, "'m.fmu'", {"a": var}, "components.m", problems) == {}
    assert problems == [
        "components.m.start.a: must be at least -180, the min of variable 'a' of FMU 'm.fmu' (got -181.0)",
        "components.m.start.a: must be at most 90, the max of variable 'a' of FMU 'm.fmu' (got 91)"]


def test_an_fmu_cache_that_cannot_be_used_is_named_with_its_setting_and_the_reason(tmp_path, monkeypatch, capsys):
    """$COSIM_FMU_CACHE naming a file: exit 2 in one line naming the component's model, the cache, the
    setting and the system's reason (the line named only a folder inside the cache: 'error:
    .../f8c2...: Not a directory')."""
    not_a_folder = tmp_path / "some_file"
    not_a_folder.write_text("a file")
    monkeypatch.setenv("COSIM_FMU_CACHE", str(not_a_folder))
    path = tmp_path / "gust.yaml"
    path.write_text(gust_scene())
    assert main(["validate", str(path)]) == 2
    assert one_error_line(capsys.readouterr().err) == (
        f"error: {path}: components.gust.model: {GUST_MODEL}: cannot keep its FMU in the FMU cache {not_a_folder} "
        "($COSIM_FMU_CACHE): Not a directory")


def _with_model_description(src: Path, dst: Path, edit) -> Path:
    """A copy of the FMU ``src`` at ``dst`` whose modelDescription.xml is ``edit(text)``."""
    import zipfile

    with zipfile.ZipFile(src) as old, zipfile.ZipFile(dst, "w") as new:
        for item in old.infolist():
            data = old.read(item.filename)
            if item.filename == "modelDescription.xml":
                data = edit(data.decode()).encode()
            new.writestr(item, data)
    return dst


ONCE_SCENE = """
name: once
dt: 0.001
until: 0.005
components:
<COMPONENTS>
record: {visual_rate: 0}
"""


def test_an_fmu_instantiated_only_once_per_process_is_refused_a_second_instance(bounded_fmu, tmp_path, capsys):
    """canBeInstantiatedOnlyOncePerProcess: two components of one such FMU are refused naming the one
    that holds it (both were made: an FMU enforcing it failed without saying why, one keeping its
    state in globals ran both on one state); one component runs, and runs again once it is let go."""
    _with_model_description(bounded_fmu / "plain.fmu", tmp_path / "once.fmu", lambda text: text.replace(
        'canBeInstantiatedOnlyOncePerProcess="false"', 'canBeInstantiatedOnlyOncePerProcess="true"'))
    one = "  a: {type: FMU, path: once.fmu, outputs: {y: y}}"
    scene = tmp_path / "two.yaml"
    scene.write_text(ONCE_SCENE.replace("<COMPONENTS>", one + "\n" + one.replace("a:", "b:")))
    assert main(["run", str(scene), "-o", str(tmp_path / "two.mcap")]) == 2
    said = one_error_line(capsys.readouterr().err)
    assert ("components.b: cannot be built from these values: ValueError: once.fmu: the FMU can be instantiated "
            "only once per process (canBeInstantiatedOnlyOncePerProcess), and 'a' already holds its instance") in said
    assert not (tmp_path / "two.mcap").exists()
    single = tmp_path / "one.yaml"
    single.write_text(ONCE_SCENE.replace("<COMPONENTS>", one))
    for _ in range(2):
        assert run_scene(load(single), None, progress=False).result.status == "ok"


def test_an_fmu_that_cannot_be_instantiated_says_why_in_its_own_words(tmp_path, capsys, monkeypatch):
    """A model whose constructor raises (here when the process has BROKEN set: its build instantiates
    it too): the error quotes what the FMU logged (it said only FMPy's 'Failed to instantiate model').
    Its binary's double release at exit is headed off all the same: the failed instantiate had made
    the Python state released twice, and the test process that ran it could abort at exit
    ("corrupted double-linked list", exit 134, once in CI after every test had passed)."""
    from cosim.fmi import pythonfmu_exit

    guarded = set(pythonfmu_exit._guarded)
    model = tmp_path / "broken.py"
    model.write_text(BOUNDED_MODEL.replace("super().__init__(**kwargs)", (
        "super().__init__(**kwargs)\n        import os\n"
        "        if os.environ.get('BROKEN'):\n            raise RuntimeError('no calibration table')")))
    build_fmu(model, tmp_path / "broken.fmu")
    monkeypatch.setenv("BROKEN", "1")
    scene = tmp_path / "broken.yaml"
    scene.write_text(ONCE_SCENE.replace("<COMPONENTS>", "  a: {type: FMU, path: broken.fmu, outputs: {y: y}}"))
    assert main(["run", str(scene), "-o", str(tmp_path / "broken.mcap")]) == 2
    said = one_error_line(capsys.readouterr().err)
    assert "FMU 'broken.fmu': instantiate returned no instance (Failed to instantiate model): [Fatal]" in said
    assert "RuntimeError('no calibration table')" in said
    assert [Path(p).name for p in pythonfmu_exit._guarded - guarded] == ["Bounded.so"]


def test_an_fmu_with_neither_path_nor_model_is_told_that_alone(tmp_path):
    """Neither given: the one problem (a second said "no such file None")."""
    scene = tmp_path / "none.yaml"
    scene.write_text(ONCE_SCENE.replace("<COMPONENTS>", "  a: {type: FMU, outputs: {y: y}}"))
    with pytest.raises(ScenarioError) as info:
        load(scene)
    assert info.value.problems == [
        "components.a.path: give either path (an .fmu file) or model (a pythonfmu .py file), one of them"]


ODD_MODEL = '''
from pythonfmu import Fmi2Causality, Fmi2Slave, Fmi2Variability, Integer, Real

globals().setdefault("_held_namespaces", []).append(globals())  # see scenarios/models/wind_gust.py


class Odd(Fmi2Slave):
    """At its first step: n = 99 (mode 1) or r = nan (mode 2); else n = 1, r = 1."""

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.mode, self.n, self.r = 0, 0, 0.0
        for variable in (Integer("mode", causality=Fmi2Causality.parameter, variability=Fmi2Variability.tunable),
                         Integer("n", causality=Fmi2Causality.output, variability=Fmi2Variability.discrete),
                         Real("r", causality=Fmi2Causality.output)):
            self.register_variable(variable)

    def do_step(self, current_time, step_size):
        self.n = 99 if self.mode == 1 else 1
        self.r = float("nan") if self.mode == 2 else 1.0
        return True
'''


@pytest.mark.parametrize(("mode", "said"), [
    (1, "component 'odd' failed at t = 0 s: ValueError: FMU 'odd.py': variable 'n' = 99 is no StageId (port st, "
        "field stage; its values: 0 approach, 1 hit, 2 slide, 3 fly_away, 4 sink, 5 rest, 6 float, 7 left_pond, "
        "8 ground)"),
    (2, "component 'odd' failed at t = 0 s: non-finite value in output 'r' field 'value'"),
])
def test_an_fmu_output_its_port_cannot_take_names_the_variable_and_counts_the_call(tmp_path, mode, said):
    """An enum's number out of its range named with the FMU, variable, port and the enum's values (it
    said "99 is not a valid StageId"); the doStep that gave it, or a NaN, is counted (it said "0
    doStep calls")."""
    (tmp_path / "odd.py").write_text(ODD_MODEL)
    scene = tmp_path / "odd.yaml"
    scene.write_text(ONCE_SCENE.replace("<COMPONENTS>", f"  odd: {{type: FMU, model: odd.py, start: {{mode: {mode}}}, "
                                        "outputs: {r: r, st: {type: Stage, fields: {stage: n}}}}"))
    outcome = run_scene(load(scene), None, progress=False)
    assert outcome.result.status == "failed"
    assert outcome.result.reason.startswith(said), outcome.result.reason
    assert "odd: FMU 'odd.py' (FMI 2.0), 1 doStep call" in outcome.summary


def test_a_build_whose_copy_into_place_fails_leaves_no_part_file(tmp_path, monkeypatch):
    """A full disk while the built FMU is copied into place: the error goes on to the caller, and no
    hidden part file is left beside the destination (each failed attempt left one, under its own
    process id, that nothing ever removed)."""
    import errno
    import shutil

    def full_disk(src, dst):
        with open(dst, "wb") as out:
            out.write(b"half an fmu")
        raise OSError(errno.ENOSPC, "No space left on device", str(dst))

    monkeypatch.setattr(shutil, "copyfile", full_disk)
    with pytest.raises(OSError, match="No space left"):
        build_fmu(GUST_MODEL, tmp_path / "gust.fmu")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("key", ["model", "path"])
def test_an_fmu_file_name_too_long_for_the_file_system_is_said_on_its_key(tmp_path, key):
    """A model or path of 300 characters: the file system refuses to look it up; said on the scene's
    key, the name shortened (it was the raw OSError, naming neither the key nor the scene, the whole
    name on the line)."""
    path = tmp_path / "gust.yaml"
    path.write_text(gust_scene(source=f"{key}: {'x' * 300}"))
    with pytest.raises(ScenarioError, match=rf"components\.gust\.{key}: cannot be looked up: File name too long "
                                            r"\(300 characters: 'x{57}\.\.\.'\)"):
        load(path)


_GAIN_MODEL = '''from pythonfmu import Fmi2Causality, Fmi2Slave, Real


class Gain(Fmi2Slave):
    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.y = 0.0
        self.register_variable(Real("y", causality=Fmi2Causality.output))

    def do_step(self, t, h):
        self.y = {gain} * (t + h)
        return True
'''


def test_two_models_of_one_file_name_are_refused_rather_than_one_running_the_others_code(tmp_path):
    """PythonFMU imports an FMU's model module by name, once per process: b/gain.py ran a/gain.py's
    code (y = t where it says 100 t), the run said ok and its replay vouched for it. Refused as the
    scene loads, naming the module and what to do; the same model twice is one module and runs."""
    for folder, gain in (("a", 1.0), ("b", 100.0)):
        (tmp_path / folder).mkdir()
        (tmp_path / folder / "gain.py").write_text(_GAIN_MODEL.format(gain=gain))
    scene = ("name: twin\ndt: 0.01\nuntil: 0.03\ncomponents:\n"
             "  a: {{type: FMU, model: a/gain.py, outputs: {{y: y}}}}\n"
             "  b: {{type: FMU, model: {b}/gain.py, outputs: {{y: y}}}}\n"
             "record: {{visual_rate: 0, checkpoint_every: 0}}\n")
    twins = tmp_path / "twins.yaml"
    twins.write_text(scene.format(b="b"))
    with pytest.raises(ScenarioError, match=r"components\.b: .*its model module 'gain' is already loaded in this "
                                            r"process .* and differs from this FMU's; .*give the model's file a "
                                            r"name of its own"):
        load(twins)
    same = tmp_path / "same.yaml"
    same.write_text(scene.format(b="a"))
    outcome = run_scene(load(same), tmp_path / "same.mcap", progress=False)
    assert outcome.result.status == "ok"
    recording = Recording(outcome.recording)
    for name in ("a", "b"):
        assert [m.value for _, m in recording.messages(f"/{name}/y", Number)] == pytest.approx([0.0, 0.01, 0.02, 0.03])


def test_a_model_module_whose_file_is_gone_is_let_go_for_the_next_fmu_to_import_its_own(tmp_path):
    """A model module held from an FMU FMPy unpacked, ran and deleted cannot be compared with the next
    FMU's of the same name: kept, the next one ran its code (b's gain.py running a's); it is let go,
    so that PythonFMU imports the next FMU's own file."""
    import sys
    import types

    from components.fmu.instance import _check_module_not_taken

    for folder, gain in (("a", 1), ("b", 2)):
        (tmp_path / folder).mkdir()
        (tmp_path / folder / "gone_gain.py").write_text(f"K = {gain}\n")
    held = types.ModuleType("gone_gain")
    held.__file__ = str(tmp_path / "a" / "gone_gain.py")
    sys.modules["gone_gain"] = held
    try:
        with pytest.raises(ValueError, match="already loaded in this process"):
            _check_module_not_taken("gone_gain", tmp_path / "b", tmp_path / "b.fmu")
        (tmp_path / "a" / "gone_gain.py").unlink()
        _check_module_not_taken("gone_gain", tmp_path / "b", tmp_path / "b.fmu")
        assert "gone_gain" not in sys.modules
    finally:
        sys.modules.pop("gone_gain", None)
