"""Many runs of one scene over a grid or random plan of its values (``cosim sweep``).

- :mod:`~cosim.sweep.plan`: the sweep file, its axes and derived values, the points it makes;
- :mod:`~cosim.sweep.backends`: where the points run (a process pool, or a Dask cluster);
- :mod:`~cosim.sweep.run`: running a plan, resumable, a failed point a row like any other;
- :mod:`~cosim.sweep.table`: the result table (CSV, or Parquet) and its journal;
- :mod:`~cosim.sweep.figure`: the summary figure (heat map, line or scatter);
- :mod:`~cosim.sweep.command`: the ``cosim sweep`` subcommand.

Public face: :func:`load_sweep`, :func:`loads_sweep`, :class:`Sweep`, :func:`run_sweep`.
"""

from __future__ import annotations

from cosim import lazy_exports

_EXPORTS = {
    "Sweep": "cosim.sweep.plan",
    "load_sweep": "cosim.sweep.plan",
    "loads_sweep": "cosim.sweep.plan",
    "run_sweep": "cosim.sweep.run",
}

__all__ = ["Sweep", "load_sweep", "loads_sweep", "run_sweep"]

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
