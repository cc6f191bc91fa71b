"""Scheduler trace tests: execution order and the inputs each step received."""

from __future__ import annotations

import math

import pytest

from cosim.errors import SimulationError
from cosim.scenario import loads
from cosim.scheduler import BaseObserver, Simulation


def run(text: str, **kw):
    scene = loads(text)
    sim = Simulation(scene, **kw)
    result = sim.run()
    return sim, result


def values(comp, port="x"):
    """(step start [ms], received value) pairs of a toy component's recorded inputs."""
    return [(round(t * 1000, 6), None if d[port] is None else round(d[port].value, 9)) for t, d in comp.seen]


class Trace(BaseObserver):
    def __init__(self):
        self.exchanges = []
        self.events = []
        self.finished = None

    def on_exchange(self, time_ns, component, port, msg):
        self.exchanges.append((time_ns, component, port))

    def on_event(self, time_ns, component, kind, detail):
        self.events.append((time_ns, component, kind, detail))

    def on_finished(self, sim, result):
        self.finished = result


def test_chain_runs_in_topological_order_and_sees_this_ticks_outputs():
    """Chain src -> g -> acc:

        src.out --> g.x --> g.out --> acc.x

    declared in reverse order, it still runs src, g, acc each tick, and each receiver sees the value its
    source produced for the end of the same step (Gauss-Seidel)."""
    sim, result = run("""
dt: 0.001
until: 0.003
components:
  acc: {type: "tests.toys:Accumulator"}
  g: {type: "tests.toys:Gain", gain: 2}
  src: {type: "tests.toys:Source", rate: 1000}
connections:
  - g.out -> acc.x
  - src.out -> g.x
""")
    assert sim.scene.order == ["src", "g", "acc"]
    assert values(sim.components["g"]) == [(0.0, 1.0), (1.0, 2.0), (2.0, 3.0)]
    assert values(sim.components["acc"]) == [(0.0, 2.0), (1.0, 4.0), (2.0, 6.0)]
    assert result.status == "ok" and result.tick == 3


def test_cycle_with_delay_feeds_previous_step_value_and_initial_first():
    """Cycle through a delayed edge:

        g.out --> acc.x --> acc.total -(delay)-> g.x

    g first receives the edge's initial value, then the total acc published at the end of the
    previous step."""
    sim, _ = run("""
dt: 0.001
until: 0.004
components:
  g: {type: "tests.toys:Gain", gain: 1000}
  acc: {type: "tests.toys:Accumulator"}
connections:
  - g.out -> acc.x
  - {from: acc.total, to: g.x, delay: 1, initial: {value: 1.0}}
""")
    assert sim.scene.order == ["g", "acc"]
    # total_{k+1} = total_k + 1000 * x_k * dt with x_0 = initial = 1  ->  1, 2, 4, 8
    assert values(sim.components["g"]) == [(0.0, 1.0), (1.0, 1.0), (2.0, 2.0), (3.0, 4.0)]
    assert values(sim.components["acc"]) == [(0.0, 1000.0), (1.0, 1000.0), (2.0, 2000.0), (3.0, 4000.0)]


def test_delayed_edge_ignores_initial_outputs_and_uses_its_own_initial():
    """A t = 0 initial output of the source is not delivered through a delayed edge: the edge's own
    initial value is, so a scene states explicitly what a loop starts from."""
    sim, _ = run("""
dt: 0.001
until: 0.002
components:
  g: {type: "tests.toys:Gain", gain: 1}
  acc: {type: "tests.toys:Accumulator"}
connections:
  - g.out -> acc.x
  - {from: acc.total, to: g.x, delay: 1, initial: {value: 7.0}}
""")
    assert values(sim.components["g"])[0] == (0.0, 7.0)


def test_each_component_reads_its_inputs_at_t0_before_the_first_step():
    """start_inputs: a direct edge's value at t = 0 is its source's initial output, a delayed edge's
    its own initial (not the source's initial output); a step, by contrast, sees the values at its
    end."""
    sim, _ = run("""
dt: 0.001
until: 0.002
components:
  g: {type: "tests.toys:Gain", gain: 1}
  acc: {type: "tests.toys:Accumulator"}
  h: {type: "tests.toys:Gain", gain: 1}
connections:
  - g.out -> acc.x
  - {from: acc.total, to: g.x, delay: 1, initial: {value: 7.0}}
  - acc.total -> h.x
""")
    assert sim.components["g"].started["x"].value == 7.0  # acc publishes 0.0 at t = 0
    assert sim.components["h"].started["x"].value == 0.0  # acc's initial output
    assert values(sim.components["h"])[0] == (0.0, 0.007)  # acc's total after its first step


def test_a_failure_reading_the_inputs_at_t0_is_named_with_the_component():
    """An exception in start_inputs is a SimulationError naming the component at t = 0; observers
    are told the run failed."""
    trace = Trace()
    scene = loads("""
dt: 0.001
until: 1.0
components:
  bad: {type: "tests.toys:Faulty", mode: start}
""")
    with pytest.raises(SimulationError, match=r"'bad' failed at t = 0 s: its inputs at t = 0: RuntimeError: "
                                              r"boom at the start"):
        Simulation(scene, observers=[trace]).run()
    assert trace.finished.status == "failed" and trace.finished.tick == 0


def test_multi_rate_holds_the_slow_value_and_publishes_at_the_end_of_its_step():
    """Multi-rate, every 1 and every 4:

        src (every 1) --> slow.x (every 4) --> slow.total --> g.x (every 1)

    slow steps at ticks 0 and 4 and sees src's newest output up to the end of its first tick; g sees
    slow's initial output until slow's first step ends (t = 4 ms), then the held value."""
    sim, _ = run("""
dt: 0.001
until: 0.008
components:
  src: {type: "tests.toys:Source", rate: 1000}
  slow: {type: "tests.toys:Accumulator", every: 4}
  g: {type: "tests.toys:Gain", gain: 1}
connections:
  - src.out -> slow.x
  - slow.total -> g.x
""")
    slow = sim.components["slow"]
    assert values(slow) == [(0.0, 1.0), (4.0, 5.0)]
    assert slow.calls == [0.004, 0.004]
    # slow.total: 0 at t=0 (initial output), 0.004 at 4 ms, 0.004 + 0.02 at 8 ms
    g_inputs = values(sim.components["g"])
    assert [v for _, v in g_inputs] == [0.0, 0.0, 0.0, 0.004, 0.004, 0.004, 0.004, 0.024]


def test_additive_port_receives_the_sum_of_its_sources():
    """Additive port fed twice:

        a.force --+
                  +--> sum.f
        b.force --+
    """
    sim, _ = run("""
dt: 0.001
until: 0.002
components:
  a: {type: "tests.toys:Source", start: 1, rate: 0}
  b: {type: "tests.toys:Source", start: 10, rate: 0}
  sum: {type: "tests.toys:Summer"}
connections:
  - a.force -> sum.f
  - b.force -> sum.f
""")
    assert values(sim.components["sum"], "f") == [(0.0, 11.0), (1.0, 11.0)]


def test_event_port_delivers_each_message_once():
    """An event input gets a message once; a held input keeps the last value (src every 2, sum every 1)."""
    sim, _ = run("""
dt: 0.001
until: 0.004
components:
  src: {type: "tests.toys:Source", rate: 1000, every: 2}
  sum: {type: "tests.toys:Summer"}
connections:
  - src.out -> sum.kick
  - src.force -> sum.f
""")
    assert values(sim.components["sum"], "kick") == [(0.0, None), (1.0, 2.0), (2.0, None), (3.0, 4.0)]
    assert values(sim.components["sum"], "f") == [(0.0, 2.0), (1.0, 2.0), (2.0, 2.0), (3.0, 4.0)]


KICKS = """
dt: 0.001
until: 0.012
components:
  k: {type: "tests.toys:Kicker", at: [1, 2, 3, 5, 9]}
  every_step: {type: "tests.toys:Catcher"}
  every_4: {type: "tests.toys:Catcher", every: 4}
  delayed_4: {type: "tests.toys:Catcher", every: 4}
connections:
  - k.kick -> every_step.kick
  - k.kick -> every_4.kick
  - {from: k.kick, to: delayed_4.kick, delay: 1, initial: {value: 0.5}}
"""


def test_a_receiver_stepping_less_often_than_its_source_gets_every_event_summed():
    """Kicks at the kicker's steps 1, 2, 3, 5 and 9 (stamped 1, 2, 3, 5, 9 ms). A receiver stepping every
    4 ms takes those published since its last step at once, their sum, the momentum they carry: it
    received only the newest, and the others were lost without a word (1, 5 and 9 of 20; the delayed
    one 3 and 5). Direct: 1 at 0 ms (the kick of its own tick), 2 + 3 + 5 at 4 ms, 9 at 8 ms; delayed:
    the initial 0.5, then 1 + 2 + 3 stamped by 4 ms, 5 by 8 ms (9 comes after its last step)."""
    sim, _ = run(KICKS)
    assert values(sim.components["every_step"], "kick") == [
        (0.0, 1.0), (1.0, 2.0), (2.0, 3.0), (3.0, None), (4.0, 5.0), (5.0, None), (6.0, None), (7.0, None),
        (8.0, 9.0), (9.0, None), (10.0, None), (11.0, None)]
    assert values(sim.components["every_4"], "kick") == [(0.0, 1.0), (4.0, 10.0), (8.0, 9.0)]
    assert values(sim.components["delayed_4"], "kick") == [(0.0, 0.5), (4.0, 6.0), (8.0, 5.0)]
    assert sim.components["every_4"].total == sim.components["every_step"].total == 20.0


def test_an_event_that_cannot_be_summed_is_refused_a_receiver_stepping_less_often():
    """A receiver stepping less often than its source would get several of its events in one step;
    one that cannot be summed is refused as the scene loads, naming the input, the rates and the
    remedy (it would have lost all but the last)."""
    from cosim.errors import ScenarioError

    with pytest.raises(ScenarioError) as err:
        loads("""
dt: 0.001
until: 0.004
components:
  src: {type: "tests.toys:Source"}
  sum: {type: "tests.toys:Summer", every: 3}
connections:
  - src.out -> sum.kick
""")
    assert ("components.sum: its event input 'kick' (Scalar) comes from src, which steps every 1 base steps against "
            "its 3: up to 3 messages would arrive in one of its steps, and a Scalar cannot be summed; step sum at "
            "least as often as src") in err.value.problems


def test_a_connection_given_twice_is_refused():
    """An additive input fed twice by the same connection received its value twice (a kick of 1 arrived
    as 2); the repeat is refused, naming both."""
    from cosim.errors import ScenarioError

    with pytest.raises(ScenarioError) as err:
        loads(KICKS + "  - k.kick -> every_step.kick\n")
    assert err.value.problems == ["connections.3: repeats connections.0 (k.kick -> every_step.kick): each "
                                  "connection delivers its own copy; give it once"]


def test_a_substepping_component_publishes_what_each_of_its_substeps_published():
    """A kicker substepping 3 times a step kicks at its 2nd, 4th and 9th substeps: its steps publish
    what their substeps did (2 in the first step, 4 in the second, 9 in the third); only the last
    substep's outputs were kept, and the receiver got 9 alone."""
    sim, _ = run("""
dt: 0.001
until: 0.003
on_unstable: substep
components:
  k: {type: "tests.toys:Kicker", at: [2, 4, 9], stable_step: 0.0004}
  c: {type: "tests.toys:Catcher"}
connections:
  - k.kick -> c.kick
""")
    assert values(sim.components["c"], "kick") == [(0.0, 2.0), (1.0, 4.0), (2.0, 9.0)]


def test_component_stop_request_ends_the_run():
    """A component's request_stop ends the run after the tick, with status 'stopped' and the reason."""
    _, result = run("""
dt: 0.001
until: 1.0
components:
  src: {type: "tests.toys:Source", start: 1000, rate: 0}
  acc: {type: "tests.toys:Accumulator", stop_at: 3.0}
connections:
  - src.out -> acc.x
""")
    assert result.status == "stopped"
    assert result.tick == 3
    assert "acc: total reached 3" in result.reason


def test_substep_subdivides_and_is_reported():
    """With on_unstable: substep, a step above max_stable_step is split into equal substeps, and
    observers hear about it once."""
    trace = Trace()
    scene = loads("""
dt: 0.001
until: 0.003
on_unstable: substep
components:
  acc: {type: "tests.toys:Accumulator", stable_step: 0.0003}
""")
    sim = Simulation(scene, observers=[trace])
    sim.run()
    calls = sim.components["acc"].calls
    assert len(calls) == 12 and calls[0] == pytest.approx(0.00025)
    assert [(e[1], e[2]) for e in trace.events] == [("acc", "substep")]
    assert "4 substeps" in trace.events[0][3]


def test_runtime_instability_with_error_policy_names_component_bound_and_step():
    """A component whose stable step shrinks below the step at run time fails with a clear error."""
    scene = loads("""
dt: 0.001
until: 0.003
components:
  acc: {type: "tests.toys:Accumulator"}
""")
    sim = Simulation(scene)
    sim.components["acc"].max_stable_step = lambda: 0.0005
    with pytest.raises(SimulationError,
                       match=r"'acc' failed at t = 0 s: step 0.001 s exceeds the stable step 0.0005 s"):
        sim.run()


@pytest.mark.parametrize(("dt", "bound", "said"), [
    # six digits gave "step 0.00412183 s exceeds the stable step 0.00412183 s"
    ("0.004121831", 0.0041218305, "step 0.004121831 s exceeds the stable step 0.00412183 s"),
    # six digits rounded the bound up to the step: "... giving at most 0.001 s", which still exceeds it
    ("0.001", 0.00099999995, "step 0.001 s exceeds the stable step 0.000999999 s (on_unstable: error; use a "
                             "base step or 'every' giving at most 0.000999999 s"),
    ("0.001", 0.000999477, "step 0.001 s exceeds the stable step 0.000999477 s"),
])
def test_a_step_just_over_its_bound_is_said_in_digits_that_tell_them_apart(dt, bound, said):
    """The step and the bound it exceeds in six digits, or as many as tell them apart, the bound
    rounded down, so that a step of the value advised is within it."""
    scene = loads(f"""
dt: {dt}
until: 0.01
components:
  acc: {{type: "tests.toys:Accumulator"}}
""")
    sim = Simulation(scene)
    sim.components["acc"].max_stable_step = lambda: bound
    with pytest.raises(SimulationError) as failure:
        sim.run()
    assert said in str(failure.value)


@pytest.mark.parametrize("on_unstable", ["error", "substep"])
@pytest.mark.parametrize("bound", [0.0, -1.0, math.nan])
def test_a_stable_step_no_step_can_keep_fails_the_run_saying_so(bound, on_unstable):
    """A component whose stable step is 0, negative or NaN fails the run at that step, whatever
    on_unstable: a NaN passed every check and the run went on unbounded, 0 said "(on_unstable:
    error; ... at most 0 s)" under substep."""
    scene = loads(f"""
dt: 0.001
until: 0.003
on_unstable: {on_unstable}
components:
  acc: {{type: "tests.toys:Accumulator"}}
""")
    sim = Simulation(scene)
    sim.components["acc"].max_stable_step = lambda: bound
    with pytest.raises(SimulationError, match=rf"'acc' failed at t = 0 s: its stable step is {bound!r} s: no step "
                                              "can be stable"):
        sim.run()


def test_a_stable_step_of_zero_at_load_is_refused_saying_so(monkeypatch):
    """At load, under on_unstable: substep, a stable step of 0 divided the step into substeps by it:
    an internal ZeroDivisionError."""
    from cosim.errors import ScenarioError
    from tests.toys import Accumulator

    monkeypatch.setattr(Accumulator, "max_stable_step", lambda self: 0.0)
    with pytest.raises(ScenarioError, match=r"components\.acc: its stable step from the start is 0\.0 s: no step "
                                            "can be stable"):
        loads('dt: 0.001\nuntil: 0.003\non_unstable: substep\ncomponents:\n  acc: {type: "tests.toys:Accumulator"}\n')


def test_failure_becomes_simulation_error_with_component_and_time():
    """An exception inside a component becomes a SimulationError naming it and the time; observers
    are told the run failed."""
    trace = Trace()
    scene = loads("""
dt: 0.001
until: 1.0
components:
  bad: {type: "tests.toys:Faulty", fail_at: 0.0025}
""")
    with pytest.raises(SimulationError, match=r"'bad' failed at t = 0.003 s: RuntimeError: boom"):
        Simulation(scene, observers=[trace]).run()
    assert trace.finished.status == "failed" and trace.finished.tick == 3


def test_non_finite_output_stops_the_run_naming_the_field():
    """A NaN in an output stops the run with an error naming the component, the port and the field."""
    scene = loads("""
dt: 0.001
until: 1.0
components:
  bad: {type: "tests.toys:Faulty", fail_at: 0.002, mode: nan}
""")
    with pytest.raises(SimulationError,
                       match=r"'bad' failed at t = 0.002 s: non-finite value in output 'out' field 'value'"):
        Simulation(scene).run()


def test_time_is_integer_ticks_without_drift():
    """After a million ticks of 0.1 ms the clock reads exactly 100 s (no float accumulation)."""
    scene = loads("""
dt: 0.0001
until: 100
components:
  g: {type: "tests.toys:Gain", every: 1000000}
""")
    sim = Simulation(scene)
    sim.tick = 999_999
    sim.step()
    assert sim.time_ns == 100 * 10**9
    assert math.isclose(sim.time_ns / 1e9, 100.0, rel_tol=0, abs_tol=0)


def test_checkpoint_restore_continues_bit_for_bit():
    """Restoring a mid-run checkpoint into a fresh simulation gives the same final state as the run
    that never stopped."""
    text = """
dt: 0.001
until: 0.010
components:
  g: {type: "tests.toys:Gain", gain: 1.5}
  acc: {type: "tests.toys:Accumulator"}
connections:
  - g.out -> acc.x
  - {from: acc.total, to: g.x, delay: 1, initial: {value: 1.0}}
"""
    full, resumed, _ = full_and_restarted(text, 5_000_000)
    assert resumed.components["acc"].total == full.components["acc"].total


def full_and_restarted(text: str, checkpoint_ns: int, restarted_text: str | None = None):
    """(the run of ``text`` whole, the same run checkpointed at ``checkpoint_ns`` and restarted there
    with the scene ``restarted_text`` (default: the same), the checkpoint)."""
    full = Simulation(loads(text))
    full.run()
    half = Simulation(loads(text))
    half.run(until_ns=checkpoint_ns)
    cp = half.checkpoint()
    resumed = Simulation(loads(restarted_text or text))
    resumed.restore(cp)
    resumed.run()
    return full, resumed, cp


def test_a_restart_delivers_every_event_a_slower_receiver_had_waiting():
    """A receiver stepping every 8 ms of its source's 1 has 5 kicks waiting at a checkpoint taken at
    6 ms, more than the two messages a checkpoint keeps of a port: the checkpoint keeps the edge's
    queue, and the restarted run receives the same (3 of the 5 were lost, and a restart from a
    checkpoint of a recording made before queues were kept still takes what the port holds)."""
    text = """
dt: 0.001
until: 0.016
components:
  k: {type: "tests.toys:Kicker"}
  c: {type: "tests.toys:Catcher", every: 8}
connections:
  - k.kick -> c.kick
"""
    full, resumed, cp = full_and_restarted(text, 6_000_000)
    assert [stamp for stamp, _ in cp["queues"][0]] == [2_000_000, 3_000_000, 4_000_000, 5_000_000, 6_000_000]
    assert values(resumed.components["c"], "kick") == values(full.components["c"], "kick")[1:] == [(8.0, 44.0)]
    assert resumed.components["c"].total == full.components["c"].total == 1.0 + 44.0


def test_a_restart_finds_each_connections_deliveries_by_the_connection_not_its_place():
    """A restart whose scene lists the same connections in another order is the same run: each edge's
    deliveries are found by the connection (by position, two swapped lines traded theirs, and a kick
    was lost); one reading a port no connection of the saved run read is refused, since that port's
    last messages were not kept."""
    text = """
dt: 0.001
until: 0.012
components:
  k: {type: "tests.toys:Kicker", at: [2, 3, 4, 6, 7, 9]}
  k3: {type: "tests.toys:Kicker", every: 3}
  c: {type: "tests.toys:Catcher", every: 2}
  c3: {type: "tests.toys:Catcher", every: 3}
  src: {type: "tests.toys:Source"}
connections:
  - k.kick -> c.kick
  - k3.kick -> c3.kick
"""
    swapped = text.replace("  - k.kick -> c.kick\n  - k3.kick -> c3.kick\n",
                           "  - k3.kick -> c3.kick\n  - k.kick -> c.kick\n")
    full, resumed, cp = full_and_restarted(text, 5_000_000, swapped)
    for name in ("c", "c3"):
        assert resumed.components[name].total == full.components[name].total
    rewired = Simulation(loads(text.replace("  - k3.kick -> c3.kick\n",
                                            "  - k3.kick -> c3.kick\n  - src.force -> c.kick\n")))
    with pytest.raises(ValueError, match=r"connection src.force -> c.kick reads src.force, which no connection of the "
                                         r"saved run read: its last messages were not kept"):
        rewired.restore(cp)


def test_a_run_whose_end_is_not_on_a_step_says_where_it_ended():
    """until 1.5 steps runs two whole steps: the result says t = 2 steps (it said 'reached t =
    0.0015 s' of a run that simulated 0.002 s)."""
    from pathlib import Path

    from cosim.scenario import load

    scene = load(Path(__file__).resolve().parents[1] / "scenarios" / "ping_pong.yaml", ["until=0.0015"])
    result = Simulation(scene).run()
    assert result.steps == 2 and result.reason == "reached t = 0.002 s"


_NOTES = """
name: notes
dt: 0.001
until: 0.004
components:
  a: {{type: "tests.toys:Announcer", at_start: {at_start}, every: {every}}}
  s: {{type: "tests.toys:Summer"}}
connections:
  - {edge}
"""


def test_an_event_at_t0_that_cannot_be_summed_with_the_first_steps_is_refused_not_dropped():
    """On a direct event edge the source's t = 0 message and its first step's reach the receiver's
    first step together; a type that cannot be summed delivered the later alone (five published,
    four delivered). The run now fails at t = 0 naming both ends; without a t = 0 message, over a
    delayed edge (its initial stands for t = 0) or from a source stepping less often than the
    receiver (its first step's comes later), every message is delivered once."""
    trace = Trace()
    with pytest.raises(SimulationError, match=r"Scalar at t = 0 on 'note'.*s\.kick.*cannot be summed"):
        run(_NOTES.format(at_start="true", every=1, edge="a.note -> s.kick"), observers=[trace])
    assert trace.finished.status == "failed"
    sim, result = run(_NOTES.format(at_start="false", every=1, edge="a.note -> s.kick"))
    assert result.status == "ok"
    assert values(sim.components["s"], "kick") == [(0.0, 0.001), (1.0, 0.002), (2.0, 0.003), (3.0, 0.004)]
    sim, result = run(_NOTES.format(at_start="true", every=1,
                                     edge="{from: a.note, to: s.kick, delay: 1, initial: {value: -1}}"))
    assert result.status == "ok"
    assert values(sim.components["s"], "kick") == [(0.0, -1.0), (1.0, 0.001), (2.0, 0.002), (3.0, 0.003)]
    sim, result = run(_NOTES.format(at_start="true", every=2, edge="a.note -> s.kick"))
    assert result.status == "ok"
    assert values(sim.components["s"], "kick") == [(0.0, 0.0), (1.0, 0.002), (2.0, None), (3.0, 0.004)]


def test_the_end_is_said_to_every_digit_of_the_time():
    """A run ending at 1000.125 s said "reached t = 1000.12 s" (six figures), beside a recording and
    a status stamped 1000.125."""
    _, result = run("""
name: long
dt: 0.125
until: 1000.125
components:
  s: {type: "tests.toys:Source", rate: 1}
""")
    assert result.status == "ok" and result.reason == "reached t = 1000.125 s"
    assert result.time_ns == 1_000_125_000_000
