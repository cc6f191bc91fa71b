"""The two kinds of failure: bad input (ScenarioError) and a run that went wrong (SimulationError)."""

from __future__ import annotations

from cosim.timebase import format_time


class CosimError(Exception):
    """Base of the framework's errors."""


class ScenarioError(CosimError):
    """Bad input: every problem found, each as ``path: rule (got value)``.

    ``source`` names the file (or ``<string>``); ``problems`` holds one line per problem.
    """

    def __init__(self, problems: list[str] | str, source: str = "<scene>"):
        self.problems = [problems] if isinstance(problems, str) else list(problems)
        self.source = source
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
        self.reason = reason
        super().__init__(f"component {component!r} failed at t = {format_time(time_ns)}: {reason}")


