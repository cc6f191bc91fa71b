"""The physics components of the stone-skipping simulation (RigidBody, SolidGround, WaterSurface,
WaterCoupler, StageMonitor) and their messages. Nothing here imports MCAP, Foxglove or YAML."""
