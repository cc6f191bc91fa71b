"""What a viewer shows: derived from the exchanged messages, never fed back into the physics.

- :mod:`~cosim.view.items`: viewer items (poses, shapes, meshes, log lines), the ``cosim.visuals``
  registry through which a package says how its messages look, and the deriver that turns exchanges
  into items at a frame rate;
- :mod:`~cosim.view.foxglove`: those items as Foxglove protobuf messages (``foxglove.SceneUpdate``,
  ``foxglove.FrameTransforms``, ``foxglove.Log``) for recordings;
- :mod:`~cosim.view.live`: the same channels streamed to Foxglove over WebSocket (``cosim run --live``).

Public face: :func:`visual_deriver`, :class:`LiveView`.
"""

from __future__ import annotations

from cosim import lazy_exports

_EXPORTS = {
    "visual_deriver": "cosim.view.foxglove",
    "LiveView": "cosim.view.live",
}

__all__ = ["LiveView", "visual_deriver"]

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
