"""FMI, the co-simulation standard: scenes exported as co-simulation FMUs (pythonfmu), and the
building of FMUs from small Python models, on demand and cached.

FMUs used as components (through FMPy) are the ``FMU`` component type, in ``components.fmu``.
Everything here needs the ``[fmi]`` extra (``fmpy``, ``pythonfmu``) and imports it lazily.
"""

# how many calls of cosim's FMU component into an FMU are under way in this process
# (components.fmu.instance), which read the FMU's log: an exported scene failing within one is said
# in that scene's own error line, not a second time by the FMU on standard error (cosim.fmi.slave).
# Counted around each call, not set once: the same process may run an exported scene for another
# master (FMPy) while the scene runs an FMU of its own.
host_calls = 0
