"""FMI, the co-simulation standard: scenes exported as co-simulation FMUs (pythonfmu), and the
building of FMUs from small Python models, on demand and cached.

FMUs used as components (through FMPy) are the ``FMU`` component type, in ``components.fmu``.
Everything here needs the ``[fmi]`` extra (``fmpy``, ``pythonfmu``) and imports it lazily.
"""
