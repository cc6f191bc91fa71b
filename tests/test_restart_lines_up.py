"""A run restarted from a checkpoint records, from the checkpoint's time on, every exchange and
checkpoint the original recorded: also the outputs of a step that spans that time (the water,
stepping every 14 ticks, publishes at its step's start what it stamps at its end), and no request the
original did not make."""

from __future__ import annotations

from collections import defaultdict
from pathlib import Path

from cosim.cli import main
from cosim.record.reader import Recording

SCENES = Path(__file__).resolve().parent.parent / "scenarios"
FROM_NS = 200_000_000


def _after(path: Path, t_ns: int) -> dict[str, list[tuple[int, bytes]]]:
    """Every recorded message stamped after ``t_ns`` [ns], by channel, but the viewer's (made from
    the exchanges; a restart draws its first frame at its first step) and the run's status."""
    kept: dict[str, list[tuple[int, bytes]]] = defaultdict(list)
    for topic, stamp, payload in Recording(path).raw():
        if stamp > t_ns and not topic.startswith("/scene") and topic not in ("/tf", "/cosim/status"):
            kept[topic].append((stamp, payload))
    return kept


def test_a_restart_records_what_the_original_did_from_its_checkpoint_on(tmp_path):
    original, restarted = tmp_path / "ricochet.mcap", tmp_path / "restarted.mcap"
    assert main(["run", str(SCENES / "ricochet.yaml"), "-q", "--until", "0.4", "-o", str(original)]) == 0
    assert main(["replay", str(original), "--from", "0.2", "-q", "-o", str(restarted)]) == 0
    before, after = _after(original, FROM_NS), _after(restarted, FROM_NS)
    # the water's patch and field of its step from 0.1988 s, stamped 0.2002 s, and the checkpoint at 0.3 s
    assert before["/pond/field"][0][0] == 200_200_000 and "/cosim/checkpoint" in before
    assert sorted(after) == sorted(before)
    for topic, messages in before.items():
        assert after[topic] == messages, topic


def test_a_restart_of_a_restart_records_what_the_original_did(tmp_path):
    """The restart's own checkpoint at its start is the original's, so a restart from it is the original
    again: the pond's field (a port no connection reads) published by the step spanning 0.2 s was left
    out of the first restart's checkpoint, and the second restart lost it."""
    original, once, twice = tmp_path / "ricochet.mcap", tmp_path / "once.mcap", tmp_path / "twice.mcap"
    assert main(["run", str(SCENES / "ricochet.yaml"), "-q", "--until", "0.4", "-o", str(original)]) == 0
    assert main(["replay", str(original), "--from", "0.2", "-q", "-o", str(once)]) == 0
    assert main(["replay", str(once), "--from", "0.2", "-q", "-o", str(twice)]) == 0
    def checkpoint(path: Path) -> bytes:
        return next(data for _, stamp, data in Recording(path).raw(["/cosim/checkpoint"]) if stamp == FROM_NS)

    assert checkpoint(once) == checkpoint(original)
    before, after = _after(original, FROM_NS), _after(twice, FROM_NS)
    assert sorted(after) == sorted(before)
    for topic, messages in before.items():
        assert after[topic] == messages, topic
