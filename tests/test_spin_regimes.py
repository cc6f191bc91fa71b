"""tools/spin_regimes.py and the history it draws (components.analysis.experiments.attack_history):
the curves are the throws of the validation table, and the tool writes its figure."""

from __future__ import annotations

import numpy as np

from components.analysis import experiments as ex
from tools import spin_regimes


def test_the_history_is_the_tables_throw():
    """The 10 rev/s throw (fig. 7): the history holds the dip and the attack at the bounce that the
    table's outcome reports, and its wetted spell lasts the outcome's contact time."""
    h = ex.attack_history(ex.throw_scene(3.5, 20.0, 20.0, spin_rev_s=10.0))
    assert h.outcome == ex.run_throw(ex.throw_scene(3.5, 20.0, 20.0, spin_rev_s=10.0))
    assert h.attack_deg.min() == h.outcome.attack_deg[0]
    assert h.outcome.attack_deg[2] in h.attack_deg
    wet = h.time_s[h.wetted]
    assert abs((wet[-1] - wet[0]) - h.outcome.contact_s) < 2e-4
    assert h.time_s[0] == 0.0 and np.all(np.diff(h.time_s) > 0)
    # and what the figure shows of it is Rosellini et al.'s fig. 7: the attack dips below 10 deg in
    # the contact and is back above 12 deg when the disk leaves the water, which it does
    assert h.attack_deg[h.wetted].min() < 10.0 < 12.0 < h.attack_deg[h.wetted][-1]
    assert h.outcome.bounced


def test_the_tool_draws_the_three_regimes(tmp_path, capsys):
    png = tmp_path / "regimes.png"
    assert spin_regimes.main(["--figure", str(png)]) == 0
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    out = capsys.readouterr().out
    assert "| fig. 3: 65 rev/s |" in out and "bounces" in out and "sinks" in out
