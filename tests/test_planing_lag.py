"""tools/planing_lag.py: the point model of a held disk's planing contacts (docs/validation.md,
section 2) gives the co-simulation's single contact, and a lag of the piled-up water gives back
more of the vertical speed but lengthens the contact."""

from __future__ import annotations

import pytest

from tools import contact_time_law
from tools import planing_lag as pl


def test_the_point_model_gives_the_co_simulations_single_contact():
    """The aluminium disk at 3.5 m/s, alpha = beta = 20 deg: a contact within 1.5% of Rosellini et
    al.'s law alone (tools/contact_time_law.py's own point model, 36.5 ms; this one 36.9 ms), which
    the co-simulation's contact matches (36.4 ms, the validation table); bouncing at a 40 deg impact
    and not at 45 (as the table's steepest). It compared with a pinned 36.8 ms, within 5%."""
    contacts, _ = pl.throw(pl.MAGIC_DISK, 3.5, 20.0, 20.0, t_end=0.5)
    law, bounced = contact_time_law.law_contact(3.5, 20.0, 20.0)
    assert bounced
    assert contacts[0].t_out - contacts[0].t_in == pytest.approx(law, rel=0.015)
    assert pl.bounces(pl.MAGIC_DISK, 3.5, 40.0, 20.0, 0.0)
    assert not pl.bounces(pl.MAGIC_DISK, 3.5, 45.0, 20.0, 0.0)


def test_the_planing_law_gives_back_part_of_the_vertical_speed_and_the_lag_more():
    """The held reference stone's first contact: the law gives back 0.5 to 0.7 of the vertical speed
    it met the water with; Wagner's lagged rise gives back more, and its contact lasts longer."""
    def first(rise: float) -> pl.Contact:
        return pl.throw(pl.REFERENCE_STONE, 11.0, 6.0, 8.0, rise, t_end=0.3)[0][0]

    law, lagged = first(0.0), first(pl.WAGNER_RISE)
    given_back = -law.vz_out / law.vz_in
    assert 0.5 < given_back < 0.7
    assert -lagged.vz_out / lagged.vz_in > given_back + 0.1
    assert lagged.t_out - lagged.t_in > law.t_out - law.t_in


def test_the_lag_on_the_way_out_only_keeps_the_entry_and_gives_back_more():
    """Lagged only while the face rises, the aluminium disk's single contact and its steepest
    bouncing impact stay the law's (within 2%; 40 deg, not 45), the held reference stone's first
    contact gives back more of its vertical speed than the law, and its speed lost per contact
    still falls from contact to contact (docs/validation.md, section 2)."""
    law = pl.throw(pl.MAGIC_DISK, 3.5, 20.0, 20.0, t_end=0.5)[0][0]
    out = pl.throw(pl.MAGIC_DISK, 3.5, 20.0, 20.0, pl.WAGNER_RISE, t_end=0.5, exit_only=True)[0][0]
    assert out.t_out - out.t_in == pytest.approx(law.t_out - law.t_in, rel=0.02)
    assert pl.bounces(pl.MAGIC_DISK, 3.5, 40.0, 20.0, pl.WAGNER_RISE, exit_only=True)
    assert not pl.bounces(pl.MAGIC_DISK, 3.5, 45.0, 20.0, pl.WAGNER_RISE, exit_only=True)
    stone = pl.throw(pl.REFERENCE_STONE, 11.0, 6.0, 8.0, pl.WAGNER_RISE, exit_only=True)[0]
    plain = pl.throw(pl.REFERENCE_STONE, 11.0, 6.0, 8.0)[0]
    assert -stone[0].vz_out / stone[0].vz_in > -plain[0].vz_out / plain[0].vz_in + 0.05
    losses = [c.vx_in ** 2 + c.vz_in ** 2 - c.vx_out ** 2 - c.vz_out ** 2 for c in stone[:4]]
    assert losses == sorted(losses, reverse=True)


def test_the_impact_angle_held_through_the_contact_gives_back_the_vertical_speed_and_loses_the_magic_angle():
    """Read with the touchdown's direction through each contact (Bocquet's elastic contact), the law
    gives back nearly all of the held reference stone's vertical speed and loses about the same V^2
    at its first four contacts (within 25%, Bocquet's row), but the magic-angle disk then bounces
    at lower speeds at 10 deg than at 20, there below half the measured 2.5 m/s: the heave damping the
    coupler's law has is what puts the minimum where Clanet et al. measured it (docs/validation.md,
    section 2)."""
    stone = pl.throw(pl.REFERENCE_STONE, 11.0, 6.0, 8.0, held_angle=True)[0]
    assert -stone[0].vz_out / stone[0].vz_in > 0.9
    losses = [c.vx_in ** 2 + c.vz_in ** 2 - c.vx_out ** 2 - c.vz_out ** 2 for c in stone[:4]]
    assert max(losses) < 1.25 * min(losses)
    held = {alpha: pl.u_min(alpha, 0.0, held_angle=True) for alpha in (10.0, 20.0)}
    assert held[10.0] < min(held[20.0], 1.25)
    law = {alpha: pl.u_min(alpha, 0.0) for alpha in (10.0, 20.0)}
    assert law[20.0] < law[10.0]
    assert law[20.0] == pytest.approx(2.30, abs=0.02)
