"""The physics components of the stone-skipping simulation (RigidBody, SolidGround, WaterSurface,
WaterCoupler, StageMonitor) and their messages. Nothing here imports MCAP, Foxglove or YAML."""

from components import kernel_cache

kernel_cache.refresh()  # before any kernel can load stale machine code from numba's cache
