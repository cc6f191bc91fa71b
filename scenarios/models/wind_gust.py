"""A wind gust on a thrown stone, as a pythonfmu co-simulation model (FMI 2.0).

The air moves with the wind w(t), a "1 - cosine" gust (the shape aviation's gust loads use):
w = W/2 (1 - cos(2 pi (t - t0) / T)) for t0 <= t <= t0 + T, zero outside, blowing towards the
azimuth ``heading_deg`` (0: along +x, 90: along +y) in the horizontal plane. The stone feels the
quadratic drag of the air passing it: F = 1/2 rho CdA |w - v| (w - v), world frame, v its velocity.
Outside the gust this is still air's drag.

Inputs vx, vy, vz [m/s]; outputs Fx, Fy, Fz [N]; parameters below. The model's whole state is its
registered variables (what pythonfmu serializes for FMU state save and restore). A relative speed
above ``max_speed`` is outside the drag law's range (a compressible flow): the step fails with an
Error naming the speed.
"""

import math

from pythonfmu import Fmi2Causality, Fmi2Slave, Fmi2Variability, Real
from pythonfmu.enums import Fmi2Initial, Fmi2Status

# pythonfmu's binaries (0.7) run this text again in this module's namespace at each instantiation and
# then release one reference to the namespace they never took: each run adds one here to make up for it
globals().setdefault("_held_namespaces", []).append(globals())


class WindGust(Fmi2Slave):
    """Quadratic air drag on a body in a 1 - cosine wind gust."""

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.description = "Air drag on a body in a 1 - cosine wind gust (world frame, SI units)"
        self.peak_speed = 8.0  # [m/s] W, the gust's peak wind speed
        self.start_time = 0.2  # [s] t0, when the gust begins
        self.duration = 0.4  # [s] T, how long it blows
        self.heading_deg = 90.0  # [deg] where the wind blows to: 90 is a crosswind towards +y
        self.drag_area = 0.004  # [m^2] Cd A of the stone (a 5 cm disk, partly edge-on)
        self.air_density = 1.2  # [kg/m^3]
        self.max_speed = 60.0  # [m/s] the drag law's range
        self.vx = self.vy = self.vz = 0.0
        self.Fx = self.Fy = self.Fz = 0.0
        for name in ("peak_speed", "start_time", "duration", "heading_deg", "drag_area", "air_density",
                     "max_speed"):
            self.register_variable(Real(name, causality=Fmi2Causality.parameter,
                                        variability=Fmi2Variability.tunable))
        for name in ("vx", "vy", "vz"):
            self.register_variable(Real(name, causality=Fmi2Causality.input))
        for name in ("Fx", "Fy", "Fz"):  # exact start values: known before the first step
            self.register_variable(Real(name, causality=Fmi2Causality.output, initial=Fmi2Initial.exact,
                                        start=0.0))

    def wind(self, t):
        """Wind speed [m/s] at time t [s]."""
        phase = (t - self.start_time) / self.duration
        if not 0.0 <= phase <= 1.0:
            return 0.0
        return 0.5 * self.peak_speed * (1.0 - math.cos(2.0 * math.pi * phase))

    def do_step(self, current_time, step_size):
        # the force held over the step is the drag at its start (an explicit step, as a
        # co-simulation sees its inputs)
        w = self.wind(current_time)
        heading = math.radians(self.heading_deg)
        rx = w * math.cos(heading) - self.vx
        ry = w * math.sin(heading) - self.vy
        rz = -self.vz
        speed = math.sqrt(rx * rx + ry * ry + rz * rz)
        if speed > self.max_speed:
            message = (f"relative air speed {speed:.6g} m/s at t = {current_time:.6g} s is above "
                       f"max_speed = {self.max_speed:g} m/s")
            self.log(message, Fmi2Status.error)
            raise ValueError(message)
        k = 0.5 * self.air_density * self.drag_area * speed
        self.Fx, self.Fy, self.Fz = k * rx, k * ry, k * rz
        return True
