"""One co-simulation FMU (FMI 2.0 or 3.0) running through FMPy: instantiate, set, step, get, and
its state as bytes, with every failed call turned into an :class:`FmuCallError` holding the FMU's
own log messages.

Each FMU file is unpacked once per process (the instances of one FMU share its shared library, as
FMI allows) and the folder is removed when the process ends.
"""

from __future__ import annotations

import atexit
import gc
import os
import shutil
import tempfile
from collections.abc import Callable
from ctypes import byref
from pathlib import Path
from typing import Any

import cosim.fmi
from cosim.errors import NO_ROOM
from cosim.fmi.pythonfmu_exit import release_at_exit

LOG_KEEP = 50  # log messages kept per call: a chatty FMU cannot grow memory without bound
STATUS = ["OK", "Warning", "Discard", "Error", "Fatal", "Pending"]
ERROR, FATAL = 3, 4
FREEING = frozenset({"freeFMUstate"})  # the calls (through _call) an FMU that returned Error still takes


_unpacked: dict[tuple[str, int, int], str] = {}

# FMI 2 instances by the componentEnvironment their callbacks carry (1, 2, ...), for the one logger
# callback they all share (_fmi2_logger)
_by_environment: dict[int, FmuInstance] = {}
# an FMU file that can be instantiated only once per process (canBeInstantiatedOnlyOncePerProcess)
# -> the name of its live instance: a second one is refused, not made (an FMU keeping global state
# would run two instances on one state without a word, and one that enforces it fails saying nothing)
_only_once: dict[str, str] = {}
_fmi2_dispatch: Any = None


def _fmi2_logger() -> Any:
    """The one FMI 2 logger callback of this process. FMPy's proxy, which formats an FMU's printf-style
    messages, keeps a single logger for the whole process, the last one given: with one callback per
    instance, an FMU instantiated inside another (an exported scene that holds an FMU) took every
    message, and the outer FMU's failure reached its host as "the FMU logged nothing". One callback
    routes each message by its instance's componentEnvironment instead."""
    global _fmi2_dispatch
    if _fmi2_dispatch is None:
        from fmpy.fmi2 import fmi2CallbackLoggerTYPE

        def route(env: Any, instance: Any, status: int, category: Any, message: Any) -> None:
            owner = _by_environment.get(env or 0)
            if owner is not None:
                owner._keep(status, category, message)

        _fmi2_dispatch = fmi2CallbackLoggerTYPE(route)
    return _fmi2_dispatch


class FmuCallError(RuntimeError):
    """An FMU call returned Discard, Error or Fatal. ``status``: its name; ``log``: what the FMU
    logged during the call (its own words)."""

    def __init__(self, function: str, status: str, log: list[str]):
        self.function, self.status, self.log = function, status, log
        said = "; ".join(log) if log else "the FMU logged nothing"
        super().__init__(f"{function} returned {status}: {said}")


class FmuNotCalled(FmuCallError):
    """A call refused without reaching the FMU: it returned Error or Fatal earlier, after which FMI 2.0
    and 3.0 allow no further call (after Error only freeing it)."""

    def __init__(self, function: str, worst: str):
        self.function, self.status, self.log = function, "not called", []
        RuntimeError.__init__(self, f"{function} not called: the FMU returned {worst} earlier (FMI: an FMU that "
                                    "returned Error is only freed, one that returned Fatal is not called again)")


def _unpack(fmu_file: Path) -> str:
    """The folder ``fmu_file`` is unpacked to, once per process per file version."""
    st = fmu_file.stat()
    key = (str(fmu_file.resolve()), st.st_mtime_ns, st.st_size)
    folder = _unpacked.get(key)
    if folder is None:
        folder = _unpacked[key] = _extract_whole(fmu_file)
        atexit.register(shutil.rmtree, folder, True)
    return folder


def _extract_whole(fmu_file: Path) -> str:
    """A new folder in the temporary folder (``$TMPDIR``) holding all of ``fmu_file``, or none at all:
    on any failure the folder goes again (FMPy's own extract left a half-unpacked folder behind at
    each try). A write refused for want of room (a full disk, a quota, a file-size limit) is raised
    as the OSError of that errno naming the folder, which the command line reports as the machine's
    limit (``FOLDER: cannot be written (...)``, exit 1), not as the scene's fault."""
    from fmpy import extract

    folder = tempfile.mkdtemp(prefix="cosim-fmu-")
    try:
        extract(str(fmu_file), folder)
    except BaseException as exc:  # an interrupt too: nothing half-unpacked stays
        shutil.rmtree(folder, ignore_errors=True)
        if isinstance(exc, OSError) and exc.errno in NO_ROOM:
            raise OSError(exc.errno, exc.strerror or os.strerror(exc.errno), folder) from None
        raise
    return folder


_held_namespaces: list[Any] = []


def _hold_pythonfmu_namespace(md: Any, folder: str) -> None:
    """One more reference to the namespace of a pythonfmu FMU's slave module, once per instance.
    pythonfmu's binaries (0.7) release one reference to that namespace at each instantiation
    without having taken it; held here, it is never freed while the FMU still uses it (which
    corrupts the heap). Any other FMU: nothing to do."""
    if not str(getattr(md, "generationTool", "") or "").startswith("PythonFMU"):
        return
    import sys

    name_file = Path(folder) / "resources" / "slavemodule.txt"
    module = sys.modules.get(name_file.read_text().strip()) if name_file.is_file() else None
    if module is not None:
        _held_namespaces.append(vars(module))


def check_pythonfmu_resources(md: Any, folder: str, fmu_file: Path) -> None:
    """A PythonFMU-made FMU runs the Python module its ``resources/slavemodule.txt`` names: one whose
    module is missing would crash the process inside the FMU's binary (a segmentation fault, no word),
    so it is refused here, naming what is missing (ValueError). Any other FMU: nothing to check."""
    if not str(getattr(md, "generationTool", "") or "").startswith("PythonFMU"):
        return
    resources = Path(folder) / "resources"
    name_file = resources / "slavemodule.txt"
    module = name_file.read_text(errors="replace").strip() if name_file.is_file() else ""
    if not module:
        raise ValueError(f"{fmu_file}: a PythonFMU FMU without resources/slavemodule.txt naming its model "
                         "module: the FMU is damaged (export it again)")
    top = module.split(".")[0]
    if not ((resources / f"{top}.py").is_file() or (resources / top / "__init__.py").is_file()):
        raise ValueError(f"{fmu_file}: its model module {module!r} is missing from its resources (no "
                         f"resources/{top}.py): the FMU is damaged (export it again)")
    _check_module_not_taken(module, resources, fmu_file)


def _check_module_not_taken(module: str, resources: Path, fmu_file: Path) -> None:
    """PythonFMU's binary puts the FMU's resources on ``sys.path`` and imports its model module by
    name: a module of that name this process already holds (another FMU's model of the same file
    name, or a module of Python's own) is the one every later FMU of that name runs. Two models
    ``a/gain.py`` and ``b/gain.py`` in one scene ran a's code for both, without a word, and a replay
    vouched for it bit for bit. Refused (ValueError) unless the module held is this FMU's own text.
    One whose file is gone (an FMU that FMPy's ``simulate_fmu`` unpacked, ran and deleted in this
    process; the FMUs of scenes stay unpacked until the process ends) cannot be compared: it is let
    go, so that this FMU imports its own."""
    import sys

    held = sys.modules.get(module)
    if held is None:
        return
    relative = Path(*module.split("."))
    own = next((f for f in (resources / relative.with_suffix(".py"), resources / relative / "__init__.py")
                if f.is_file()), None)
    held_file = getattr(held, "__file__", None)
    if held_file is not None and not Path(held_file).is_file():
        for name in [n for n in sys.modules if n == module or n.startswith(module + ".")]:
            del sys.modules[name]
        return
    try:
        same = own is not None and held_file is not None and Path(held_file).read_bytes() == own.read_bytes()
    except OSError:
        same = False
    if not same:
        where = f"from {held_file}" if held_file else "built into Python"
        raise ValueError(f"{fmu_file}: its model module {module!r} is already loaded in this process ({where}) "
                         f"and differs from this FMU's; PythonFMU runs one module of a name per process, so this "
                         f"FMU would run that one's code: give the model's file a name of its own and build the "
                         f"FMU again")


def _status_name(status: int) -> str:
    """An FMI status's name (Fatal), or its number if it has none."""
    return STATUS[status] if 0 <= status < len(STATUS) else f"status {status}"


def _text(value: Any) -> str:
    return value.decode("utf-8", "replace") if isinstance(value, bytes) else str(value or "")


class FmuInstance:
    """A co-simulation instance of the FMU ``fmu_file`` described by ``md`` (FMPy's model
    description), named ``name``, initialized with ``start`` (variable -> value) at t = 0."""

    def __init__(self, fmu_file: Path, md: Any, name: str, start: dict[str, Any], variables: dict[str, Any]):
        self.md = md
        self.fmi3 = md.fmiVersion.startswith("3")
        self.worst = 0  # the worst status a call returned: after Error only freeInstance, after Fatal nothing
        self.log: list[str] = []
        self.can_save = bool(md.coSimulation.canGetAndSetFMUstate and md.coSimulation.canSerializeFMUstate)
        folder = _unpack(fmu_file)
        check_pythonfmu_resources(md, folder, fmu_file)
        self._once = self._claim_only_instance(fmu_file, md, name)
        common = {"guid": md.guid, "unzipDirectory": folder,
                  "modelIdentifier": md.coSimulation.modelIdentifier, "instanceName": name}
        def inside_the_file(text: str) -> str:  # named inside the FMU file, not the folder it was unpacked to
            return text.replace(folder.rstrip("/") + "/", f"{fmu_file}:").replace(folder, str(fmu_file))

        try:
            self._load(md, common)
        except Exception as exc:
            # an instance that failed logs no more (it stayed registered for the FMU's callbacks)
            self._unregister()
            if isinstance(exc, FmuCallError):
                raise FmuCallError(exc.function, exc.status, [inside_the_file(m) for m in exc.log]) from None
            if type(exc) not in (ValueError, OSError, RuntimeError, Exception):  # one that says more than a text
                raise
            raise type(exc)(inside_the_file(str(exc))) from None
        self.live = True
        try:
            _hold_pythonfmu_namespace(md, folder)
            for name_, value in start.items():
                var = variables[name_]
                self.set(var.type, [var.valueReference], [value])
            self._call("enterInitializationMode", self.fmu.enterInitializationMode)
            self._call("exitInitializationMode", self.fmu.exitInitializationMode)
        except BaseException:
            self.close()  # freed, and its claim let go: nothing else holds this half-made instance
            raise

    @staticmethod
    def _claim_only_instance(fmu_file: Path, md: Any, name: str) -> str | None:
        """For an FMU that can be instantiated only once per process, its key in ``_only_once``,
        claimed for instance ``name``; refused while another instance of it lives."""
        if not getattr(md.coSimulation, "canBeInstantiatedOnlyOncePerProcess", False):
            return None
        key = str(fmu_file.resolve())
        if key in _only_once:
            gc.collect()  # an earlier run's instance not let go yet (held in a reference cycle)
        if key in _only_once:
            raise ValueError(f"{fmu_file.name}: the FMU can be instantiated only once per process "
                             f"(canBeInstantiatedOnlyOncePerProcess), and {_only_once[key]!r} already holds "
                             "its instance")
        _only_once[key] = name
        return key

    def _load(self, md: Any, common: dict[str, Any]) -> None:
        """Load the FMU's binary (``common``: FMPy's slave arguments) and instantiate it. A pythonfmu
        binary's double release of its Python state at exit (:mod:`cosim.fmi.pythonfmu_exit`) is
        headed off as soon as it is loaded: instantiate makes that state also when the model's
        constructor then fails."""
        if self.fmi3:
            from fmpy.fmi3 import FMU3Slave

            self.fmu = FMU3Slave(**common)
            release_at_exit(self.fmu.dll._name)
            self._call("instantiate", self.fmu.instantiate, loggingOn=True, logMessage=self._log3)
        else:
            from fmpy import calloc, free
            from fmpy.fmi2 import (
                FMU2Slave,
                fmi2CallbackAllocateMemoryTYPE,
                fmi2CallbackFreeMemoryTYPE,
                fmi2CallbackFunctions,
            )
            from fmpy.logging import addLoggerProxy

            self.fmu = FMU2Slave(**common)
            release_at_exit(self.fmu.dll._name)
            callbacks = fmi2CallbackFunctions()
            self._environment = 1 + max(_by_environment, default=0)
            _by_environment[self._environment] = self
            callbacks.componentEnvironment = self._environment
            callbacks.logger = _fmi2_logger()
            callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
            callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
            addLoggerProxy(byref(callbacks))  # formats the FMU's printf-style messages before they reach us
            self._callbacks = callbacks  # kept alive as long as the FMU may call back
            self._call("instantiate", self.fmu.instantiate, callbacks=callbacks, loggingOn=True)
            self._call("setupExperiment", self.fmu.setupExperiment, startTime=0.0)

    # --- the FMU's log -------------------------------------------------------------------------

    def _keep(self, status: int, category: Any, message: Any) -> None:
        label = STATUS[status] if 0 <= status < len(STATUS) else str(status)
        if len(self.log) < LOG_KEEP:
            self.log.append(f"[{label}] {_text(message).strip()}")

    def _log3(self, env: Any, status: int, category: Any, message: Any) -> None:
        self._keep(status, category, message)

    def _call(self, function: str, call: Callable[..., Any], *args: Any, **kwargs: Any) -> Any:
        """``call(*args)``, with a failed status as an FmuCallError naming ``function`` and quoting
        what the FMU logged meanwhile (its errors first, else everything)."""
        from fmpy.fmi1 import FMICallException

        # FMI's rule for every caller: a scene that failed in this FMU is still asked for its state and
        # told to restore one (setFMUstate of an exported scene), and pythonfmu's FMUs took a doStep after
        # their Fatal and ran on
        if self.worst >= FATAL or (self.worst >= ERROR and function not in FREEING):
            raise FmuNotCalled(function, _status_name(self.worst))
        self.log = []
        # its log reaches this process (loggingOn), which reports a failure in its words: an FMU cosim
        # exported says nothing of its own on standard error meanwhile (cosim.fmi.host_calls)
        cosim.fmi.host_calls += 1
        try:
            return call(*args, **kwargs)
        except FMICallException as exc:
            status = _status_name(exc.status)
            self.worst = max(self.worst, exc.status)
            # the FMU's own words first: an Error it logged says more than the Fatal its wrapper adds
            said = ([m for m in self.log if m.startswith("[Error]")] or
                    [m for m in self.log if m.startswith("[Fatal]")] or self.log)
            raise FmuCallError(function, status, said) from None
        except Exception as exc:
            if function != "instantiate" or type(exc) is not Exception:
                raise
            # FMPy's answer to an instantiate that returned no instance: a bare "Failed to instantiate
            # model"; what the FMU logged meanwhile says why (a pythonfmu model's exception, a missing file)
            said = [m for m in self.log if m.startswith(("[Error]", "[Fatal]"))] or self.log
            raise FmuCallError(function, f"no instance ({exc})", said) from None
        finally:
            cosim.fmi.host_calls -= 1

    # --- values --------------------------------------------------------------------------------

    def _accessor(self, verb: str, fmu_type: str) -> Callable[..., Any]:
        if self.fmi3:
            kind = "Int64" if fmu_type == "Enumeration" else fmu_type
        else:
            kind = "Integer" if fmu_type == "Enumeration" else fmu_type
        return getattr(self.fmu, f"{verb}{kind}")

    def get(self, fmu_type: str, refs: list[int]) -> list[Any]:
        """The values of variables ``refs`` (all of the model description type ``fmu_type``)."""
        return list(self._call(f"get{fmu_type}", self._accessor("get", fmu_type), refs))

    def set(self, fmu_type: str, refs: list[int], values: list[Any]) -> None:
        self._call(f"set{fmu_type}", self._accessor("set", fmu_type), refs, values)

    def do_step(self, t: float, dt: float) -> None:
        """Advance the FMU from ``t`` by ``dt`` [s]; an FMI 3.0 FMU asking to end the run is a failure
        too (a co-simulation cannot go on without it)."""
        result = self._call("doStep", self.fmu.doStep, t, dt)
        if self.fmi3 and result is not None and result[1]:
            raise FmuCallError("doStep", "terminateSimulation", self.log)

    # --- state ---------------------------------------------------------------------------------

    def save(self) -> bytes:
        """The FMU's state, serialized by the FMU itself."""
        get = self.fmu.getFMUState if self.fmi3 else self.fmu.getFMUstate
        free = self.fmu.freeFMUState if self.fmi3 else self.fmu.freeFMUstate
        state = self._call("getFMUstate", get)
        try:
            return bytes(self._call("serializeFMUstate", self.fmu.serializeFMUState, state))
        finally:
            self._free_state(free, state)

    def restore(self, data: bytes) -> None:
        """Put the FMU back into a state :meth:`save` returned."""
        put = self.fmu.setFMUState if self.fmi3 else self.fmu.setFMUstate
        free = self.fmu.freeFMUState if self.fmi3 else self.fmu.freeFMUstate
        state = self._call("deSerializeFMUstate", self.fmu.deserializeFMUState, data)
        try:
            self._call("setFMUstate", put, state)
        finally:
            self._free_state(free, state)

    def _free_state(self, free: Callable[..., Any], state: Any) -> None:
        """Free a state the FMU made, unless it answered Fatal meanwhile: then nothing may be called, and
        the refusal would hide the failure being raised."""
        if self.worst < FATAL:
            self._call("freeFMUstate", free, state)

    def close(self) -> None:
        """Terminate and free the instance (once; errors here are not worth a failure)."""
        if not getattr(self, "live", False):
            return
        self.live = False
        try:
            self._end()
        finally:
            self._unregister()

    def _unregister(self) -> None:
        """Let go of what the process holds for this instance: its entry for the FMU's log callbacks (it
        logs no more) and its claim on an FMU that can be instantiated only once per process."""
        _by_environment.pop(getattr(self, "_environment", 0), None)
        _only_once.pop(getattr(self, "_once", None), None)

    def _end(self) -> None:
        """Terminate and free the instance, as far as the worst status it answered lets them be called."""
        if self.worst >= FATAL:  # FMI: after Fatal no function may be called (the FMU may be gone)
            return
        calls = [self.fmu.freeInstance]
        if self.worst < ERROR:  # FMI: after Error only freeInstance
            calls.insert(0, self.fmu.terminate)
        for call in calls:
            try:
                call()
            except Exception:  # an FMU that fails to terminate has nothing left to give
                pass
