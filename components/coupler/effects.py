"""The coupler's effects, switched on by name in a scene (``effects: [buoyancy, pressure, ...]``).

Each effect is one bit of a mask handed to the compiled kernel, plus what it needs: column work
(the occupied height of each water column under the body) or surface-element work (the wetted
faces). An effect that is not named costs nothing; with no effect named the coupler does no
column or element work at all.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Effect:
    """One switchable water effect."""

    name: str
    bit: int
    columns: bool  # needs the occupied height b_ij of the columns under the body
    elements: bool  # needs the wetted surface elements of the body
    doc: str


DISPLACEMENT = 1
BUOYANCY = 2
PRESSURE = 4
FRICTION = 8
WAVE_DRAG = 16
ADDED_MASS = 32

EFFECTS: dict[str, Effect] = {
    e.name: e
    for e in (
        Effect("displacement", DISPLACEMENT, True, False,
               "push the submerged volume into the water (published as OccupiedHeight)"),
        Effect("buoyancy", BUOYANCY, True, False,
               "rho g b_ij s^2 upward at each column's submerged centroid (force and torque)"),
        Effect("pressure", PRESSURE, False, True,
               "hydrodynamic pressure on wetted faces moving into the water (Rosellini/Clanet law)"),
        Effect("friction", FRICTION, False, True,
               "tangential skin friction on wetted faces, -1/2 rho C_f |u| u_t dA"),
        Effect("wave_drag", WAVE_DRAG, True, False,
               "capillary-gravity wave drag against the horizontal velocity above c_min, fading as the body's "
               "top goes under (exp(-2 g d / U^2))"),
        Effect("added_mass", ADDED_MASS, False, False,
               "the water a submerged body carries along, added to its inertia (published as AddedMass)"),
    )
}
"""All effects by name, in their canonical order."""

COLUMN_MASK = sum(e.bit for e in EFFECTS.values() if e.columns)
ELEMENT_MASK = sum(e.bit for e in EFFECTS.values() if e.elements)


def unknown_effects(names: list[str]) -> list[str]:
    """Problems with a list of effect names (unknown or repeated), as plain sentences."""
    problems = []
    seen: set[str] = set()
    for name in names:
        if name not in EFFECTS:
            problems.append(f"unknown effect {name!r} (valid: {', '.join(EFFECTS)})")
        elif name in seen:
            problems.append(f"effect {name!r} is listed twice")
        seen.add(name)
    return problems


def effect_mask(names: list[str]) -> int:
    """The bit mask of the named effects; raises ValueError naming the valid effects on a bad name."""
    problems = unknown_effects(names)
    if problems:
        raise ValueError("; ".join(problems))
    mask = 0
    for name in names:
        mask |= EFFECTS[name].bit
    return mask
