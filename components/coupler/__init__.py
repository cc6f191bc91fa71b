"""The water coupler: two-way stone-water interaction per water column under the body.

Scenes name it ``WaterCoupler`` (or ``Coupler``). Effects are switched on by name
(:data:`components.coupler.effects.EFFECTS`); the force laws are in :mod:`.forces`, the geometry in
:mod:`.geometry`, the compiled per-step work in :mod:`.kernel`, the component in :mod:`.component`.
"""

from components.coupler.component import WaterCoupler, WaterCouplerParams
from components.coupler.effects import EFFECTS

__all__ = ["EFFECTS", "WaterCoupler", "WaterCouplerParams"]
