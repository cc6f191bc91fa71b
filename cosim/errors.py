"""The two kinds of failure: bad input (ScenarioError) and a run that went wrong (SimulationError)."""

from __future__ import annotations

import errno
import re
import signal
from typing import Any

from cosim.timebase import format_time

NO_ROOM = frozenset({errno.ENOSPC, errno.EDQUOT, errno.EFBIG})
"""The errnos of a write refused for want of room (a full disk, a quota, a file-size limit)."""

_CONTROL = re.compile(r"[\x00-\x1f\x7f-\x9f\u2028\u2029]")  # control characters and every line break


def one_line(text: str) -> str:
    """``text`` with every control character and line break (newline, carriage return, NEL, the
    Unicode line and paragraph separators, NUL...) written as its escape,
    so a name or value taken from user input cannot break an error message over several lines."""
    return _CONTROL.sub(lambda m: repr(m.group())[1:-1], str(text))


def shortened(text: str, most: int) -> str:
    """``text`` on one line (its runs of white space, line breaks among them, as one space), cut to
    at most ``most`` characters, an ellipsis ending what was cut."""
    text = " ".join(str(text).split())
    return text if len(text) <= most else text[:most - 3] + "..."


class CosimError(Exception):
    """Base of the framework's errors."""


class ScenarioError(CosimError):
    """Bad input: every problem found, each as ``path: rule (got value)``.

    ``source`` names the file (or ``<string>``); ``problems`` holds one line per problem.
    """

    def __init__(self, problems: list[str] | str, source: str = "<scene>"):
        self.problems = [one_line(p) for p in ([problems] if isinstance(problems, str) else problems)]
        self.source = one_line(source)
        super().__init__(self._text())

    def _text(self) -> str:
        if len(self.problems) == 1:
            return f"{self.source}: {self.problems[0]}"
        lines = [f"{self.source}: {len(self.problems)} problems"]
        lines += [f"  {p}" for p in self.problems]
        return "\n".join(lines)


class RecordingError(CosimError):
    """A recording that cannot be read (missing, truncated, corrupt, or not a cosim run)."""


class SimulationError(CosimError):
    """A run that failed: names the component, the simulation time and the reason."""

    def __init__(self, component: str, time_ns: int, reason: str):
        self.component = component
        self.time_ns = time_ns
        self.reason = reason = readable_reason(reason)
        super().__init__(f"component {component!r} failed at t = {format_time(time_ns)}: {reason}")


class StateRestoreError(CosimError):
    """A component's ``set_state`` refused the state a checkpoint holds for it with a ValueError,
    KeyError or TypeError: the state is not one it takes (a checkpoint of another scene, settings changed
    by --set, or a set_state that reads what its get_state does not write). Names the component and
    the error; a restart says it as its input's fault (exit 2). Any other error of a set_state is the
    component's failure (:class:`SimulationError`)."""

    exit_code = 2  # the checkpoint's (or the overrides') fault, not a failed run

    def __init__(self, component: str, error: BaseException):
        self.component = component
        self.error = error
        if isinstance(error, KeyError) and error.args:
            said = (f"it holds no {error.args[0]!r} for component {component!r}, whose set_state reads it (a "
                    "component or setting changed by --set, or a set_state reading what its get_state does "
                    "not write?)")
        elif isinstance(error, ValueError) and repr(component) in str(error):
            said = str(error)  # a refusal in the component's own words, naming it
        elif isinstance(error, ValueError):
            said = f"component {component!r} cannot take the state it holds: {error}"
        else:
            said = f"component {component!r} cannot take the state it holds: {type(error).__name__}: {error}"
        super().__init__(readable_reason(said))


ANSI_ESCAPE = re.compile(r"\x1b\[[0-9;]*[A-Za-z]")
REASON_MOST = 1000  # [characters] of a failure's reason kept in the one line, the status and the summary


def readable_reason(reason: str) -> str:
    """``reason`` without a terminal's colour codes, at most REASON_MOST characters: an exception's
    text becomes a run's error line, its recorded status and its summary, and a compiled kernel's
    typing error (numba's) held several kilobytes coloured for a terminal."""
    reason = ANSI_ESCAPE.sub("", str(reason))
    if len(reason) <= REASON_MOST:
        return reason
    kept = REASON_MOST - len(f"... ({len(reason)} more characters)")
    return reason[:kept] + f"... ({len(reason) - kept} more characters)"


def quiet_interrupts(hook: Any) -> Any:
    """A ``sys.unraisablehook`` that drops a KeyboardInterrupt and hands anything else to ``hook``.

    A Ctrl-C (or SIGTERM) raised where Python cannot pass it on (a callback the interpreter runs
    itself, an exit handler joining a pool's threads as the process ends) is dropped there and
    printed with a traceback; a command that has already said it was interrupted has nothing to add."""
    def quiet(unraisable: Any) -> None:
        if not isinstance(unraisable.exc_value, KeyboardInterrupt):
            hook(unraisable)
    return quiet


def ending_signals() -> tuple[int, ...]:
    """Besides Ctrl-C, the signals that end a command or a run the way Ctrl-C does: SIGTERM, and
    SIGHUP (its terminal closed), where the system has them and the process was not started
    ignoring them (``nohup``) or with a handler set outside Python; those stay as they are."""
    found = []
    for name in ("SIGTERM", "SIGHUP"):
        signum = getattr(signal, name, None)
        if signum is None:
            continue
        old = signal.getsignal(signum)
        if old in (signal.SIG_DFL, signal.default_int_handler) or callable(old):
            found.append(signum)
    return tuple(found)


def counted(n: int, singular: str, plural: str | None = None) -> str:
    """``n`` and the noun in its number, for what the commands and summaries print: counted(1,
    "connection") is "1 connection", counted(0, "connection") "0 connections"; ``plural`` when it
    is not the singular with an s."""
    return f"{n} {singular if n == 1 else (plural or singular + 's')}"
