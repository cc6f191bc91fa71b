"""The coupler-alone benchmark times the coupler's real work: re-run on the held skip's captured
inputs, a fresh coupler publishes what the coupler of the whole run published, step by step."""

from __future__ import annotations

import importlib.util
import pickle
import sys
from pathlib import Path

from cosim.messages import messages_equal

TOOL = Path(__file__).resolve().parent.parent / "tools" / "bench_coupler_alone.py"


def load_tool():
    spec = importlib.util.spec_from_file_location("bench_coupler_alone", TOOL)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


def test_the_coupler_alone_publishes_what_it_published_in_the_run(tmp_path):
    bench = load_tool()
    seen: list[dict] = []
    steps_file = tmp_path / "steps.pickle"
    n = bench.capture(steps_file, seen)
    assert n == len(seen) > 4000  # the whole held skip: flight, four contacts, glide
    steps = pickle.loads(steps_file.read_bytes())
    coupler = bench._fresh_coupler()
    wet = 0
    for (t_ns, dt_ns, inputs, args, kwargs), published in zip(steps, seen, strict=True):
        again = coupler.step(t_ns, dt_ns, inputs, *args, **kwargs)
        assert again.keys() == published.keys(), t_ns
        assert all(messages_equal(again[port], published[port]) for port in again), t_ns
        wet += "contact" in again and again["contact"].wetted
    assert wet > 1000  # the contacts and the glide were re-run, not only the flight


def test_a_revision_that_is_none_is_said_before_anything_runs(capsys, monkeypatch):
    """--against a revision the repository does not have: one line, exit 2, before the held skip is
    run to capture its steps (it was said only after that run, a minute later on a busy machine)."""
    tool = load_tool()
    monkeypatch.setattr(tool, "capture", lambda path: (_ for _ in ()).throw(AssertionError("ran the skip")))
    assert tool.main(["--against", "no-such-revision"]) == 2
    assert capsys.readouterr().err.strip() == f"error: --against no-such-revision: not a revision of {tool.ROOT}"
