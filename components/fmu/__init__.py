"""FMU: a co-simulation FMU (FMI 2.0 or 3.0, through FMPy) as a component; its variables mapped onto
typed ports. Needs the ``[fmi]`` extra."""

from components.fmu.component import FMU

__all__ = ["FMU"]
