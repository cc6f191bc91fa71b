"""FMI's rule after a failure, kept by cosim as a master and by its exported FMU: an FMU that returned
Error is only freed, one that returned Fatal is not called again, and the exported scene rolls back
to a saved state without calling the FMU that failed it.

    gust_flight (stone <-> gust FMU, max_speed a parameter) --cosim fmu export--> gusty.fmu
    SceneSlave (gusty.fmu's class, run here) --doStep--> the gust returns Fatal at t = 0.062 s
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

fmpy = pytest.importorskip("fmpy")
pytest.importorskip("pythonfmu")

from components.fmu.instance import ERROR, FATAL, FmuCallError, FmuInstance  # noqa: E402
from cosim.cli import main  # noqa: E402
from cosim.fmi.slave import SceneSlave  # noqa: E402
from tests.fmu_toys import fmu_cache, gust_scene  # noqa: E402, F401

pytestmark = pytest.mark.usefixtures("fmu_cache")

STEP = 0.01  # [s] the communication step: 10 base steps of 1 ms
FAILING_MAX_SPEED = 8.01  # [m/s] the falling stone's air speed passes it at t = 0.062 s (8 m/s at the throw)


@pytest.fixture(scope="module")
def gusty(tmp_path_factory) -> Path:
    """The gust flight (no water: quick) exported with the gust's max_speed as a parameter."""
    folder = tmp_path_factory.mktemp("gusty")
    scene = folder / "gust.yaml"
    scene.write_text(gust_scene(start="{peak_speed: 8.0, start_time: 0.05, duration: 0.1, max_speed: 60.0}"))
    fmu = folder / "gusty.fmu"
    assert main(["fmu", "export", str(scene), "-o", str(fmu), "--step", str(STEP), "--preset", "none",
                 "--parameter", "max_speed=components.gust.start.max_speed",
                 "--output-var", "x=stone.state.position[0]", "--output-var", "vz=stone.state.velocity[2]"]) == 0
    return fmu


def _slave(fmu: Path, name: str, max_speed: float) -> SceneSlave:
    """``fmu``'s scene class, run in this process, initialized with the gust's ``max_speed`` [m/s]."""
    slave = SceneSlave(instance_name=name, resources=str(Path(fmpy.extract(str(fmu))) / "resources"))
    slave.values["max_speed"] = max_speed
    slave.setup_experiment(0.0, None, None)
    slave.exit_initialization_mode()
    return slave


class _Watched:
    """An FMPy FMU object that notes the name of each of its functions called."""

    def __init__(self, fmu: Any):
        self.fmu, self.called = fmu, []

    def __getattr__(self, name: str) -> Any:
        function = getattr(self.fmu, name)

        def call(*args: Any, **kwargs: Any) -> Any:
            self.called.append(name)
            return function(*args, **kwargs)
        return call if callable(function) else function


def _run_to_the_failure(slave: SceneSlave) -> tuple[dict[str, Any], dict[str, Any]]:
    """Step ``slave`` from 0 until the gust fails it; the state saved at t = 0.01 s and the values at
    t = 0.02 s."""
    assert slave.do_step(0.0, STEP)
    saved = slave._get_fmu_state()
    assert slave.do_step(STEP, STEP)
    at_2_steps = dict(slave.values)
    k = 2
    while slave.do_step(k * STEP, STEP):
        k += 1
        assert k < 20, "the gust never failed the scene"
    return saved, at_2_steps


def test_set_fmu_state_after_an_inner_fatal_rolls_back_without_calling_that_fmu(gusty, capfd):
    """setFMUstate of a state saved before the gust's Fatal, then a doStep from that state: the values
    are those the run had, bit for bit, and the gust instance that returned Fatal is called no more
    (its getFMUstate, setFMUstate and doStep were called, and the dead model ran on): the state went
    into the scene built anew, with a gust instance of its own."""
    slave = _slave(gusty, "outer", FAILING_MAX_SPEED)
    saved, at_2_steps = _run_to_the_failure(slave)
    failed_gust = slave.sim.components["gust"].fmu
    assert failed_gust.worst == FATAL
    watched = failed_gust.fmu = _Watched(failed_gust.fmu)
    slave._set_fmu_state(saved)
    assert slave.do_step(STEP, STEP)
    assert watched.called == []
    assert slave.values == at_2_steps
    assert slave.sim.components["gust"].fmu is not failed_gust
    assert "component 'gust' failed at t = 0.062 s" in capfd.readouterr().err


def test_get_fmu_state_of_a_scene_an_inner_fatal_failed_is_refused_naming_why(gusty, capfd):
    """getFMUstate after the gust's Fatal fails saying why, on standard error too, without calling
    the gust (its state was taken from the dead instance); a state saved before still restores."""
    slave = _slave(gusty, "saving", FAILING_MAX_SPEED)
    saved, _ = _run_to_the_failure(slave)
    failed_gust = slave.sim.components["gust"].fmu
    watched = failed_gust.fmu = _Watched(failed_gust.fmu)
    capfd.readouterr()
    with pytest.raises(RuntimeError, match=r"cannot save this state: component 'gust' failed at t = 0\.062 s: "
                                           r".*getFMUstate not called: the FMU returned Fatal earlier"):
        slave._get_fmu_state()
    assert watched.called == []
    assert "error: FMU SceneSlave (instance 'saving'): cannot save this state: " in capfd.readouterr().err
    slave._set_fmu_state(saved)
    assert slave.do_step(STEP, STEP)


def _instance_that_returned(worst: int) -> FmuInstance:
    """An FMU instance (no FMU behind it) whose worst answer so far was ``worst``."""
    instance = FmuInstance.__new__(FmuInstance)
    instance.worst, instance.log = worst, []
    return instance


@pytest.mark.parametrize(("worst", "name"), [(ERROR, "Error"), (FATAL, "Fatal")])
def test_an_fmu_that_returned_error_or_fatal_is_not_called_again(worst, name):
    """After Fatal no call reaches the FMU; after Error none but freeing (FMI 2.0 and 3.0): each
    refusal names the function and why, and the function is never run."""
    instance, ran = _instance_that_returned(worst), []
    for function in ("doStep", "getFMUstate", "deSerializeFMUstate", "setFMUstate", "getReal"):
        with pytest.raises(FmuCallError, match=rf"^{function} not called: the FMU returned {name} earlier"):
            instance._call(function, ran.append, function)
    if worst == ERROR:
        instance._call("freeFMUstate", ran.append, "freeFMUstate")
    else:
        with pytest.raises(FmuCallError, match=r"^freeFMUstate not called: the FMU returned Fatal earlier"):
            instance._call("freeFMUstate", ran.append, "freeFMUstate")
    assert ran == (["freeFMUstate"] if worst == ERROR else [])


class _FatalSetState:
    """An FMI 2 FMU whose setFMUstate answers Fatal; notes each function called."""

    def __init__(self) -> None:
        self.called: list[str] = []

    def deserializeFMUState(self, data: bytes) -> str:
        self.called.append("deserializeFMUState")
        return "state"

    def setFMUstate(self, state: str) -> None:
        from fmpy.fmi1 import FMICallException

        self.called.append("setFMUstate")
        raise FMICallException(function="fmi2SetFMUstate", status=FATAL)

    def freeFMUstate(self, state: str) -> None:
        self.called.append("freeFMUstate")


def test_a_restore_answered_fatal_frees_nothing_and_says_fatal():
    """setFMUstate answered Fatal: the state it was given is not freed (no call after Fatal, which
    the restore's clean-up made), and the error is setFMUstate's."""
    instance = _instance_that_returned(0)
    instance.fmi3, instance.fmu = False, _FatalSetState()
    with pytest.raises(FmuCallError, match=r"^setFMUstate returned Fatal"):
        instance.restore(b"saved")
    assert instance.fmu.called == ["deserializeFMUState", "setFMUstate"]
