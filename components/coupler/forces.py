"""Water force laws on a body, as plain functions (physics.md section 3).

Sign convention: ``n`` is the element's OUTWARD normal and ``u`` its velocity relative to the water
(body point velocity minus the water's velocity). A height field knows the surface's vertical
velocity only; under the surface the water's is taken on the long-wave profile, falling linearly
from the surface's at the surface to 0 at the bed (continuity through a layer whose horizontal flow
is uniform over its depth). Shorter waves die out faster with depth (sinh(k z) / sinh(k H) <= z / H
for a wave of number k on depth H), so this is the most the surface's motion can move the water at
a submerged element. A face advances into the water when ``u.n > 0``; the pressure then pushes it back along
``-n``. (physics.md writes the same condition as ``u.n < 0`` with ``u`` the water's velocity seen
from the face.)

* Pressure (Rosellini et al. 2005, Clanet et al. 2004; Newtonian term of Nagahiro & Hayakawa 2005)::

      dF = -1/2 rho_w (C_L |u| (u.n) + C_N (u.n)^2) dA n        where u.n > 0, else 0

  For a flat plate at attack angle alpha moving at speed U with impact angle beta,
  u.n = U sin(alpha + beta), so the sum is the published F = 1/2 rho_w C_L U^2 S sin(alpha + beta).
  A disk's spin about its own axis only slides its faces and rim along themselves and pushes no
  water, so the pressure uses the point velocity without that spin (friction uses all of it); a
  sphere's rotation likewise moves no water and is left out of its pressure.
* Impact pressure on a blunt body (a sphere). The law above is the one measured on a skipping disk,
  a lifting surface: a flat face that meets the water at a small angle and sheds it at its trailing
  edge carries a pressure linear in the angle (planing, like a thin wing's lift). A sphere has no
  such face: each part of it meets the water head on, and the pressure there is the impact
  (modified Newtonian) pressure, the law above with C_L = 0 and C_N = C_B::

      p = 1/2 rho_w C_B (u.n)^2        where u.n > 0, else 0

  C_B = 1 is the stagnation pressure 1/2 rho U^2 where the surface faces the flow (no coefficient
  fitted). Summed over a half-immersed sphere's advancing quarter it is a drag coefficient of 0.5
  on the immersed half-disk (a sphere's is 0.47 at Reynolds numbers 1e4-2e5), and it gives
  Johnson & Reid's ricochet law 18 deg / sqrt(relative density) within a few per cent at the
  speeds where that law applies (docs/validation.md). The disk's planing law on a sphere's cap gave
  it twice that lift and ricochets at 25 deg instead of 18.
* Planing and submerged (physics.md section 3). The law above is a planing law: it holds while the
  body pierces the surface, with a splash sheet ahead and an air cavity behind it. Once the water
  closes over the body's highest point (over ``closure_depth``) the body is submerged: the pressure
  becomes a drag along the relative velocity on the face's projected area::

      dF = -1/2 rho_w C_D (u.n) u dA        where u.n > 0

  which sums to the textbook ``-1/2 rho_w C_D |u| u A_projected`` (C_D = 1.17 for a disk face on;
  0.457 for a sphere, its measured 0.47 less the skin friction 8/3 C_f = 0.013 that the friction
  effect adds over it), with no lift; on a disk its torque comes from the geometry, and on a
  sphere it passes through the centre (a pressure is normal to the surface).
* Friction (Bocquet 2003): ``dF_t = -1/2 rho_w C_f |u| u_t dA`` on every wetted element, with
  ``u_t = u - (u.n) n``. The default C_f = 0.005 is a smooth turbulent flat plate's skin friction
  at the stones' Reynolds numbers: the ITTC-1957 line C_f = 0.075 / (log10 Re - 2)^2, the one
  planing-hull practice uses for a planing face's friction (Savitsky 1964), gives 0.0055 to 0.0047
  for Re = U 2R / nu = 5e5 to 1e6 (a 10 cm stone at 5 to 10 m/s). Nothing is fitted: the pressure
  law already carries the plate's drag (its force along -n tilts backwards by the attack angle),
  and no measurement of a skipping stone fixes a friction of its own (Bocquet's mu is a ratio of
  coefficients he leaves free). Larger values would lump in spray losses.
  A face receding from the water (u.n < 0) stays wetted only if the water can follow it: its
  hydrostatic head accelerates the water at most like g, so a face leaving faster than about
  sqrt(2 g d) at depth d opens an air cavity (ventilates). The friction of a receding element is
  scaled by the smooth factor ``2 g d / (2 g d + (u.n)^2)`` (:func:`ventilation`), d the mean depth
  of the element's wetted part (its centre's depth once it is wholly under): 1 for a face sliding
  along itself or receding slowly deep down, about 0 for the upper face and trailing rim of a
  skipping stone, which are in its air cavity. Air reaches that cavity only from the surface the
  body pierces, so the factor acts in the body's planing share alone (the share the pressure law
  gives the planing law): a body wholly under water is not ventilated, and its whole skin friction
  adds to the submerged pressure drag (a sphere's C_D below is the measured one less that friction).
* Buoyancy: ``rho_w g b s^2`` upward per column (or sub-column) at its wet interval's centroid.
* Capillary-gravity wave drag (Raphael & de Gennes 1996: no waves, hence no wave resistance, below
  c_min = (4 g gamma / rho_w)^(1/4) = 0.23 m/s). Chosen form, a drag on the immersed cross-section
  that saturates past the hull speed::

      F_w = -1/2 rho_w C_W S_w (U^2 - c_min^2) / (1 + U^2 / (g L)) exp(-2 g d / U^2) U_hat,  U > c_min
      S_w = V_sub / L,   L = 2 R

  U is the body's horizontal speed (the water has no horizontal velocity in a height field), V_sub
  the submerged volume and L the body's length along the motion, so S_w is the mean immersed
  cross-section. It vanishes continuously at c_min (Raphael & de Gennes find a jump for a point
  disturbance; a body much larger than the capillary length, 2.7 mm, smooths it, and a continuous
  onset keeps the dynamics step-size independent). Slow, it grows like a form drag; past the hull
  speed sqrt(g L) the wave resistance of a body stops growing (Havelock), so F_w tends to
  1/2 C_W rho_w g V_sub, a fixed share of the displaced weight: a floating ball pushed at 0.5 m/s
  feels it fully, a stone skimming at 8 m/s (Froude number ~10) hardly at all. d is the depth of the
  body's top under the surface (0 while it pierces it): a body under water makes waves only through
  the pressure it sets up at the surface, Havelock's factor (:func:`wave_drag_magnitude`). It acts at
  the submerged centroid. C_W is a calibration coefficient (default 0.3).
"""

from __future__ import annotations

import math

from numba import njit

from components import kernel_cache

kernel_cache.install()  # before the cached kernels below: their cache keyed on every kernel source

RHO_WATER = 1000.0  # water density [kg/m^3]
GRAVITY = 9.81  # gravitational acceleration [m/s^2]
SURFACE_TENSION = 0.072  # water-air surface tension [N/m]
C_MIN = (4.0 * GRAVITY * SURFACE_TENSION / RHO_WATER) ** 0.25  # minimum capillary-gravity wave speed [m/s]
C_LIFT = 1.0  # C_L of the pressure law [-] (physics.md: about 1)
C_NEWTONIAN = 1.4  # C_N of the Newtonian (u.n)^2 term when switched on [-] (Nagahiro & Hayakawa 2005)
C_FRICTION = 0.005  # C_f of the skin friction [-]: the ITTC-1957 line at Re = 5e5-1e6 (0.0055-0.0047)
C_WAVE = 0.3  # C_W of the capillary-gravity wave drag [-] (calibration coefficient)
C_IMPACT = 1.0  # C_B of the impact pressure on blunt surfaces [-]: the stagnation pressure 1/2 rho U^2 where
# the surface meets the flow head on (modified Newtonian theory)
C_DRAG_DISK = 1.17  # C_D of a submerged disk face on [-] (Hoerner, Fluid-Dynamic Drag, 1965)
C_DRAG_SPHERE_TOTAL = 0.47  # the measured C_D of a submerged sphere [-] (subcritical Reynolds numbers, 1e4-2e5)
# its pressure (form) drag [-]: the measured total holds the skin friction too, which the friction
# effect adds over the sphere, 1/2 rho C_f U^2 times (8/3) pi R^2 (sin^2 over its surface); counted
# in both, a granite ball sank 1.4% slower than the measured C_D gives
C_DRAG_SPHERE = C_DRAG_SPHERE_TOTAL - 8.0 / 3.0 * C_FRICTION
CLOSURE_DEPTH = 1e-3  # depth [m] of the body's top under the surface over which planing gives way


@njit(cache=True)
def pressure_magnitude(speed: float, u_n: float, rho: float, c_l: float, c_n: float) -> float:
    """Pressure [Pa] on a face advancing into the water at normal speed ``u_n`` > 0 (0 otherwise)."""
    if u_n <= 0.0:
        return 0.0
    return 0.5 * rho * (c_l * speed * u_n + c_n * u_n * u_n)


@njit(cache=True)
def friction_factor(speed: float, rho: float, c_f: float) -> float:
    """Factor k [kg/m^3 * m/s] such that the friction traction is -k u_t [Pa]."""
    return 0.5 * rho * c_f * speed


@njit(cache=True)
def ventilation(u_n: float, depth: float, g: float) -> float:
    """Wetted share [-] of a face receding at normal speed -u_n from water at ``depth`` [m] below the
    surface: 2 g d / (2 g d + u_n^2), smooth, 1 when not receding."""
    if u_n >= 0.0:
        return 1.0
    head = 2.0 * g * depth
    if head <= 0.0:
        return 0.0
    return head / (head + u_n * u_n)


@njit(cache=True)
def wave_drag_magnitude(speed: float, volume: float, length: float, rho: float, c_w: float,
                        c_min: float, g: float, depth: float = 0.0) -> float:
    """Capillary-gravity wave drag [N] against a horizontal ``speed`` [m/s] (0 below c_min) of a
    body whose top is ``depth`` [m] under the surface (0 or less: it pierces the surface).

    A body under water makes waves only through the pressure its flow sets up at the surface, and
    the pressure of a wave of number k falls off with depth as exp(-k d): a submerged body's wave
    resistance carries Havelock's factor exp(-2 k0 f), k0 = g / U^2 the wave number of the
    waves that keep pace with it, f its depth (Havelock 1931; Wehausen & Laitone 1960, section 19).
    Here f is the depth of the body's top, so the drag goes on continuously from the surface-piercing
    law as the water closes over the body; without it a sphere 20 cm under water at 1 m/s felt the
    same wave drag as one at the surface (0.029 N, a sixth of its pressure drag) where the factor
    gives 0.029 of it (its top 18 cm under)."""
    if speed <= c_min or volume <= 0.0 or length <= 0.0:
        return 0.0
    froude2 = speed * speed / (g * length) if g > 0.0 else 0.0
    drag = 0.5 * rho * c_w * (volume / length) * (speed * speed - c_min * c_min) / (1.0 + froude2)
    if depth > 0.0 and g > 0.0:
        drag *= math.exp(-2.0 * g * depth / (speed * speed))
    return drag


def segment_area(radius: float, s_f: float) -> float:
    """Wetted area [m^2] of a flat disk immersed over a depth ``s_f`` along its face (circular segment)."""
    if s_f <= 0.0:
        return 0.0
    if s_f >= 2.0 * radius:
        return math.pi * radius * radius
    x = 1.0 - s_f / radius
    return radius * radius * (math.acos(x) - x * math.sqrt(1.0 - x * x))


def plate_force(rho: float, c_l: float, speed: float, area: float, alpha: float, beta: float) -> float:
    """Rosellini et al. force [N] on a plate of wetted ``area`` at attack ``alpha``, impact ``beta`` [rad]."""
    return 0.5 * rho * c_l * speed * speed * area * math.sin(alpha + beta)
