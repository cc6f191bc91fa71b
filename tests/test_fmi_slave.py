"""The exported scene's FMU class (cosim.fmi.slave) as a master drives it: a start time after 0, an
Integer parameter, a state of another scene, and the reason of a failure where a user sees it.

    held_skip.yaml --cosim fmu export--> held.fmu --FMPy simulate_fmu / FMU2Slave--> rows
    skip.yaml      --cosim fmu export--> free.fmu (another scene: its state is no state of held.fmu)
"""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

fmpy = pytest.importorskip("fmpy")
pytest.importorskip("pythonfmu")

from cosim.cli import main  # noqa: E402
from cosim.fmi.slave import SceneSlave  # noqa: E402
from tests.fmu_toys import ROOT, SKIP_SCENE, fmu_cache  # noqa: E402, F401

pytestmark = pytest.mark.usefixtures("fmu_cache")

STEP = 0.01  # [s] the communication step: 20 base steps of 0.5 ms
MOTION = ("x", "y", "z", "vx", "vy", "vz")


@pytest.fixture(scope="module")
def held(tmp_path_factory) -> Path:
    """The held skip exported with the throw preset and a 10 ms step."""
    fmu = tmp_path_factory.mktemp("held") / "held.fmu"
    assert main(["fmu", "export", str(SKIP_SCENE), "-o", str(fmu), "--step", str(STEP)]) == 0
    return fmu


def _in_a_process(code: str) -> subprocess.CompletedProcess[str]:
    """Run ``code`` in a Python of its own: an FMU call answered Fatal leaves pythonfmu's instance
    unfit to be freed, and the process holding it may abort as it exits."""
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300, check=False)


def test_a_start_time_after_0_gives_the_scenes_values_at_that_time(held):
    """simulate_fmu from t = 0.05 s: the rows at 0.05, 0.06, 0.07 s are those of a run from 0, bit for
    bit (the start time was ignored: rows stamped 0.05 s held the t = 0 values, every doStep refused)."""
    whole = fmpy.simulate_fmu(str(held), stop_time=0.07, output_interval=STEP)
    late = fmpy.simulate_fmu(str(held), start_time=0.05, stop_time=0.07, output_interval=STEP)
    assert len(late) == 3 and late["time"][0] == 0.05
    for got, want in zip(late, whole[5:], strict=True):
        assert np.array([got[k] for k in MOTION]).tobytes() == np.array([want[k] for k in MOTION]).tobytes()


@pytest.mark.parametrize(("start", "said"), [
    ("0.0003", "a start time of 0.0003 s is not a whole multiple of the scene's base step dt = 0.0005 s"),
    ("-1.0", "a start time of -1 s: must be at least 0 s (the scene begins at t = 0)"),
    # (an infinite one was Fatal with no reason said: its base step, round(inf), raised)
    ("float('inf')", "a start time of inf s: must be at most 9.22e+09 s (the scene's clock counts 64-bit nanoseconds)"),
])
def test_a_start_time_off_the_scenes_grid_is_refused_at_setup_with_the_reason(held, start, said):
    """A start time the scene cannot be at fails setupExperiment (pythonfmu answers Fatal), the reason
    on standard error as well as in the log."""
    done = _in_a_process(f"import fmpy; fmpy.simulate_fmu({str(held)!r}, start_time={start}, stop_time=1.0)")
    assert done.returncode != 0
    assert "fmi2SetupExperiment failed with status 4 (fatal)" in done.stderr
    assert f"error: FMU held (instance 'held'): {said}" in done.stderr


@pytest.fixture(scope="module")
def pond_fmu(tmp_path_factory) -> Path:
    """The held skip with its pond's cell count along x (an integer) as a parameter, and the water's
    volume as an output."""
    fmu = tmp_path_factory.mktemp("pond") / "pond.fmu"
    assert main(["fmu", "export", str(SKIP_SCENE), "-o", str(fmu), "--step", str(STEP), "--preset", "none",
                 "--parameter", "nx=components.pond.nx", "--parameter", "density=components.stone.density",
                 "--output-var", "volume=pond.field.volume"]) == 0
    return fmu


def test_an_integer_scene_value_is_an_integer_parameter_that_takes_effect(pond_fmu):
    """nx is an Integer (start 800); 900 cells make the water 9 m long instead of 8 (its override was
    written as 900.0, and the scene refused it: 'must be an integer')."""
    md = fmpy.read_model_description(str(pond_fmu))
    (nx,) = [v for v in md.modelVariables if v.name == "nx"]
    assert (nx.type, nx.start) == ("Integer", "800")
    as_written = fmpy.simulate_fmu(str(pond_fmu), stop_time=STEP)
    longer = fmpy.simulate_fmu(str(pond_fmu), stop_time=STEP, start_values={"nx": 900})
    assert as_written["volume"][0] == pytest.approx(8 * 1 * 0.5)  # 800 x 100 cells of 1 cm, 0.5 m deep [m^3]
    assert longer["volume"][0] == pytest.approx(9 * 1 * 0.5)


def _slave(fmu: Path, name: str) -> SceneSlave:
    """``fmu``'s scene class, run in this process (not through the FMU's binaries), initialized."""
    slave = SceneSlave(instance_name=name, resources=str(Path(fmpy.extract(str(fmu))) / "resources"))
    slave.setup_experiment(0.0, None, None)
    slave.exit_initialization_mode()
    return slave


def test_a_state_of_another_scene_is_refused_changing_nothing(held, tmp_path, capfd):
    """setFMUstate with the state of another scene's FMU (same variables, another pond): refused, and
    the instance's variables and scene are as before. Refused by the scene it was saved with, not by
    what of it fails to fit: a stone alone took the state of a stone with a gust model (the
    variables alike, the extra component and its connections let through); here the variables were
    taken, and the stone restored, before the pond refused."""
    free = tmp_path / "free.fmu"
    assert main(["fmu", "export", str(ROOT / "scenarios" / "skip.yaml"), "-o", str(free), "--step", str(STEP)]) == 0
    other = _slave(free, "other")
    other.do_step(0.0, STEP)
    mine = _slave(held, "mine")
    assert sorted(other.values) == sorted(mine.values) and other.values != mine.values
    before = mine._get_fmu_state()
    with pytest.raises(RuntimeError, match=r"cannot restore this state: it is the state of another exported scene"):
        mine._set_fmu_state(other._get_fmu_state())
    assert mine._get_fmu_state() == before
    assert mine.do_step(0.0, STEP)  # and it steps on from where it was
    fresh = SceneSlave(instance_name="fresh", resources=mine.resources)
    with pytest.raises(RuntimeError, match=r"cannot restore this state"):
        fresh._set_fmu_state(other._get_fmu_state())
    assert fresh.sim is None and fresh.values == SceneSlave(instance_name="x", resources=mine.resources).values
    assert "error: FMU SceneSlave (instance 'mine'): cannot restore this state" in capfd.readouterr().err


def test_a_master_that_adds_up_its_time_is_followed_on_the_scenes_grid(held, capfd):
    """A doStep time off the scene's time by round-off (a master's t += h drifts by ulps of t that grow
    with the run: 1.1 ns by t = 2304 s in steps of 0.1 s, two millionths of a 0.5 ms base step, was
    refused, said as "doStep from t = 2304.3 s, but the scene is at t = 2304.3 s") is the scene's
    time; a quarter of a base step off is not, and is said in digits that tell the two apart."""
    slave = _slave(held, "summing")
    assert slave.do_step(0.0, STEP)
    assert slave.do_step(STEP + 1.1e-9, STEP)
    assert slave.sim.time_ns == 2 * round(STEP * 1e9)
    off = 2 * STEP + 0.3 * 0.0005
    capfd.readouterr()
    assert not slave.do_step(off, STEP)
    said = capfd.readouterr().err
    assert f"doStep from t = {off!r} s, but the scene is at t = {2 * STEP!r} s" in said


FINITE_STEP = ("must be a finite number of seconds, ending by t = 9.22e+09 s (the scene's clock counts 64-bit "
               "nanoseconds)")


def test_a_do_step_at_a_time_or_by_a_step_that_is_not_finite_is_refused_changing_nothing(held, capfd):
    """A time or a step of NaN or infinity answers Discard with the reason on standard error, and the
    scene stays where it was, stepping on as it should after: doStep from t = NaN was taken (NaN passed
    the check against the scene's time, which compares false) and a NaN or infinite step was Fatal, the
    instance dead and nothing said (the step's count of base steps, round(inf), raised)."""
    slave = _slave(held, "odd")
    values = dict(slave.values)
    for t, h, said in [
        (math.nan, STEP, "doStep from t = nan s: the communication point must be a finite time"),
        (math.inf, STEP, "doStep from t = inf s: the communication point must be a finite time"),
        (0.0, math.nan, f"a communication step of nan s: {FINITE_STEP}"),
        (0.0, math.inf, f"a communication step of inf s: {FINITE_STEP}"),
        (0.0, -math.inf, f"a communication step of -inf s: {FINITE_STEP}"),
        (0.0, 1e300, f"a communication step of 1e+300 s: {FINITE_STEP}"),  # finite, but inf base steps
    ]:
        capfd.readouterr()
        assert not slave.do_step(t, h), (t, h)
        assert f"error: FMU SceneSlave (instance 'odd'): {said}" in capfd.readouterr().err
        assert slave.sim.tick == 0 and slave.values == values
    assert slave.do_step(0.0, STEP)
    assert slave.sim.time_ns == round(STEP * 1e9)


def test_a_refused_do_step_is_said_on_standard_error_without_debug_logging(held, capfd):
    """FMPy's default (no debug logging) with a step off the scene's grid: the FMU answers Discard,
    FMPy ends the run at the failed step's start without a word, and the reason is on standard error
    (pythonfmu's binaries pass no log message on unless debug logging is on)."""
    rows = fmpy.simulate_fmu(str(held), stop_time=STEP, output_interval=0.0007)
    assert list(rows["time"]) == [0.0, 0.0]  # FMPy records the last successful time once more
    err = capfd.readouterr().err
    assert "error: FMU held (instance 'held'): a communication step of 0.0007 s is not a whole multiple " \
           "of the scene's base step dt = 0.0005 s" in err


def test_an_invalid_start_value_is_said_on_standard_error(held):
    """spin = NaN: exitInitializationMode fails (Fatal, FMPy raises), the scene's reason on standard
    error (it was in the FMU's log only, which FMPy shows with debug logging)."""
    done = _in_a_process(f"import fmpy; fmpy.simulate_fmu({str(held)!r}, stop_time=0.01, "
                         "start_values={'spin': float('nan')})")
    assert "fmi2ExitInitializationMode failed with status 4 (fatal)" in done.stderr
    assert "error: FMU held (instance 'held'): the scene cannot start: scene.yaml: components.stone.spin: " \
           "must be a number (got 'nan')" in done.stderr


def test_a_cosim_scene_holding_a_failing_exported_scene_says_why_in_one_line(tmp_path):
    """An exported scene that holds an FMU itself (gust_skip: its gust), failing at 0.359 s, run as a
    component of a cosim scene: the run's one error line quotes the inner failure, through both FMUs
    (the inner FMU took the process's one logger, and the line said "the FMU logged nothing"; the
    exported FMU's own line on standard error would have said it a second time)."""
    fmu = tmp_path / "gusty.fmu"
    assert main(["fmu", "export", str(ROOT / "scenarios" / "gust_skip.yaml"), "--set",
                 "components.gust.start.max_speed=9", "-o", str(fmu), "--step", str(STEP)]) == 0
    scene = tmp_path / "host.yaml"
    scene.write_text("name: host\ndt: 0.0005\nuntil: 0.6\ncomponents:\n  throw:\n    type: FMU\n"
                     "    path: gusty.fmu\n    every: 20\n    outputs: {vz: vz}\n")
    done = subprocess.run([sys.executable, "-m", "cosim.cli", "run", str(scene), "--no-record", "-q"],
                          capture_output=True, text=True, timeout=300, check=False, cwd=tmp_path)
    assert done.returncode == 1
    (line,) = done.stderr.strip().splitlines()
    assert line.startswith("error: component 'throw' failed at t = 0.35 s: FMU 'gusty.fmu' doStep returned "
                           "Discard: [Error] component 'gust' failed at t = 0.359 s: "), line
    assert "relative air speed 9.00094 m/s at t = 0.359 s is above max_speed = 9 m/s" in line
    # FMPy as the master: the FMU component inside the scene calls its own FMU, but the exported FMU's
    # failure comes after that call, outside any cosim call into it, and is said on standard error
    done = _in_a_process(f"import fmpy; fmpy.simulate_fmu({str(fmu)!r}, stop_time=0.6)")
    assert "error: FMU gusty (instance 'gusty'): component 'gust' failed at t = 0.359 s: " in done.stderr


def test_a_parameter_set_after_initialization_is_refused_and_keeps_its_value(held):
    """The parameters are fixed: setReal of speed after exitInitializationMode fails (it answered OK,
    and speed then read 20 while the scene ran with the speed it had); before, it is taken. Through
    pythonfmu's binaries the refusal is Fatal (pythonfmu's answer to any exception of a setter)."""
    slave = SceneSlave(instance_name="early", resources=str(Path(fmpy.extract(str(held))) / "resources"))
    speed = next(v.value_reference for v in slave.vars.values() if v.name == "speed")
    slave.set_real([speed], [9.0])  # before initialization: taken
    slave.setup_experiment(0.0, None, None)
    slave.exit_initialization_mode()
    assert slave.get_real([speed]) == [9.0]
    with pytest.raises(RuntimeError, match=r"parameter 'speed' set to 20\.0 after initialization: a fixed "
                                           r"parameter takes a value only before exitInitializationMode "
                                           r"\(FMI 2\.0\); it stays 9\.0"):
        slave.set_real([speed], [20.0])
    assert slave.get_real([speed]) == [9.0] and slave.values["speed"] == 9.0
    done = _in_a_process(
        "from fmpy import read_model_description, extract\nfrom fmpy.fmi2 import FMU2Slave\n"
        f"md = read_model_description({str(held)!r})\n"
        f"s = FMU2Slave(guid=md.guid, unzipDirectory=extract({str(held)!r}), modelIdentifier='held', "
        "instanceName='late')\n"
        "s.instantiate(); s.setupExperiment(startTime=0.0); s.enterInitializationMode(); s.exitInitializationMode()\n"
        "s.setReal([next(v.valueReference for v in md.modelVariables if v.name == 'speed')], [20.0])\n")
    assert "fmi2SetReal failed with status 4 (fatal)" in done.stderr
    assert "error: FMU held (instance 'late'): parameter 'speed' set to 20.0 after initialization" in done.stderr


def test_a_state_saved_before_initialization_takes_the_instance_back_to_before_it(held):
    """setFMUstate of a state saved before initialization, on an instance 20 ms into its run: no scene
    and no latest messages, so doStep waits for initialization, which then runs from t = 0 again with
    the state's parameters (the scene stayed at 20 ms while the outputs read 0: a doStep from 0 was
    refused, one from 20 ms accepted)."""
    resources = str(Path(fmpy.extract(str(held))) / "resources")
    fresh = SceneSlave(instance_name="fresh", resources=resources)
    fresh.values["speed"] = 9.0
    before_initialization = fresh._get_fmu_state()
    slave = _slave(held, "back")
    slave.do_step(0.0, STEP)
    slave.do_step(STEP, STEP)
    slave._set_fmu_state(before_initialization)
    assert slave.sim is None and slave.latest.messages == {}
    assert slave.values == before_initialization["values"] and slave.values["x"] == 0.0
    assert not slave.do_step(2 * STEP, STEP)  # refused: doStep before initialization
    slave.setup_experiment(0.0, None, None)
    slave.exit_initialization_mode()
    assert slave.do_step(0.0, STEP)
    fresh.setup_experiment(0.0, None, None)
    fresh.exit_initialization_mode()
    fresh.do_step(0.0, STEP)
    assert [slave.values[k] for k in MOTION] == [fresh.values[k] for k in MOTION]


def test_do_step_after_terminate_is_refused_and_reset_makes_the_fmu_run_again(held, capfd):
    """FMI 2.0 allows only reset or freeInstance after terminate: a doStep is refused with Discard and
    its reason (it was run, and the stone moved on); reset then makes the instance run the scene from
    t = 0 again, to the same values."""
    from fmpy.fmi2 import FMU2Slave

    md = fmpy.read_model_description(str(held))
    x = next(v.valueReference for v in md.modelVariables if v.name == "x")
    slave = FMU2Slave(guid=md.guid, unzipDirectory=fmpy.extract(str(held)), modelIdentifier="held",
                      instanceName="ended")
    slave.instantiate()
    seen = []
    for _ in range(2):  # the run, then the run again after reset
        slave.setupExperiment(startTime=0.0)
        slave.enterInitializationMode()
        slave.exitInitializationMode()
        slave.doStep(currentCommunicationPoint=0.0, communicationStepSize=STEP)
        seen.append(slave.getReal([x]))
        slave.terminate()
        with pytest.raises(Exception, match=r"fmi2DoStep failed with status 2 \(discard\)"):
            slave.doStep(currentCommunicationPoint=STEP, communicationStepSize=STEP)
        assert slave.getReal([x]) == seen[-1]
        slave.reset()
    slave.freeInstance()
    assert seen[0] == seen[1] and seen[0][0] > 0.3  # the stone moved on from x = 0.3 m, twice alike
    err = capfd.readouterr().err
    assert err.count("error: FMU held (instance 'ended'): doStep from t = 0.01 s after terminate: a terminated "
                     "FMU takes only reset or freeInstance (FMI 2.0)") == 2


def test_outputs_read_in_initialization_mode_are_the_scenes_at_the_start_time(held):
    """FMI 2.0 lists every output as an initial unknown, which a master may read in Initialization
    Mode: there they are the scene's values at the start time as the parameters stand (they read 0),
    a parameter set meanwhile counts, and exitInitializationMode keeps the scene so started."""
    resources = str(Path(fmpy.extract(str(held))) / "resources")
    slave = SceneSlave(instance_name="early", resources=resources)
    refs = {v.name: v.value_reference for v in slave.vars.values()}
    slave.setup_experiment(0.05, None, None)
    slave.enter_initialization_mode()
    first = slave.get_real([refs[k] for k in MOTION])
    slave.set_real([refs["speed"]], [9.0])
    early = slave.get_real([refs[k] for k in MOTION])
    started = slave._started[1]
    slave.exit_initialization_mode()
    assert slave.sim is started and slave.get_real([refs[k] for k in MOTION]) == early
    late = SceneSlave(instance_name="late", resources=resources)
    late.set_real([refs["speed"]], [9.0])
    late.setup_experiment(0.05, None, None)
    late.exit_initialization_mode()
    assert early == late.get_real([refs[k] for k in MOTION])
    assert early[0] > 0.3 and early[3] > 0.0 and first != early  # moved on from x = 0.3 m, at its own speed


@pytest.fixture(scope="module")
def stepped(tmp_path_factory) -> Path:
    """The held skip exported with its base step dt as a parameter (step)."""
    fmu = tmp_path_factory.mktemp("stepped") / "stepped.fmu"
    assert main(["fmu", "export", str(SKIP_SCENE), "-o", str(fmu), "--step", str(STEP), "--parameter",
                 "step=dt"]) == 0
    return fmu


def test_a_start_time_is_checked_against_the_base_step_the_parameters_give(stepped):
    """A start of 0.5 ms with the step parameter made 1 ms: refused at setupExperiment when set before
    it, and as the scene starts when set in Initialization Mode (it was checked against the scene's
    0.5 ms, then rounded down to 0 without a word, and every doStep refused)."""
    resources = str(Path(fmpy.extract(str(stepped))) / "resources")
    said = r"a start time of 0\.0005 s is not a whole multiple of the scene's base step dt = 0\.001 s"
    before = SceneSlave(instance_name="before", resources=resources)
    step = next(v.value_reference for v in before.vars.values() if v.name == "step")
    before.set_real([step], [0.001])
    with pytest.raises(RuntimeError, match=said):
        before.setup_experiment(0.0005, None, None)
    during = SceneSlave(instance_name="during", resources=resources)
    during.setup_experiment(0.0005, None, None)  # on the scene's own 0.5 ms grid: taken
    during.enter_initialization_mode()
    during.set_real([step], [0.001])
    with pytest.raises(RuntimeError, match=said):
        during.exit_initialization_mode()
    on_grid = SceneSlave(instance_name="on_grid", resources=resources)
    on_grid.set_real([step], [0.001])
    on_grid.setup_experiment(0.002, None, None)
    on_grid.exit_initialization_mode()
    assert on_grid.sim.time_ns == 2_000_000


@pytest.fixture(scope="module")
def until_fmu(tmp_path_factory) -> Path:
    """The held skip with its end (the scene's `until`) as a parameter."""
    fmu = tmp_path_factory.mktemp("until") / "until.fmu"
    assert main(["fmu", "export", str(SKIP_SCENE), "-o", str(fmu), "--step", str(STEP),
                 "--parameter", "end=until"]) == 0
    return fmu


def test_the_scene_ends_at_its_until_and_the_outputs_hold_after_it(until_fmu):
    """The FMU runs its scene as `cosim run` does, which ends it at its `until`: past it time goes on
    and the outputs hold (it ran on, so that `--parameter end=until` moved nothing and a master past
    the end got values `cosim run` never gives). The rows up to the end are those of a longer scene's,
    bit for bit."""
    short = fmpy.simulate_fmu(str(until_fmu), stop_time=0.1, output_interval=STEP, start_values={"end": 0.05})
    long = fmpy.simulate_fmu(str(until_fmu), stop_time=0.1, output_interval=STEP, start_values={"end": 0.1})
    rows = lambda table: np.array([[row[k] for k in MOTION] for row in table])
    assert rows(short)[:6].tobytes() == rows(long)[:6].tobytes()  # t = 0 to 0.05 s
    assert (rows(short)[6:] == rows(short)[5]).all()  # held from the end on
    assert not (rows(long)[6:] == rows(long)[5]).all()  # the longer scene moves on
