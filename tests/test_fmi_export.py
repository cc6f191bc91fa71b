"""A scene exported as an FMU (``cosim fmu export``): FMPy finds its model description valid,
simulating it gives the trajectory and skip count of ``cosim run`` at the same times, bit for bit,
and the FMU imported back into another scene (``type: FMU``) does the same.

    skip.yaml --cosim fmu export--> skip.fmu --FMPy simulate_fmu--> rows every 10 ms
                                             --type: FMU, every 20--> /throw/stage, /throw/velocity
"""

from __future__ import annotations

import errno
import math
import os
import re
import zipfile
from pathlib import Path

import numpy as np
import pytest

fmpy = pytest.importorskip("fmpy")
pytest.importorskip("pythonfmu")

from fmpy.validation import validate_fmu  # noqa: E402

from components.messages import BodyState, Stage  # noqa: E402
from cosim.cli import main  # noqa: E402
from cosim.examples import Number  # noqa: E402
from cosim.record.reader import Recording  # noqa: E402
from cosim.replay import restart_simulation  # noqa: E402
from cosim.runner import run_scene  # noqa: E402
from cosim.scenario import load  # noqa: E402
from tests.cli_toys import fill_leaving, one_error_line, small_disk  # noqa: E402
from tests.fmu_toys import SKIP_SCENE, fmu_cache  # noqa: E402, F401

pytestmark = pytest.mark.usefixtures("fmu_cache")

UNTIL = 0.6  # [s] three skips of the reference throw
UNTIL_NS = 600_000_000
STEP = 0.01  # [s] the communication step: 20 base steps of 0.5 ms

IMPORT_SCENE = """
name: skip_as_fmu
dt: 0.0005
until: 0.6
components:
  throw:
    type: FMU
    path: skip.fmu
    every: 20
    outputs:
      stage: {type: Stage, fields: {stage: stage, skips: skips, x: x}}
      vz: vz
record: {visual_rate: 0, checkpoint_every: 0}
"""


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    """skip.fmu exported by the command line, beside a recorded ``cosim run`` of the same 0.6 s."""
    folder = tmp_path_factory.mktemp("export")
    fmu = folder / "skip.fmu"
    assert main(["fmu", "export", str(SKIP_SCENE), "-o", str(fmu), "--step", str(STEP)]) == 0
    outcome = run_scene(load(SKIP_SCENE), folder / "skip.mcap", until_ns=UNTIL_NS, progress=False)
    assert outcome.result.status == "ok", outcome.result.reason
    return fmu, Recording(outcome.recording)


def _recorded(rec: Recording) -> tuple[dict[int, BodyState], list[tuple[int, Stage]]]:
    return dict(rec.messages("/stone/state", BodyState)), rec.messages("/stages/stage", Stage)


def _skips_at(stages: list[tuple[int, Stage]], time_ns: int) -> int:
    return max((m.skips for t, m in stages if t <= time_ns), default=0)


def test_fmpy_finds_no_problem_in_the_model_description(exported):
    fmu, _ = exported
    assert validate_fmu(str(fmu)) == []
    md = fmpy.read_model_description(str(fmu))
    assert md.fmiVersion == "2.0" and md.coSimulation.modelIdentifier == "skip"
    assert [v.name for v in md.modelVariables if v.causality == "parameter"] == [
        "speed", "angle_deg", "tilt_deg", "spin"]
    assert [v.name for v in md.modelVariables if v.causality == "output"] == [
        "x", "y", "z", "vx", "vy", "vz", "stage", "skips"]
    assert md.defaultExperiment.stepSize == "0.01"
    assert md.coSimulation.canGetAndSetFMUstate and md.coSimulation.canSerializeFMUstate


def test_fmpy_simulates_the_trajectory_and_skips_of_cosim_run_bit_for_bit(exported):
    fmu, rec = exported
    states, stages = _recorded(rec)
    rows = fmpy.simulate_fmu(str(fmu), stop_time=UNTIL, output_interval=STEP)
    assert len(rows) == 61
    for row in rows:
        stamp = round(row["time"] * 1e9)
        want = states[stamp]
        got = np.array([row[k] for k in ("x", "y", "z", "vx", "vy", "vz")])
        assert got.tobytes() == np.concatenate([want.position, want.velocity]).tobytes(), stamp
        assert row["skips"] == _skips_at(stages, stamp)
    assert rows["skips"][-1] == 3


def test_a_changed_throw_parameter_changes_the_throw(exported):
    fmu, _ = exported
    rows = fmpy.simulate_fmu(str(fmu), stop_time=STEP, output_interval=STEP, start_values={"speed": 6.0})
    angle = math.atan2(1.39, 7.88)  # the scene's own angle below the horizontal
    assert rows["vx"][0] == pytest.approx(6.0 * math.cos(angle), rel=1e-15)
    assert rows["vz"][0] == pytest.approx(-6.0 * math.sin(angle), rel=1e-15)


def test_the_exported_skip_imported_back_as_a_component_runs_the_same_throw(exported, tmp_path):
    fmu, rec = exported
    states, stages = _recorded(rec)
    (tmp_path / "skip.fmu").write_bytes(fmu.read_bytes())
    scene_path = tmp_path / "skip_as_fmu.yaml"
    scene_path.write_text(IMPORT_SCENE)
    outcome = run_scene(load(scene_path), tmp_path / "imported.mcap", progress=False)
    assert outcome.result.status == "ok", outcome.result.reason
    imported = Recording(outcome.recording)
    seen = imported.messages("/throw/stage", Stage)
    vz = dict(imported.messages("/throw/vz", Number))
    assert len(seen) == 61
    for stamp, msg in seen:
        assert np.float64(msg.x).tobytes() == states[stamp].position[:1].tobytes()
        assert np.float64(vz[stamp].value).tobytes() == states[stamp].velocity[2:].tobytes()
        assert msg.skips == _skips_at(stages, stamp)
    assert seen[-1][1].skips == 3


def test_two_scenes_exported_under_one_name_run_side_by_side_each_its_own(exported, tmp_path):
    """PythonFMU runs one model module of a name per process: two FMUs exported as skip.fmu from two
    scenes share one module text (each runs the scene of its own resources), so one scene holds both
    (a module that differed would be refused as the scene loads: tests/test_fmu_component.py)."""
    fmu, rec = exported
    states, _ = _recorded(rec)
    (tmp_path / "a").mkdir()
    (tmp_path / "a" / "skip.fmu").write_bytes(fmu.read_bytes())
    assert main(["fmu", "export", str(SKIP_SCENE), "-o", str(tmp_path / "b" / "skip.fmu"), "--step", str(STEP),
                 "--set", "components.stone.velocity=[6.88, 0.0, -1.39]"]) == 0
    both = IMPORT_SCENE.replace("until: 0.6", "until: 0.05").replace("path: skip.fmu", "path: a/skip.fmu")
    both += both[both.index("  throw:"):both.index("record:")].replace("throw:", "other:").replace("a/skip", "b/skip")
    both = both.replace("\nrecord: {visual_rate: 0, checkpoint_every: 0}\n  other:", "\n  other:")
    both += "record: {visual_rate: 0, checkpoint_every: 0}\n"
    (tmp_path / "both.yaml").write_text(both)
    outcome = run_scene(load(tmp_path / "both.yaml"), tmp_path / "both.mcap", progress=False)
    assert outcome.result.status == "ok", outcome.result.reason
    imported = Recording(outcome.recording)
    a, b = (dict(imported.messages(f"/{name}/stage", Stage)) for name in ("throw", "other"))
    assert sorted(a) == sorted(b) and len(a) == 6
    for stamp in a:
        assert np.float64(a[stamp].x).tobytes() == states[stamp].position[:1].tobytes()
    assert b[50_000_000].x == pytest.approx(a[50_000_000].x - 0.05, abs=1e-12)  # b thrown 1 m/s slower


def test_the_imported_skip_restarts_from_a_checkpoint_through_the_fmus_own_state(exported, tmp_path):
    """The exported FMU saves its state (the scene's checkpoint); a restart of the importing scene from
    0.3 s ends where the whole run ends, bit for bit."""
    fmu, _ = exported
    (tmp_path / "skip.fmu").write_bytes(fmu.read_bytes())
    scene_path = tmp_path / "skip_as_fmu.yaml"
    scene_path.write_text(IMPORT_SCENE.replace("checkpoint_every: 0", "checkpoint_every: 0.3"))
    whole = run_scene(load(scene_path), tmp_path / "whole.mcap", progress=False)
    sim, stamp = restart_simulation(Recording(whole.recording), 300_000_000)
    again = run_scene(sim.scene, tmp_path / "again.mcap", simulation=sim, progress=False)
    assert stamp == 300_000_000 and again.result.status == "ok"
    first = Recording(whole.recording).messages("/throw/stage", Stage)[-1]
    second = Recording(again.recording).messages("/throw/stage", Stage)[-1]
    assert second[0] == first[0] == UNTIL_NS
    assert np.float64(second[1].x).tobytes() == np.float64(first[1].x).tobytes() and second[1].skips == 3


def test_a_communication_step_off_the_base_step_grid_is_refused_with_the_reason(tmp_path, capsys):
    out = tmp_path / "bad.fmu"
    assert main(["fmu", "export", str(SKIP_SCENE), "-o", str(out), "--step", "0.0007"]) == 2
    line = one_error_line(capsys.readouterr().err)
    assert "--step: a communication step of 0.0007 s is not a whole multiple of the scene's base step " \
           "dt = 0.0005 s" in line
    assert not out.exists()


def test_an_fmu_name_too_long_for_its_model_identifier_is_refused_before_the_build(tmp_path, capsys):
    """An FMU named in 251 characters: exit 2 naming the limit, before any build (it failed inside
    the build, naming a temporary file)."""
    out = tmp_path / ("c" * 251 + ".fmu")
    assert main(["fmu", "export", str(SKIP_SCENE), "-o", str(out)]) == 2
    assert "an FMU's name (its model identifier) is at most 200 characters (got 251)" in one_error_line(
        capsys.readouterr().err)
    assert not out.exists()


@pytest.mark.parametrize(("step", "said"), [
    ("1e300", "--step 1e+300 s: must be at most 9.22e+09 s"),
    ("1e-12", "--step: a communication step of 1e-12 s is not a whole multiple"),
])
def test_a_communication_step_beyond_the_clock_or_below_a_nanosecond_is_named_as_given(tmp_path, capsys, step,
                                                                                        said):
    """--step 1e300: exit 2 with the bound (it ended in an internal OverflowError); 1e-12: the step as
    given, not its rounding to whole nanoseconds ('a communication step of 0 s')."""
    out = tmp_path / "bad.fmu"
    assert main(["fmu", "export", str(SKIP_SCENE), "-o", str(out), "--step", step]) == 2
    assert said in one_error_line(capsys.readouterr().err)
    assert not out.exists()


def test_an_importer_stepping_off_the_grid_gets_the_fmus_reason(exported, tmp_path):
    """An importing scene whose step is 0.7 ms: the FMU refuses its first doStep, naming both steps."""
    fmu, _ = exported
    (tmp_path / "skip.fmu").write_bytes(fmu.read_bytes())
    scene_path = tmp_path / "off.yaml"
    scene_path.write_text(IMPORT_SCENE.replace("dt: 0.0005", "dt: 0.0007").replace("every: 20", "every: 1"))
    outcome = run_scene(load(scene_path), None, progress=False)
    assert outcome.result.status == "failed"
    assert "FMU 'skip.fmu' doStep returned" in outcome.result.reason
    assert "a communication step of 0.0007 s is not a whole multiple of the scene's base step dt = 0.0005 s" \
        in outcome.result.reason


def test_a_refused_do_step_leaves_the_fmu_usable(exported):
    """A doStep off the base step's grid, or from another time, is refused with Discard and a logged
    reason; the instance stays usable, and the right doStep then runs (an answer of Fatal left it
    dead, and a further call crashed the process)."""
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave

    fmu_path, _ = exported
    md = read_model_description(str(fmu_path))
    slave = FMU2Slave(guid=md.guid, unzipDirectory=extract(str(fmu_path)),
                      modelIdentifier=md.coSimulation.modelIdentifier, instanceName="refused")
    slave.instantiate()
    slave.setupExperiment(startTime=0.0)
    slave.enterInitializationMode()
    slave.exitInitializationMode()
    for t, h in ((0.0, 0.0007), (0.5, 0.01)):
        with pytest.raises(Exception, match=r"fmi2DoStep failed with status 2 \(discard\)"):
            slave.doStep(currentCommunicationPoint=t, communicationStepSize=h)
    slave.doStep(currentCommunicationPoint=0.0, communicationStepSize=0.01)
    x = slave.getReal([next(v.valueReference for v in md.modelVariables if v.name == "x")])[0]
    assert x > 0.3  # the stone moved on from x = 0.3 m
    slave.terminate()
    slave.freeInstance()


def test_an_output_the_scene_does_not_have_is_refused(tmp_path, capsys):
    code = main(["fmu", "export", str(SKIP_SCENE), "-o", str(tmp_path / "x.fmu"),
                 "--output-var", "w=stone.state.spin"])
    assert code == 2
    assert "output 'w': BodyState has no field 'spin'" in one_error_line(capsys.readouterr().err)


@pytest.mark.parametrize("where", ["a_file/skip.fmu", "folder_ending/", "an_existing_folder"])
def test_an_fmu_path_that_cannot_be_written_is_refused_before_the_build(tmp_path, capsys, where):
    """-o under a file, ending in a separator, or naming a folder: exit 2 at once, one line naming
    the path (it was found only after the minute-long build, as 'File exists')."""
    (tmp_path / "a_file").write_text("not a folder")
    (tmp_path / "an_existing_folder").mkdir()
    with pytest.raises(SystemExit) as exit_:
        main(["fmu", "export", str(SKIP_SCENE), "-o", str(tmp_path / where) + ("/" if where.endswith("/") else "")])
    assert exit_.value.code == 2
    line = one_error_line(capsys.readouterr().err)
    assert "argument -o/--output" in line and str(tmp_path) in line


def test_the_throw_preset_offers_no_parameter_a_script_overrides():
    """A body whose velocity and tilt are scripted (scenarios/scripted_skim.yaml): no speed, angle,
    tilt or spin parameter (they changed no output, and a tilt made the FMU fail to initialize);
    the reference skip keeps all four."""
    from pathlib import Path

    from components.fmu import throw
    from cosim.scenario import load

    root = Path(__file__).resolve().parents[1] / "scenarios"
    assert [p.name for p in throw.parameters(load(root / "scripted_skim.yaml"))] == []
    assert [p.name for p in throw.parameters(load(root / "skip.yaml"))] == ["speed", "angle_deg", "tilt_deg", "spin"]


@pytest.mark.parametrize("name, identifier", [("class.fmu", "fmu_class"), ("None.fmu", "fmu_None"),
                                              ("9lives.fmu", "fmu_9lives"), ("my skip.fmu", "my_skip"),
                                              ("__class__.fmu", "fmu___class__"), ("__dict__.fmu", "fmu___dict__")])
def test_a_file_name_that_is_no_python_class_name_gets_an_identifier_that_is(name, identifier):
    """The model identifier names the slave's Python class: a keyword (class.fmu) made the build fail
    with a SyntaxError, reported as an internal error; a dunder (__class__.fmu) was written, and the
    binary then found the module's own __class__ in its place, and could not instantiate it."""
    from pathlib import Path

    from cosim.fmi.export import model_identifier

    assert model_identifier(Path(name)) == identifier


@pytest.mark.parametrize("name, identifier", [("skïp.fmu", "sk_p"), ("été.fmu", "_t_"), ("ü.fmu", "_"),
                                              ("٣lives.fmu", "_lives"), ("Ωmega 2.fmu", "_mega_2")])
def test_a_file_name_beyond_ascii_gets_an_ascii_c_identifier(name, identifier):
    """FMI's model identifier is a C identifier, ASCII letters, digits and _ (skïp.fmu kept its ï, a
    letter to Python's \\w but none to C)."""
    from cosim.fmi.export import model_identifier

    got = model_identifier(Path(name))
    assert got == identifier and re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", got)


def test_an_fmu_named_beyond_ascii_exports_and_passes_fmpys_validation(tmp_path):
    """skïp.fmu exports with the model identifier sk_p, in which FMPy finds no problem."""
    out = tmp_path / "skïp.fmu"
    assert main(["fmu", "export", str(SKIP_SCENE), "-o", str(out), "--step", str(STEP)]) == 0
    assert fmpy.read_model_description(str(out)).coSimulation.modelIdentifier == "sk_p"
    assert validate_fmu(str(out)) == []


INNER_SCENE = """
name: outer
dt: 0.001
until: 0.01
components:
  stone: {type: RigidBody, position: [0, 0, 1.0], velocity: [8.0, 0.0, -1.0], lock_attitude: true}
  gust:
    type: FMU
    path: inner.fmu
    inputs: {body: {type: BodyState, fields: {"velocity[0]": vx}}}
    outputs: {wrench: {type: Wrench, fields: {"force[0]": Fx}}}
connections:
  - stone.state -> gust.body
  - {from: gust.wrench, to: stone.wrench, delay: 1, initial: {force: [0, 0, 0], torque: [0, 0, 0]}}
"""


@pytest.mark.parametrize("given", ["inner.fmu", "new/../inner.fmu", "link.fmu"])
def test_an_fmu_the_scene_itself_uses_is_not_replaced_by_its_export(tmp_path, monkeypatch, capsys, given):
    """-o naming the scene's own FMU (components.gust.path), as written, through a folder not made
    yet, or through a link: exit 2 naming the component and its key, the FMU as it was and no
    folder made (the export silently replaced it, and the scene in it then ran itself)."""
    from cosim.fmi.build import cached_fmu
    from tests.fmu_toys import GUST_MODEL

    monkeypatch.chdir(tmp_path)
    (tmp_path / "inner.fmu").write_bytes(cached_fmu(GUST_MODEL).read_bytes())
    (tmp_path / "link.fmu").symlink_to("inner.fmu")
    (tmp_path / "outer.yaml").write_text(INNER_SCENE)
    before = (tmp_path / "inner.fmu").read_bytes()
    assert main(["fmu", "export", "outer.yaml", "-o", given]) == 2
    assert one_error_line(capsys.readouterr().err) == (
        f"error: outer.yaml: -o {Path(given)}: is the FMU of component 'gust' (components.gust.path); it is not "
        "replaced")
    assert (tmp_path / "inner.fmu").read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["inner.fmu", "link.fmu", "outer.yaml"]


def test_the_default_experiment_runs_the_whole_scene_on_its_grid(exported):
    """The model description's default experiment: the scene's end as its stop time, the export's
    step as its step (none was written without --step, and FMPy's defaults stopped at 1 s)."""
    from fmpy import read_model_description

    fmu, _ = exported
    experiment = read_model_description(str(fmu)).defaultExperiment
    scene = load(SKIP_SCENE)
    assert float(experiment.stopTime) == scene.until_ns / 1e9
    assert float(experiment.stepSize) == STEP


def test_the_model_description_gives_each_real_its_unit(exported):
    """Each Real parameter and output names its unit, defined under UnitDefinitions (pythonfmu 0.7
    writes none: FMPy showed an empty unit column), and FMPy still finds no problem."""
    from fmpy import read_model_description

    fmu, _ = exported
    md = read_model_description(str(fmu))
    units = {v.name: v.unit for v in md.modelVariables}
    assert (units["x"], units["vz"], units["speed"], units["tilt_deg"]) == ("m", "m/s", "m/s", "deg")
    assert units["stage"] is None  # an Integer has none
    assert {u.name for u in md.unitDefinitions} >= {"m", "m/s", "deg"}


def test_a_boolean_field_is_a_boolean_output(tmp_path):
    """--output-var of a bool field exports a Boolean (it was an Integer), true while the stone is wet."""
    from fmpy import read_model_description, simulate_fmu

    out = tmp_path / "wet.fmu"
    assert main(["fmu", "export", str(SKIP_SCENE), "-o", str(out), "--step", "0.01",
                 "--output-var", "wet=coupler.contact.wetted"]) == 0
    (wet,) = [v for v in read_model_description(str(out)).modelVariables if v.name == "wet"]
    assert wet.type == "Boolean"
    result = simulate_fmu(str(out), stop_time=0.2, output=["wet"])
    assert not result["wet"][0] and result["wet"].any()  # dry at the throw, wet at the first touchdown


def _an_earlier_fmu(path: Path) -> bytes:
    """Write a small zip standing in for an FMU exported before; its bytes."""
    with zipfile.ZipFile(path, "w") as z:
        z.writestr("modelDescription.xml", "<fmiModelDescription/>")
    return path.read_bytes()


def test_an_fmu_the_disk_has_no_room_for_names_the_output_and_leaves_what_was_there(tmp_path, capsys, monkeypatch):
    """The copy into place failing half-way for want of room: exit 1 (the machine's limit, as for a
    recording), one line naming -o, the FMU there before unchanged and nothing beside it (the line
    named the build's temporary FMU, and a broken FMU was left)."""
    import cosim.fmi.export as export

    def half_then_full(source: Path, target: Path) -> None:
        target.write_bytes(source.read_bytes()[:4096])
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(export, "copy_file", half_then_full)
    out = tmp_path / "x.fmu"
    before = _an_earlier_fmu(out)
    assert main(["fmu", "export", str(SKIP_SCENE), "-o", str(out)]) == 1
    assert one_error_line(capsys.readouterr().err) == f"error: {out}: cannot be written ({os.strerror(errno.ENOSPC)})"
    assert out.read_bytes() == before and sorted(tmp_path.iterdir()) == [out]


@pytest.fixture
def full_disk(tmp_path):
    """A folder on a 2 MiB file system with 64 KiB free (a tmpfs: skipped where mounting is not allowed)."""
    with small_disk(tmp_path / "full") as folder:
        fill_leaving(folder, 64 << 10)
        yield folder


def test_an_fmu_exported_onto_a_full_disk_leaves_nothing_half_written(full_disk, capsys):
    """A real full disk (the FMU is 0.7 MB, 64 KiB free): exit 1 naming -o, an FMU there before kept
    as it was, and no broken FMU, temporary or folder made for it (it left a 4 KiB "FMU" that was
    no zip, and named a file in /tmp)."""
    out = full_disk / "x.fmu"
    before = _an_earlier_fmu(out)
    full = os.strerror(errno.ENOSPC)
    assert main(["fmu", "export", str(SKIP_SCENE), "-o", str(out)]) == 1
    assert one_error_line(capsys.readouterr().err) == f"error: {out}: cannot be written ({full})"
    assert out.read_bytes() == before
    deeper = full_disk / "new" / "deeper" / "y.fmu"
    assert main(["fmu", "export", str(SKIP_SCENE), "-o", str(deeper)]) == 1
    assert one_error_line(capsys.readouterr().err) == f"error: {deeper}: cannot be written ({full})"
    assert sorted(p.name for p in full_disk.iterdir()) == ["fill", "x.fmu"]


@pytest.mark.parametrize(("parameter", "said"), [
    ("vx0=components.stone.velocity.0", "--parameter vx0=components.stone.velocity.0: the preset 'throw' sets "
     "components.stone.velocity from its parameters speed, angle_deg, which would replace this value; use "
     "--preset none to set it with --parameter"),
    ("tilt=components.stone.tilt_deg", "--parameter tilt=components.stone.tilt_deg: parameter 'tilt_deg' already "
     "sets components.stone.tilt_deg; a scene value takes one parameter"),
])
def test_a_parameter_on_a_value_another_parameter_sets_is_refused(tmp_path, capsys, parameter, said):
    """--parameter vx0 on the velocity the throw preset derives from speed and angle: exit 2, before
    any build (vx0 = 5 with speed = 9 gave the speed's vx, 8.95, and vx0 was silently dropped)."""
    out = tmp_path / "x.fmu"
    assert main(["fmu", "export", str(SKIP_SCENE), "-o", str(out), "--parameter", parameter]) == 2
    assert said in one_error_line(capsys.readouterr().err)
    assert not out.exists()


def test_a_named_parameter_has_the_unit_its_component_declares(tmp_path, capsys):
    """--parameter density: a Real in kg/m^3 (RigidBody's declared unit), --parameter every an Integer; an
    --output-var has no unit (message fields declare none); FMPy finds no problem. Without --step, the
    printed communication step says what the FMU takes (it said 'any')."""
    out = tmp_path / "units.fmu"
    assert main(["fmu", "export", str(SKIP_SCENE), "-o", str(out), "--parameter", "density=components.stone.density",
                 "--parameter", "every=components.pond.every",
                 "--output-var", "wz=stone.state.angular_velocity[2]"]) == 0
    assert "  communication step: any whole multiple of dt = 0.0005 s (default experiment: 0.0005 s); " \
           in capsys.readouterr().out
    md = fmpy.read_model_description(str(out))
    found = {v.name: (v.type, v.unit) for v in md.modelVariables}
    assert found["density"] == ("Real", "kg/m^3") and found["every"] == ("Integer", None)
    assert found["wz"] == ("Real", None)
    assert validate_fmu(str(out)) == []


def test_a_parameter_the_scene_leaves_at_its_default_is_one_and_a_misspelled_one_is_named(tmp_path, capsys):
    """--parameter rho=components.coupler.rho: the held skip's scene does not write rho, which the
    coupler takes at its default, 1000 kg/m^3: a parameter starting there (it was refused: "the scene
    has no number ... (got None)"). A misspelled parameter is named with the one meant."""
    out = tmp_path / "rho.fmu"
    held = SKIP_SCENE.with_name("held_skip.yaml")
    assert main(["fmu", "export", str(held), "-o", str(out), "--parameter", "rho=components.coupler.rho"]) == 0
    rho = next(v for v in fmpy.read_model_description(str(out)).modelVariables if v.name == "rho")
    assert (rho.type, rho.unit, float(rho.start)) == ("Real", "kg/m^3", 1000.0)
    capsys.readouterr()
    assert main(["fmu", "export", str(held), "-o", str(tmp_path / "typo.fmu"),
                 "--parameter", "d=components.stone.densty"]) == 2
    assert "the scene has no value at 'components.stone.densty' (did you mean 'components.stone.density'?)" \
           in capsys.readouterr().err


def test_the_exported_fmu_lets_its_binary_release_python_before_the_c_exit_handlers(exported):
    """pythonfmu's binary releases its Python state twice at exit (its static pointer's destructor,
    then its unload hook), the second time into freed memory: about half the `fmpy simulate` runs of
    the exported skip started after t = 0 aborted at exit ("corrupted double-linked list"). The
    instance registers the hook to run at Python's exit, before the C handlers, once per binary."""
    from cosim.fmi import pythonfmu_exit

    fmu, _ = exported
    slave = fmpy.instantiate_fmu(fmpy.extract(str(fmu)), fmpy.read_model_description(str(fmu)), fmi_type="CoSimulation")
    try:
        binaries = {str(p.resolve()) for p in Path(slave.unzipDirectory, "binaries", "linux64").glob("*.so")}
        assert binaries and binaries <= pythonfmu_exit._guarded
    finally:
        slave.freeInstance()



@pytest.mark.parametrize(("parameter", "sets", "said"), [
    ("re=record.every", ["--set", "record.every=3000000000"],
     "--parameter 're=record.every': the scene's record.every is 3000000000, outside an FMI 2.0 Integer's range "
     "-2147483648 to 2147483647 (a 32-bit int)"),
    ("dëns=components.stone.density", [],
     "--parameter 'dëns=components.stone.density': expected NAME=key.path (e.g. density=components.stone.density), "
     "NAME of ASCII letters, digits and _, not starting with a digit, parts joined by '.' (FMI's names)"),
])
def test_a_parameter_no_fmi_2_fmu_can_hold_is_refused_before_the_build(tmp_path, capsys, parameter, sets, said):
    """An Integer beyond 32 bits, a name beyond ASCII: refused naming the rule (each was exported with exit
    0, and FMPy's validation then refused the model description)."""
    out = tmp_path / "bad.fmu"
    assert main(["fmu", "export", str(SKIP_SCENE), "-o", str(out), *sets, "--parameter", parameter]) == 2
    assert said in one_error_line(capsys.readouterr().err)
    assert not out.exists()
