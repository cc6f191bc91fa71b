"""Counts in what the commands print are in their number: "1 connection", not "1 connections"."""

from __future__ import annotations

from pathlib import Path

from cosim.cli import main
from cosim.errors import counted

ROOT = Path(__file__).resolve().parents[1]


def test_counted_puts_the_noun_in_the_count_s_number():
    assert counted(0, "step") == "0 steps"
    assert counted(1, "step") == "1 step"
    assert counted(2, "component step") == "2 component steps"
    assert counted(1, "bounce", "bounces") == "1 bounce"
    assert counted(3, "body", "bodies") == "3 bodies"


def test_validate_says_one_connection(capsys):
    assert main(["validate", str(ROOT / "scenarios" / "drop_ripple.yaml")]) == 0
    assert "2 components, 1 connection, dt" in capsys.readouterr().out


def test_a_run_of_one_step_says_one_step(tmp_path, capsys):
    scene = ROOT / "scenarios" / "ping_pong.yaml"
    assert main(["run", str(scene), "--no-record", "-q", "--set", "until=0.001", "--set", "dt=0.001"]) == 0
    assert "in 1 step of 1 ms (" in capsys.readouterr().out


def test_shortened_puts_a_message_on_one_line_within_its_length():
    from cosim.errors import shortened

    assert shortened("disk\n  full", 100) == "disk full"
    cut = shortened("x" * 500, 200)
    assert len(cut) == 200 and cut.endswith("...")
    assert shortened("y" * 200, 200) == "y" * 200
