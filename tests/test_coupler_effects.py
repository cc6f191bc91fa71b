"""The coupler's effects registry (components.coupler.effects)."""

import pytest

from components.coupler.effects import (
    COLUMN_MASK,
    EFFECTS,
    ELEMENT_MASK,
    effect_mask,
    unknown_effects,
)


def test_the_six_effects_in_canonical_order():
    """The registry holds displacement, buoyancy, pressure, friction, wave_drag, added_mass with
    distinct bits."""
    assert list(EFFECTS) == ["displacement", "buoyancy", "pressure", "friction", "wave_drag", "added_mass"]
    bits = [e.bit for e in EFFECTS.values()]
    assert len(set(bits)) == 6 and all(b & (b - 1) == 0 for b in bits)


def test_work_kinds_partition_the_forces():
    """Each force needs column work or element work, never neither; the added mass is no force of
    its own (it rides on the submergence the others find)."""
    assert COLUMN_MASK & ELEMENT_MASK == 0
    assert COLUMN_MASK | ELEMENT_MASK == effect_mask([name for name in EFFECTS if name != "added_mass"])
    assert not (COLUMN_MASK | ELEMENT_MASK) & EFFECTS["added_mass"].bit


def test_mask_of_names():
    """The mask is the OR of the named effects' bits; no names give 0."""
    assert effect_mask([]) == 0
    assert effect_mask(["pressure", "buoyancy"]) == EFFECTS["pressure"].bit | EFFECTS["buoyancy"].bit


def test_unknown_effect_lists_the_valid_ones():
    """An unknown name is an error naming it and every valid effect."""
    with pytest.raises(ValueError, match=r"unknown effect 'lift' \(valid: displacement, buoyancy, pressure, "
                                         r"friction, wave_drag, added_mass\)"):
        effect_mask(["buoyancy", "lift"])


def test_repeated_effect_is_reported():
    """Naming an effect twice is reported as such."""
    assert unknown_effects(["friction", "friction"]) == ["effect 'friction' is listed twice"]
