"""tools/planing_lag.py: the point model of a held disk's planing contacts (docs/validation.md,
section 2) gives the co-simulation's single contact, and a lag of the piled-up water gives back
more of the vertical speed but lengthens the contact."""

from __future__ import annotations

import pytest

from tools import planing_lag as pl


def test_the_point_model_gives_the_co_simulations_single_contact():
    """The aluminium disk at 3.5 m/s, alpha = beta = 20 deg: a contact within 5% of the validation
    table's 36.8 ms, bouncing at a 40 deg impact and not at 45 (as the table's steepest)."""
    contacts, _ = pl.throw(pl.MAGIC_DISK, 3.5, 20.0, 20.0, t_end=0.5)
    assert contacts[0].t_out - contacts[0].t_in == pytest.approx(0.0368, rel=0.05)
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
