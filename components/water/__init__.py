"""Height-field water: the WaterSurface component, its models, boundaries and kernels.

Modules: :mod:`.grid` (geometry and face coefficients), :mod:`.models` (``wave``, ``shallow_water``),
:mod:`.boundaries` (``reflecting``, ``absorbing``), :mod:`.kernels_numba` (compiled) and
:mod:`.kernels_numpy` (reference), :mod:`.tiles` (stepping only the water that moves),
:mod:`.diagnostics` (volume, energy), :mod:`.surface` (the
component), :mod:`.sources` (a scripted displacement for scenes).
"""

from components.water.surface import GaussianBump, WaterParams, WaterSurface

__all__ = ["GaussianBump", "WaterParams", "WaterSurface"]
