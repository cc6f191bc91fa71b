"""Recording a run to MCAP and reading it back. The scheduler knows none of this: the recorder is
one of its observers.

- :mod:`~cosim.record.recorder`: the observer that sends every exchange, the viewer channels, the
  checkpoints and the final status to a sink;
- :mod:`~cosim.record.writer`: the sink, a writer process (``python -m cosim.record.writer``) fed through
  :mod:`~cosim.record.ring` (shared memory), that writes the MCAP file; or the same writer in process;
- :mod:`~cosim.record.reader`: a recording read back (:class:`Recording`: scene, channels, messages,
  checkpoints, status);
- :mod:`~cosim.record.describe`: the text ``cosim inspect`` prints.

Public face: :class:`Recorder`, :class:`Recording`, :func:`describe_recording`.
"""

from __future__ import annotations

from cosim import lazy_exports

_EXPORTS = {
    "Recorder": "cosim.record.recorder",
    "Recording": "cosim.record.reader",
    "describe_recording": "cosim.record.describe",
}

__all__ = ["Recorder", "Recording", "describe_recording"]

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
