"""FMI, the co-simulation standard: scenes exported as co-simulation FMUs (pythonfmu), and the
building of FMUs from small Python models, on demand and cached.

FMUs used as components (through FMPy) are the ``FMU`` component type, in ``components.fmu``.
Everything here needs the ``[fmi]`` extra (``fmpy``, ``pythonfmu``) and imports it lazily.
"""

# set to "1" by a cosim scene that runs FMUs in its process with their log passed on to it
# (components.fmu.instance): an exported scene's failure is then said in that scene's own error line,
# not a second time by the FMU on standard error (cosim.fmi.slave)
HOST_READS_LOG = "COSIM_FMU_HOST_READS_LOG"
