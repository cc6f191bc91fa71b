"""Physics-aware presentation of a recording: ``cosim plot`` (PNG figures) and ``cosim render``
(an animation of the stone over the shaded water surface).

Registered as ``cosim.commands`` entry points; :mod:`components.analysis.commands` is light, and the
figure modules import matplotlib only when a command runs. Recordings are read back with
:mod:`cosim.record.reader`; nothing here touches the physics.
"""
