"""Scene input found by an audit, each now refused in one line (exit 2), read as written, or said:

- a key path index in digits int() does not read ('²') was an internal error, and one in full-width
  digits (a full-width 1) named an item;
- a random sweep axis `uniform: [-1e308, 1e308]` overflowed numpy's draw (an internal error);
- a sweep's inline scene was written back with YAML 1.1's quoting and read with YAML 1.2's numbers:
  a name "1e5" came back as 100000.0;
- a time off a whole number of nanoseconds by up to a millionth of itself was rounded without a word
  from 0.5 ms up (dt 0.0012345678912 s ran as 1234568 ns);
- `record: []`, `false`, `0` or `''` was taken for the default record block;
- a scene of a thousand components fed by one took seconds to order (the sort ran per component);
- a run of billions of steps started without a word.
"""

from __future__ import annotations

import pytest

from cosim.cli import main
from cosim.errors import ScenarioError
from cosim.scenario import LONG_RUN_S, execution_order, loads, read_yaml
from cosim.sweep.plan import yaml_value
from cosim.timebase import seconds_to_ns
from tests.cli_toys import one_error_line

BASE = """
name: base
dt: 0.001
until: 0.01
components:
  ping: {type: "cosim.examples:Ping"}
  pong: {type: "cosim.examples:Pong"}
connections:
  - ping.out -> pong.inp
  - {from: pong.out, to: ping.inp, delay: 1, initial: {value: 0.0}}
"""


@pytest.mark.parametrize("index", ["\u00b2", "\uff11"])  # superscript 2, full-width 1
def test_a_key_path_index_in_other_digits_is_no_such_key(index):
    with pytest.raises(ScenarioError) as refused:
        loads(BASE, "base.yaml", [f"connections.{index}.delay=1"])
    assert refused.value.problems == [f"--set connections.{index}.delay: no such key 'connections.{index}' "
                                      "(a list of 2 items: indices 0 to 1)"]
    with pytest.raises(ScenarioError) as refused:
        loads(BASE, "base.yaml", [f"connections.{index}=x"])
    assert "no such key" in refused.value.problems[0]


def test_a_uniform_draw_over_more_than_a_float_spans_is_refused(tmp_path, capsys):
    (tmp_path / "base.yaml").write_text(BASE)
    (tmp_path / "sweep.yaml").write_text("scene: base.yaml\nmode: random\nsamples: 3\n"
                                         "axes:\n  connections.1.initial.value: {uniform: [-1e308, 1e308]}\n")
    assert main(["sweep", str(tmp_path / "sweep.yaml"), "-q", "--dry-run", "-o", str(tmp_path / "x.csv")]) == 2
    assert one_error_line(capsys.readouterr().err).endswith(
        "axes.connections.1.initial.value.uniform: the span from -1e+308 to 1e+308 is beyond what a float holds; "
        "give ends whose difference is finite")


@pytest.mark.parametrize("text", ["1e5", "0o17", "017", "0x10", ".5", "-3", "1:30", "yes", "null"])
def test_text_that_reads_as_a_number_goes_out_quoted_and_comes_back_as_text(text):
    """What a sweep writes (its points' values, an inline scene) is read back by the scene's YAML 1.2
    reader as the text it was."""
    assert read_yaml(yaml_value(text), "x") == text
    assert read_yaml(yaml_value({"name": text, "values": [text, 1e-5]}), "x") == {"name": text, "values": [text, 1e-5]}


def test_an_inline_scene_keeps_its_quoted_text(tmp_path, capsys):
    """A sweep's inline scene named "1e5" with the description "0o17" was refused: 'name: must be a
    string (got 100000.0)'."""
    scene = BASE.replace("name: base", 'name: "1e5"\ndescription: "0o17"').replace("\n", "\n  ")
    (tmp_path / "sweep.yaml").write_text(f"scene:{scene}\naxes:\n  connections.1.initial.value: [0.0, 1.0]\n")
    assert main(["sweep", str(tmp_path / "sweep.yaml"), "-q", "--dry-run", "-o", str(tmp_path / "x.csv")]) == 0
    assert ": ok - " in capsys.readouterr().out


@pytest.mark.parametrize("seconds", [0.0012345678912, 0.0010000001, 0.5000000004, 12.0000000001])
def test_a_time_off_the_nanosecond_grid_is_refused_whatever_its_size(seconds):
    with pytest.raises(ValueError, match="must be a whole number of nanoseconds"):
        seconds_to_ns(seconds)


@pytest.mark.parametrize(("seconds", "ns"), [(0.0005, 500_000), (2.096, 2_096_000_000), (0.1 + 0.2, 300_000_000),
                                             (1e-9, 1), (6.0, 6_000_000_000), (86400.000000001, 86_400_000_000_001)])
def test_a_time_on_the_grid_is_read_through_its_floats_round_off(seconds, ns):
    assert seconds_to_ns(seconds) == ns


@pytest.mark.parametrize("value", ["[]", "false", "0", "''"])
def test_a_record_block_that_is_no_mapping_is_refused(value):
    with pytest.raises(ScenarioError) as refused:
        loads(BASE, "base.yaml", [f"record={value}"])
    assert refused.value.problems[0].startswith("record: must be a mapping (got ")
    assert loads(BASE, "base.yaml", ["record=null"]).record == loads(BASE, "base.yaml").record


def test_components_ready_together_run_in_the_order_they_are_declared():
    """Kahn's order with the ready components on a heap (a sort by declaration at every release made
    a thousand components fed by one take 3.5 s to order): ties still go in declaration order."""
    from cosim.scenario import Connection

    names = ["p", *(f"q{k}" for k in range(2000))]
    order, cycle = execution_order(names, [Connection("p", "out", f"q{k}", "inp") for k in range(1999, -1, -1)])
    assert cycle is None and order == names
    order, _ = execution_order(["c", "a", "b", "d"], [Connection("b", "out", "a", "inp"),
                                                      Connection("d", "out", "c", "inp")])
    assert order == ["b", "a", "d", "c"]


def test_a_run_that_must_take_hours_is_told_its_least_time():
    """Told with the least time the scheduler alone takes, 0.5 us a base tick and 2 us a component
    step: a billion steps, or a component stepping every million ticks of 1 ns, which still pays for
    every tick (it had no word)."""
    (notice,) = loads(BASE, "base.yaml", ["dt=1e-9", "until=1e9"]).notices
    assert notice == ("until 1000000000.0 s at dt = 1e-09 s is 1e+18 ticks and 2e+18 component steps: even at the "
                      "scheduler's own 0.5 us a tick and 2 us a step, with no physics, the run takes at least "
                      "1.43e+05 years; check dt, until and the components' every")
    (notice,) = loads(BASE, "base.yaml", ["dt=1e-9", "until=100000", "components.ping.every=1000000",
                                          "components.pong.every=1000000"]).notices
    assert "is 1e+14 ticks and 2e+08 component steps" in notice and "at least 1.58 years" in notice
    ticks = LONG_RUN_S / 2.5e-6 / 2  # (each tick steps both: 2.5 us a tick)
    assert loads(BASE, "base.yaml", [f"until={ticks * 1e-9:g}", "dt=1e-9"]).notices == []


def test_a_time_a_hair_over_the_largest_is_said_over_it():
    """until 9223372036.854775807 s (2^63 ns as a float) was refused as 'must be between 1e-09 s and
    9.22e+09 s (got 9.22337e+09)', a value that reads within the range."""
    with pytest.raises(ScenarioError) as refused:
        loads(BASE, "base.yaml", ["until=9223372036.854775807"])
    assert refused.value.problems == ["until: must be between 1e-09 s and 9.22e+09 s (got 9223372036.854776, over "
                                      "the largest, 9223372036.854775807 s)"]
    with pytest.raises(ScenarioError) as refused:
        loads(BASE, "base.yaml", ["until=1e30"])
    assert refused.value.problems == ["until: must be between 1e-09 s and 9.22e+09 s (got 1e+30)"]


def test_a_time_a_hair_under_the_tick_is_said_under_it():
    with pytest.raises(ScenarioError) as refused:
        loads(BASE, "base.yaml", ["dt=9.9999999999e-10"])
    assert refused.value.problems[0] == ("dt: must be between 1e-09 s and 9.22e+09 s (shorter than the clock's 1 ns "
                                         "tick) (got 9.9999999999e-10, under the smallest, 0.000000001 s)")


@pytest.mark.parametrize("seconds", [1000.0000000005, 600.0000000004, 1e-12])
def test_a_time_half_a_nanosecond_off_is_refused_however_long(seconds):
    """(The tolerance was a thousandth of a nanosecond or 1e-12 of the time: from 500 s up half a
    nanosecond was rounded away; now it is the float's own last bits.)"""
    with pytest.raises(ValueError, match="must be a whole number of nanoseconds"):
        seconds_to_ns(seconds)
