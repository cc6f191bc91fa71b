"""The stage monitor, driven by hand-made body and contact messages (no scheduler)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from components.messages import BodyState, GroundContact, Shape, StageId, WaterContact
from components.stages import REST_HOLD, StageMonitor

MS = 1_000_000


def body(x: float, z: float, vx: float, vz: float, mass: float = 0.12) -> BodyState:
    """A disk of R = 5 cm, e = 6 mm (0.12 kg: 2.5 times the water it would displace)."""
    v = np.array([vx, 0.0, vz])
    return BodyState(np.array([x, 0.0, z]), np.array([1.0, 0, 0, 0]), v, np.zeros(3), Shape.DISK, 0.05, 0.006,
                     mass, np.ones(3), 20.0, float(np.linalg.norm(v)), 0.0, 0.0)


DISK_WATER = 1000.0 * math.pi * 0.05**2 * 0.006  # [kg] the water the test disk displaces wholly under


def water(wetted: bool, fraction: float = 0.1, depth: float | None = None) -> WaterContact:
    z = np.zeros(3)
    if depth is None:
        depth = 0.001 if wetted else -0.05
    return WaterContact(wetted, fraction, 0.001 if wetted else 0.0, z, z, z, z, depth, 0.0)


def drive(monitor, script):
    """Step the monitor through (body, water, ground) triples at 1 ms; return what it published."""
    published = []
    for k, (b, w, g) in enumerate(script):
        out = monitor.step(k * MS, MS, {"body": b, "water": w, "ground": g})
        published.append(out)
    return published


def test_the_summary_dates_stages_to_the_digit_of_the_monitors_step():
    """Stepped every 0.5 ms, the summary gives each stage and touchdown to that step's digit, as the
    stop line does: a touchdown at 0.0015 s (it said 0.002 s, and "sink since t = 0.0525 s" beside a
    timeline saying 0.052 s); whole milliseconds keep three digits; the first stage is the run's from
    its start, at 0 s (it was dated a step late)."""
    half = MS // 2
    m = StageMonitor("stages")
    script = [(body(0.0, 0.05, 5.0, -1.0), water(False)), (body(0.005, 0.04, 5.0, -1.0), water(False)),
              (body(0.01, 0.0, 5.0, -1.0), water(True)), (body(0.015, 0.0, 5.0, -1.0), water(True))]
    for k, (b, w) in enumerate(script):
        m.step(k * half, half, {"body": b, "water": w, "ground": None})
    assert m.summary()[0] == "stages: approach (0 s) -> hit (0.0015 s)"
    whole = StageMonitor("stages")
    for k, (b, w) in enumerate(script):
        whole.step(k * MS, MS, {"body": b, "water": w, "ground": None})
    assert whole.summary()[0] == "stages: approach (0 s) -> hit (0.003 s)"
    # a step that is no power of ten keeps all its digits (0.25 ms: "0.0008 s" rounded the touchdown)
    quarter = StageMonitor("stages")
    for k, (b, w) in enumerate(script):
        quarter.step(k * MS // 4, MS // 4, {"body": b, "water": w, "ground": None})
    assert quarter.summary()[0] == "stages: approach (0 s) -> hit (0.00075 s)"


def test_skip_sequence_and_figures():
    """approach -> hit -> slide -> fly-away -> approach -> hit -> sink, one skip with its figures."""
    m = StageMonitor("stages", StageMonitor.Params(stop_after=0.002))
    script = [
        (body(0.0, 0.10, 5.0, -1.0), water(False), None),   # approach
        (body(0.5, 0.00, 5.0, -1.0), water(True), None),    # hit (touchdown at x = 0.5, t = 2 ms)
        (body(0.6, -0.001, 4.8, 0.2), water(True), None),   # slide
        (body(0.7, 0.01, 4.6, 0.8), water(False), None),    # fly-away at t = 4 ms
        (body(0.9, 0.02, 4.6, -0.1), water(False), None),   # approach again
        (body(1.5, 0.0, 4.0, -0.5), water(True), None),     # hit
        (body(1.6, -0.01, 0.3, -0.5), water(True), None),   # too slow: sink
        (body(1.6, -0.02, 0.3, -0.5), water(True, 1.0), None),
        (body(1.6, -0.03, 0.3, -0.5), water(True, 1.0), None),
    ]
    out = drive(m, script)
    labels = [o["stage"].label for o in out if "stage" in o]
    assert labels == ["approach", "hit", "slide", "fly-away", "approach", "hit", "sink"]
    skips = [o["skip"] for o in out if "skip" in o]
    assert len(skips) == 1
    s = skips[0]
    assert s.index == 1 and s.touchdown_x == 0.5 and s.distance == 0.5
    assert s.contact_time == pytest.approx(0.002)
    assert s.takeoff_angle_deg == pytest.approx(math.degrees(math.atan2(0.8, 4.6)))
    assert m.stop_reason is not None and "sink" in m.stop_reason
    assert "skips: 1" in "\n".join(m.summary())


HOLD = round(REST_HOLD / 0.001) + 1  # the 1 ms steps of drive() a body must stay slow to be at rest


def test_rest_on_ground():
    """A still stone on the ground is at rest once it has stayed so for REST_HOLD, dated from the
    start of that spell."""
    m = StageMonitor("stages")
    ground = GroundContact(True, 1.0, 0.0, False, 0.0)
    out = drive(m, [(body(0, 0.003, 0.0, 0.0), None, ground)] * HOLD)
    assert [o["stage"].stage for o in out if "stage" in o] == [StageId.GROUND, StageId.REST]
    assert "stage" in out[-1] and m.timeline[-1] == (pytest.approx(0.001), "rest")


def test_a_ball_starting_to_roll_down_a_slope_is_not_at_rest():
    """Let go on a slope, a ball rolls on its static friction: slow for its first steps, it was at
    rest (final) at the first, and the run ended with it rolling at 0.73 m/s."""
    m = StageMonitor("stages", StageMonitor.Params(stop_after=0.0))
    holding = GroundContact(True, 1.0, 0.0, False, 0.0)
    out = drive(m, [(body(0.0, 0.003, 0.0024 * k, -0.0009 * k), None, holding) for k in range(1, 40)])
    assert not [o for o in out if "stage" in o and o["stage"].stage is StageId.REST]


def test_a_stone_sliding_on_the_ground_is_not_at_rest():
    """Rest is final and ends the run: a disk slow for one step at the start of its slide down a
    35 deg ramp (the ground's friction kinetic) was taken for at rest; it is at rest once the ground
    holds it by static friction."""
    sliding = GroundContact(True, 1.0, 0.5, True, 0.0)
    holding = GroundContact(True, 1.0, 0.0, False, 0.0)
    out = drive(StageMonitor("stages"), [(body(0, 0.003, 0.001, 0.0), None, sliding)] * HOLD)
    assert not [o for o in out if "stage" in o and o["stage"].stage is StageId.REST]
    out = drive(StageMonitor("stages"), [(body(0, 0.003, 0.001, 0.0), None, holding)] * HOLD)
    assert out[-1]["stage"].stage is StageId.REST


def leaving_the_pond() -> list:
    """A skip, then 6 ms dry with the lowest point below the water level: off the water's grid."""
    return [
        (body(0.0, 0.10, 5.0, -1.0), water(False), None),
        (body(0.5, 0.0, 5.0, -0.5), water(True), None),
        (body(0.6, 0.01, 5.0, 0.5), water(False, depth=-0.01), None),
        *[(body(0.8 + 0.1 * k, -0.01 * (k + 1), 5.0, -0.5), water(False, depth=0.004 + 0.01 * k), None)
          for k in range(6)],
    ]


def test_a_stone_that_left_the_pond_stays_left_whatever_it_does_beside_it():
    """Left-pond is final: a monitor that ends no run (stop_after 0) saw its stone, which had left
    the pond, come to rest on the ground beside it, and its stage channel ended on rest while its
    outcome said left-pond."""
    m = StageMonitor("stages", StageMonitor.Params(outside_after=0.003, stop_after=0.0))
    still = GroundContact(True, 1.0, 0.0, False, 0.0)
    drive(m, [*leaving_the_pond(), *[(body(1.5, -0.1, 0.0, 0.0), water(False, depth=0.1), still) for _ in range(3)]])
    assert m.timeline[-1][1] == "left-pond" and m.metrics()["outcome"] == "left-pond"


def test_a_stone_clear_of_the_water_but_not_rising_has_not_flown_away():
    """A contact ends in a fly-away, a skip, once the stone rises clear of the water: clear but level
    (vz = 0) it made a skip with a take-off angle of 0."""
    m = StageMonitor("stages")
    out = drive(m, [(body(0.0, 0.10, 5.0, -1.0), water(False), None),
                    (body(0.5, 0.0, 5.0, -0.5), water(True), None),
                    (body(0.6, 0.01, 5.0, 0.0), water(False, depth=-0.01), None)])
    assert not [o for o in out if "skip" in o]
    out = drive(m, [(body(0.7, 0.012, 5.0, 0.3), water(False, depth=-0.012), None)])
    rising = math.degrees(math.atan2(0.3, 5.0))
    assert [o["skip"].takeoff_angle_deg for o in out if "skip" in o] == [pytest.approx(rising)]


@pytest.mark.parametrize("start_step", [67, 68])
def test_stop_after_ends_the_run_after_the_same_number_of_steps_wherever_the_stage_began(start_step):
    """Sinking from step 67 or 68 of 0.1 ms, a monitor with stop_after 0.3 s stops 3000 steps later in
    both: the time since, a difference of step times in floating point, came out a hair under 0.3 s
    from step 67, and the run went on a step more."""
    m = StageMonitor("stages", StageMonitor.Params(stop_after=0.3))
    step_ns = 100_000
    approach = body(0.0, 0.10, 5.0, -1.0)
    sinking = body(0.5, -0.01, 0.1, -0.5)
    stopped_at = None
    for k in range(start_step + 3100):
        b, w = (approach, water(False)) if k < start_step else (sinking, water(True, 1.0))
        m.step(k * step_ns, step_ns, {"body": b, "water": w, "ground": None})
        if m.stop_reason is not None:
            stopped_at = k
            break
    assert m.stop_reason is not None and "sink" in m.stop_reason
    assert stopped_at - start_step == 3000


def test_state_round_trip_continues_identically():
    """get_state/set_state reproduces the monitor's behaviour."""
    script = [(body(0.0, 0.1, 5.0, -1.0), water(False), None), (body(0.5, 0.0, 5.0, -1.0), water(True), None),
              (body(0.7, 0.01, 4.6, 0.8), water(False), None)]
    a = StageMonitor("s")
    drive(a, script[:2])
    b = StageMonitor("s")
    b.set_state(a.get_state())
    out_a = a.step(2 * MS, MS, dict(zip(("body", "water", "ground"), script[2], strict=True)))
    out_b = b.step(2 * MS, MS, dict(zip(("body", "water", "ground"), script[2], strict=True)))
    assert out_a["skip"].contact_time == out_b["skip"].contact_time
    assert a.summary() == b.summary()


def test_a_state_saved_before_distances_ran_along_the_throw_continues_with_finite_distances():
    """A checkpoint of an earlier version (no last touchdown y, no final y) restores, and the next
    skip's distance and the distance travelled are those of a monitor never interrupted (the missing
    y made them NaN and the run failed at the next skip)."""
    script = [(body(0.0, 0.1, 5.0, -1.0), water(False), None), (body(0.5, 0.0, 5.0, -1.0), water(True), None),
              (body(0.7, 0.01, 4.6, 0.8), water(False), None), (body(1.2, 0.02, 4.6, -0.8), water(False), None),
              (body(1.9, 0.0, 4.5, -0.9), water(True), None), (body(2.0, 0.01, 4.4, 0.6), water(False), None)]
    whole = StageMonitor("s")
    drive(whole, script)
    a = StageMonitor("s")
    drive(a, script[:4])
    old = a.get_state()
    del old["track"]["last_touchdown_y"], old["final_y"]
    b = StageMonitor("s")
    b.set_state(old)
    out = [b.step(k * MS, MS, dict(zip(("body", "water", "ground"), step, strict=True)))
           for k, step in enumerate(script[4:], start=4)]
    (second,) = [o["skip"] for o in out if "skip" in o]
    assert second.distance == whole.records[1].distance == 1.4
    assert b.summary() == whole.summary() and b.metrics()["distance"] == 2.0


def test_grazing_flicker_is_one_contact():
    """Losing contact for a step while the stone still skims within the clearance is not a skip."""
    m = StageMonitor("stages", StageMonitor.Params(takeoff_clearance=0.002))
    script = [
        (body(0.0, 0.10, 5.0, -1.0), water(False), None),
        (body(0.5, 0.0, 5.0, -0.5), water(True), None),
        (body(0.6, 0.0, 5.0, 0.1), water(False, depth=-0.001), None),   # dry but within 2 mm
        (body(0.7, 0.0, 5.0, 0.2), water(True), None),
        (body(0.8, 0.01, 5.0, 0.5), water(False, depth=-0.003), None),  # clear: fly-away
    ]
    out = drive(m, script)
    labels = [o["stage"].label for o in out if "stage" in o]
    assert labels == ["approach", "hit", "slide", "fly-away"]
    skips = [o["skip"] for o in out if "skip" in o]
    assert len(skips) == 1 and skips[0].contact_time == pytest.approx(0.003)


def test_dry_below_the_water_level_for_long_is_leaving_the_pond():
    """Dry while the lowest point is below the water level for outside_after: the stone left the pond,
    the run stops and the outcome says so (the skips so far are kept), naming where it came down
    beside the water, where that spell began (x = 0.8 m), not where it had fallen to by the time the
    spell was long enough (x = 1.1 m)."""
    m = StageMonitor("stages", StageMonitor.Params(outside_after=0.003))
    script = [
        (body(0.0, 0.10, 5.0, -1.0), water(False), None),
        (body(0.5, 0.0, 5.0, -0.5), water(True), None),
        (body(0.6, 0.01, 5.0, 0.5), water(False, depth=-0.01), None),  # fly-away: one skip
        (body(0.8, -0.01, 5.0, -0.5), water(False, depth=0.004), None),  # off the grid, below the level
        (body(0.9, -0.02, 5.0, -0.6), water(False, depth=0.014), None),
        (body(1.0, -0.03, 5.0, -0.7), water(False, depth=0.024), None),
        (body(1.1, -0.04, 5.0, -0.8), water(False, depth=0.034), None),
    ]
    drive(m, script)
    assert m.stop_reason is not None
    assert "stone left the pond: it came down beside the water at x = 0.8 m" in m.stop_reason
    metrics = m.metrics()
    assert metrics["outcome"] == "left-pond" and metrics["skips"] == 1 and metrics["reached_edge"] == 1
    assert m.timeline[-1] == (pytest.approx(0.007), "left-pond")


def test_the_left_pond_line_gives_where_and_when_to_the_millimetre_and_the_step():
    """The stop line gave x to three figures and the time to four: "x = 10.5 m ... since t = 1.188 s"
    for a stone that came down at 10.544 m at 1.1875 s, beside a timeline saying 1.1875 s and a
    distance of 10.24 m from x = 0.3. Now both to the digit the summary gives them."""
    half = MS // 2
    m = StageMonitor("stages", StageMonitor.Params(outside_after=0.002))
    script = [(body(10.5, 0.10, 5.0, -1.0), water(False)), (body(10.52, 0.0, 5.0, -0.5), water(True)),
              (body(10.53, 0.01, 5.0, 0.5), water(False, depth=-0.01))]
    script += [(body(10.5444 + 0.01 * k, -0.01 * (k + 1), 5.0, -0.5), water(False, depth=0.004 + 0.01 * k))
               for k in range(8)]
    for k, (b, w) in enumerate(script, start=2371):
        m.step(k * half, half, {"body": b, "water": w, "ground": None})
    assert m.stop_reason is not None
    assert "came down beside the water at x = 10.544 m, y = 0 m" in m.stop_reason
    assert "since t = 1.1875 s)" in m.stop_reason and m.outside_since == pytest.approx(1.1875)


def test_a_monitor_slower_than_its_body_dates_what_it_read_at_the_states_time():
    """Stepping every 4 base steps of 0.5 ms over a body stepping every one, the monitor reads, as
    its step begins, the body's state at the end of the body's step (the body comes first in the
    tick), not at the end of its own: it dated that state 1.5 ms late (the reference skip's touchdown
    at 0.062 s, with the x of the state of 0.0605 s). Now each stage and touchdown is dated with the
    state it was read from, to the body's digit."""
    two = 2 * MS
    m = StageMonitor("stages")
    m.source_steps["body"] = 0.0005  # [s] as the scene tells it
    script = [(body(0.0, 0.05, 5.0, -1.0), water(False)), (body(0.0125, 0.0, 5.0, -1.0), water(True)),
              (body(0.0225, 0.0, 5.0, -1.0), water(True))]
    for k, (b, w) in enumerate(script, start=30):
        m.step(k * two, two, {"body": b, "water": w, "ground": None})
    assert m.track.touchdown_time == pytest.approx(31 * 0.002 + 0.0005)  # the state read at 0.0625 s
    assert "-> hit (0.0625 s)" in m.summary()[0]


def test_a_monitor_that_ends_no_run_lets_the_others_go_on_when_its_stone_leaves():
    """stop_after 0 (each monitor of several bodies in one pond): its stone leaving the pond is its
    outcome, but it ends no run, so the other stones' contacts are not cut short (one stone off the
    edge stopped a two-stone run with the other mid-contact)."""
    m = StageMonitor("stages", StageMonitor.Params(outside_after=0.003, stop_after=0.0))
    drive(m, leaving_the_pond())
    assert m.stop_reason is None
    assert m.metrics()["outcome"] == "left-pond" and m.timeline[-1][1] == "left-pond"


def test_a_stone_that_never_touched_the_water_missed_it_rather_than_left_it():
    """Thrown beside the pond (or with the pond elsewhere), the stone is dry below the water level
    without ever having touched water: the stop reason says it missed the water, not that it left."""
    m = StageMonitor("stages", StageMonitor.Params(outside_after=0.002))
    drive(m, [(body(0.1 * k, 0.05 - 0.02 * k, 5.0, -1.0), water(False, depth=0.02 * k - 0.05), None)
              for k in range(8)])
    assert m.stop_reason is not None
    assert "stone missed the water: it came down beside the water at x = 0.3 m" in m.stop_reason  # (below at k = 3)
    assert m.metrics()["outcome"] == "left-pond"


def test_a_short_dry_spell_below_the_level_is_not_leaving():
    """A body that starts under water is dry until the water's first patch arrives: shorter than
    outside_after, so nothing is decided."""
    m = StageMonitor("stages", StageMonitor.Params(outside_after=0.003))
    script = [(body(0.0, -0.2, 0.0, 0.0), water(False, depth=0.2), None)] * 2
    script += [(body(0.0, -0.2, 0.0, -0.1), water(True, 1.0, depth=0.2), None)] * 4
    drive(m, script)
    assert m.stop_reason is None or "left" not in m.stop_reason
    assert m.metrics()["outcome"] == "sink" and m.metrics()["reached_edge"] == 0


def test_a_sunk_stone_comes_to_rest_on_the_bottom():
    """sink -> rest once the stone is still on the ground; a settling wobble under water stays at rest."""
    m = StageMonitor("stages", StageMonitor.Params(stop_after=0.0))
    touching = GroundContact(True, 1.0, 0.0, False, 0.0)
    script = [
        (body(0.0, 0.01, 0.0, -0.5), water(True, 0.5), None),
        (body(0.0, -0.2, 0.0, -0.4), water(True, 1.0), None),
        *[(body(0.0, -0.497, 0.0, -0.001), water(True, 1.0), touching)] * HOLD,
        (body(0.0, -0.497, 0.0, -0.02), water(True, 1.0), touching),  # a wobble while settling
        (body(0.0, -0.497, 0.0, -0.001), water(True, 1.0), touching),
    ]
    out = drive(m, script)
    labels = [o["stage"].label for o in out if "stage" in o]
    assert labels == ["sink", "rest"]
    assert m.metrics()["outcome"] == "rest"


def test_a_stone_under_water_sinks_only_when_the_water_no_longer_pushes_it_out():
    """Wholly under the surface, a stone the water pushes up harder than its weight (a thin stone
    dipping under while the pressure throws it back) or one still rising has not sunk; one moving
    down with less push has."""
    z = np.zeros(3)
    weight = 0.12 * 9.81

    def under(push: float) -> WaterContact:
        return WaterContact(True, 1.0, 0.01, np.array([0.0, 0.0, 0.4 * weight]),
                            np.array([0.0, 0.0, push - 0.4 * weight]), z, z, 0.01, 0.0)

    m = StageMonitor("stages")
    script = [
        (body(0.0, 0.10, 5.0, -1.0), water(False), None),
        (body(0.5, -0.01, 5.0, -1.0), under(30 * weight), None),  # thrown back out: still a hit
        (body(0.6, -0.01, 4.0, 0.3), under(0.9 * weight), None),  # still rising: a slide
        (body(0.7, -0.01, 4.0, -0.5), under(0.9 * weight), None),  # nothing holds it up: sinks
    ]
    labels = [o["stage"].label for o in drive(m, script) if "stage" in o]
    assert labels == ["approach", "hit", "slide", "sink"]


def test_a_brush_while_still_rising_is_no_touchdown_of_the_next_skip():
    """A crest brushed near the apex of a hop, the stone still rising, is part of the flight: the
    next skip's touchdown, contact time, distance and speed in are those of the real touchdown, not
    of the brush (begun as a contact, the dry descent after it went on as one, and the next skip took
    the brush's touchdown at x = 1.0, 6 ms of contact)."""
    m = StageMonitor("stages", StageMonitor.Params(takeoff_clearance=0.002))
    script = [
        (body(0.0, 0.10, 5.0, -1.0), water(False), None),                 # approach
        (body(0.5, 0.00, 5.0, -1.0), water(True), None),                  # hit: touchdown at x = 0.5
        (body(0.6, -0.001, 4.8, 0.2), water(True), None),                 # slide
        (body(0.7, 0.01, 4.6, 0.8), water(False, depth=-0.01), None),     # fly-away: skip 1
        (body(1.0, 0.02, 4.6, 0.05), water(True), None),                  # brushes a crest, still rising
        (body(1.1, 0.02, 4.6, -0.05), water(False, depth=-0.001), None),  # past the apex, 1 mm clear
        (body(1.5, 0.01, 4.6, -0.4), water(False, depth=-0.03), None),    # coming down
        (body(2.0, 0.005, 4.6, -0.8), water(False, depth=-0.02), None),
        (body(3.0, 0.00, 4.5, -0.9), water(True), None),                  # touchdown at x = 3.0, t = 9 ms
        (body(3.1, -0.001, 4.4, 0.3), water(True), None),                 # slide
        (body(3.2, 0.01, 4.3, 0.6), water(False, depth=-0.01), None),     # fly-away: skip 2
    ]
    out = drive(m, script)
    labels = [o["stage"].label for o in out if "stage" in o]
    assert labels == ["approach", "hit", "slide", "fly-away", "approach", "hit", "slide", "fly-away"]
    second = [o["skip"] for o in out if "skip" in o][1]
    assert (second.touchdown_x, second.distance) == (3.0, 2.5)
    assert second.touchdown_time == pytest.approx(0.009) and second.contact_time == pytest.approx(0.002)
    assert second.speed_in == pytest.approx(math.hypot(4.5, 0.9))


def test_a_slow_stone_climbing_out_through_a_crest_has_not_sunk():
    """After a fly-away, a stone still rising at 0.5 m/s and moving on at 0.4 m/s (under sink_speed)
    brushes a crest, 5% of it in the water: part of its flight, not a sinking, which is final (it
    was said to have sunk as it climbed out)."""
    m = StageMonitor("stages")
    out = drive(m, [(body(0.0, 0.10, 2.0, -1.0), water(False), None),
                    (body(0.2, 0.00, 2.0, -1.0), water(True), None),
                    (body(0.3, 0.01, 0.4, 0.5), water(False, depth=-0.01), None),
                    (body(0.31, 0.012, 0.4, 0.5), water(True, fraction=0.05), None)])
    assert [o["stage"].label for o in out if "stage" in o] == ["approach", "hit", "fly-away"]


def test_a_dry_spell_while_still_coming_down_is_the_same_contact():
    """The surface can drop away under a stone faster than it falls (behind a crest): dry and clear
    of the water but still moving down, the stone has not bounced. Only rising clear is a skip."""
    m = StageMonitor("stages", StageMonitor.Params(takeoff_clearance=0.002))
    script = [
        (body(0.0, 0.10, 5.0, -1.0), water(False), None),
        (body(0.5, 0.0, 5.0, -0.5), water(True), None),                   # touchdown at t = 2 ms
        (body(0.6, -0.001, 5.0, -0.3), water(False, depth=-0.004), None),  # clear, but coming down
        (body(0.7, -0.002, 5.0, -0.1), water(True), None),                # wetted again: same contact
        (body(0.8, 0.0, 5.0, 0.3), water(True), None),
        (body(0.9, 0.01, 5.0, 0.5), water(False, depth=-0.003), None),    # rising clear: the skip
    ]
    out = drive(m, script)
    labels = [o["stage"].label for o in out if "stage" in o]
    assert labels == ["approach", "hit", "slide", "fly-away"]
    skips = [o["skip"] for o in out if "skip" in o]
    assert len(skips) == 1 and skips[0].contact_time == pytest.approx(0.004)
    assert skips[0].takeoff_angle_deg > 0


def moving(x: float, y: float, z: float, v: tuple[float, float, float]) -> BodyState:
    b = body(x, z, v[0], v[2])
    return BodyState(np.array([x, y, z]), b.orientation, np.array(v), b.angular_velocity, b.shape, b.radius,
                     b.thickness, b.mass, b.inertia, b.attack_angle_deg, float(np.linalg.norm(v)), 0.0, 0.0)


def test_a_curving_throw_reports_its_drift_and_heading_per_skip():
    """Thrown along a diagonal (x = y), the stone touches down 0.1 m to the left of that line and
    flies away turned 10 deg further left: the skip's drift is +0.1 m and its heading +10 deg, and the
    summary prints both (a straight throw prints neither); its distances run along the diagonal."""
    m = StageMonitor("stages")
    c45, s45 = math.cos(math.pi / 4), math.sin(math.pi / 4)
    turned = math.radians(55.0)
    left = (-0.1 * s45, 0.1 * c45)  # 0.1 m to the left of the diagonal
    out = drive(m, [
        (moving(0.0, 0.0, 0.10, (4 * c45, 4 * s45, -1.0)), water(False), None),
        (moving(1.0 + left[0], 1.0 + left[1], 0.0, (4 * c45, 4 * s45, -1.0)), water(True), None),
        (moving(1.1, 1.2, 0.01, (4 * math.cos(turned), 4 * math.sin(turned), 0.8)), water(False), None),
    ])
    (skip,) = [o["skip"] for o in out if "skip" in o]
    assert skip.drift == pytest.approx(0.1)
    assert skip.heading_deg == pytest.approx(10.0)
    assert "drift +0.10 m, heading +10.0 deg" in "\n".join(m.summary())
    # distances run along the throw's line, not along x (along x they were 0.93 and 1.10 m)
    assert skip.distance == pytest.approx(math.sqrt(2.0))
    assert "distance travelled: 1.63 m" in "\n".join(m.summary())  # (1.1 + 1.2) cos 45 deg

    straight = StageMonitor("stages")
    drive(straight, [(body(0.0, 0.10, 5.0, -1.0), water(False), None), (body(0.5, 0.0, 5.0, -1.0), water(True), None),
                     (body(0.7, 0.01, 4.6, 0.8), water(False), None)])
    assert "skip 1:" in "\n".join(straight.summary()) and "drift" not in "\n".join(straight.summary())


def buoyant_water(fraction: float, lift: float) -> WaterContact:
    """Wetted, ``fraction`` of the stone under water, buoyancy ``lift`` [N] up."""
    z = np.zeros(3)
    return WaterContact(True, fraction, 0.001, np.array([0.0, 0.0, lift]), z, z, z, 0.001, 0.0)


WEIGHT = 0.12 * 9.81  # [N] of the test body


@pytest.mark.parametrize("density_ratio, stage", [(0.5, "float"), (2.65, "sink")])
def test_a_slow_stone_floats_if_lighter_than_water_else_sinks(density_ratio, stage):
    """Too slow to skip: a stone the water could carry wholly under (lighter than the water it would
    displace) floats; a denser one sinks. Both are final and end the run: a sunk one stop_after later,
    a floating one once it has settled (slower than 1 cm/s) that long, not while it still bobs."""
    m = StageMonitor("stages", StageMonitor.Params(stop_after=0.002))
    fraction, mass = 0.3, density_ratio * DISK_WATER
    lift = DISK_WATER * 9.81 * fraction  # buoyancy of the submerged 30%
    # bobbing changes nothing: a floating stone bobbing clear of the water, a sunk one rising within
    # it (one thrown clear out of it has not sunk: the test below)
    bob = water(False) if stage == "float" else water(True, depth=-0.001)
    script = [(body(0.0, 0.01, 5.0, -1.0, mass), water(False), None),
              (body(0.5, 0.0, 0.3, -0.1, mass), buoyant_water(fraction, lift), None),
              (body(0.5, 0.0, 0.3, 0.1, mass), bob, None),
              (body(0.5, 0.0, 0.3, 0.1, mass), bob, None),
              (body(0.5, 0.0, 0.3, 0.1, mass), bob, None),
              (body(0.5, 0.0, 0.0, 0.005, mass), buoyant_water(fraction, lift), None),  # settled from t = 6 ms
              (body(0.5, 0.0, 0.0, 0.0, mass), buoyant_water(fraction, lift), None),
              (body(0.5, 0.0, 0.0, 0.0, mass), buoyant_water(fraction, lift), None)]
    out, asked = [], None
    for k, (b, w, g) in enumerate(script):
        out.append(m.step(k * MS, MS, {"body": b, "water": w, "ground": g}))
        asked = k if asked is None and m.stop_reason else asked
    labels = [o["stage"].label for o in out if "stage" in o]
    assert labels == ["approach", stage]
    assert m.stop_reason == f"stone {stage} since t = 0.002 s"
    assert asked == (3 if stage == "sink" else 7)  # 2 ms after sinking; 2 ms after settling (at 6 ms)
    assert m.metrics()["outcome"] == stage


def test_a_sunk_stone_thrown_clear_out_of_the_water_has_not_sunk():
    """A slow stone landing in a shallow pond is said to sink as it comes in; its bed can throw it
    back up and out (a slate at 1 m/s onto 3 cm of water over a bed of restitution 0.7 flew 4 cm
    over the water while the run, said to have sunk, ended): rising clear of the water (its lowest
    point more than the take-off clearance above it), it is in a fly-away, a bounce off the ground,
    not a skip. Within the clearance, or coming down, it stays sunk."""
    heavy = 2.65 * DISK_WATER
    m = StageMonitor("stages", StageMonitor.Params(stop_after=0))
    bed = GroundContact(True, 20.0, 0.0, False, 0.0)
    out = drive(m, [(body(0.0, 0.01, 0.3, -1.0, heavy), water(False), None),
                    (body(0.01, 0.0, 0.3, -1.0, heavy), water(True, 0.3), None),  # in slowly: sunk
                    (body(0.02, -0.01, 0.3, -1.0, heavy), water(True, 1.0), bed),  # on the bed
                    (body(0.03, 0.0, 0.3, 0.5, heavy), water(False, depth=-0.001), None),  # within the clearance
                    (body(0.04, 0.01, 0.3, 0.5, heavy), water(False, depth=-0.003), None),  # clear, rising
                    (body(0.05, 0.02, 0.3, -0.5, heavy), water(False, depth=-0.01), None)])
    assert [o["stage"].label for o in out if "stage" in o] == ["approach", "sink", "fly-away", "approach"]
    assert m.track.skips == 0 and m.track.ground_bounces == 1
    m = StageMonitor("stages", StageMonitor.Params(stop_after=0))
    out = drive(m, [(body(0.0, 0.01, 0.3, -1.0, heavy), water(False), None),
                    (body(0.01, 0.0, 0.3, -1.0, heavy), water(True, 0.3), None),
                    (body(0.02, 0.01, 0.3, -0.1, heavy), water(False, depth=-0.003), None)])  # clear, falling
    assert [o["stage"].label for o in out if "stage" in o] == ["approach", "sink"]
    m = StageMonitor("stages", StageMonitor.Params(stop_after=0, outside_after=0))
    out = drive(m, [(body(0.0, 0.01, 0.3, -1.0, heavy), water(False), None),
                    (body(0.01, 0.0, 0.3, -1.0, heavy), water(True, 0.3), None),
                    # dry, rising, its lowest point below the level: off the grid's edge under water
                    (body(0.02, -0.1, 0.3, 0.005, heavy), water(False, depth=0.15), None)])
    assert [o["stage"].label for o in out if "stage" in o] == ["approach", "sink"]


def test_a_stone_driven_into_a_shallow_bed_has_not_sunk_while_the_bed_pushes():
    """Wholly under a shallow pond's water and still moving down as it meets the bed, the water's push
    below its weight: the bed, whose answer reaches it a step later, throws it back (it was said to
    have sunk, final, and flew 10 cm out of the water)."""
    m = StageMonitor("stages", StageMonitor.Params(stop_after=0))
    bed = GroundContact(True, 800.0, 0.0, False, 0.0)
    out = drive(m, [(body(0.0, 0.01, 1.0, -5.0), water(False), None),
                    (body(0.01, -0.01, 1.0, -5.0), water(True, 1.0), None),
                    (body(0.02, -0.02, 1.0, -4.0), water(True, 1.0), bed)])
    assert [o["stage"].label for o in out if "stage" in o] == ["approach", "sink"]  # before the bed: sunk
    m = StageMonitor("stages", StageMonitor.Params(stop_after=0))
    out = drive(m, [(body(0.0, 0.01, 1.0, -5.0), water(False), None),
                    (body(0.01, -0.01, 1.0, -5.0), water(True, 0.5), None),
                    (body(0.02, -0.02, 1.0, -4.0), water(True, 1.0), bed),
                    (body(0.02, -0.02, 1.0, 1.5), water(True, 1.0), None)])
    assert [o["stage"].label for o in out if "stage" in o] == ["approach", "hit", "slide"]


def test_a_slow_stone_barely_touching_waits_for_the_buoyancy_to_tell():
    """Under 1% of the stone in the water its buoyancy says too little: the contact goes on (hit,
    then slide) until it does; with no buoyancy at all in the scene's water the stone sinks at once."""
    m = StageMonitor("stages", StageMonitor.Params(stop_after=0))
    light = 0.5 * DISK_WATER
    out = drive(m, [(body(0.0, 0.01, 5.0, -1.0, light), water(False), None),
                    (body(0.5, 0.0, 0.3, -0.1, light), buoyant_water(0.001, 1e-4), None),
                    (body(0.5, 0.0, 0.3, 0.05, light), buoyant_water(0.002, 2e-4), None),
                    (body(0.5, 0.0, 0.3, -0.05, light), buoyant_water(0.2, 0.2 * DISK_WATER * 9.81), None)])
    assert [o["stage"].label for o in out if "stage" in o] == ["approach", "hit", "slide", "float"]
    m = StageMonitor("stages", StageMonitor.Params(stop_after=0))
    out = drive(m, [(body(0.0, 0.01, 5.0, -1.0), water(False), None),
                    (body(0.5, 0.0, 0.3, -0.1), water(True, 0.001), None)])
    assert [o["stage"].label for o in out if "stage" in o] == ["approach", "sink"]


def test_a_slow_stone_whose_lowest_point_just_reaches_the_surface_is_no_sinking_stone():
    """The first wetted step of a body dropped onto water: its lowest point at the surface, nothing
    under it yet, so no buoyancy either. That was taken for a scene without buoyancy, and a cork
    ball dropped from 5 cm was called sunk (final) while it bobbed; it is a hit, and it floats."""
    m = StageMonitor("stages", StageMonitor.Params(stop_after=0))
    cork = 0.1 * DISK_WATER
    out = drive(m, [(body(0.0, 0.01, 0.0, -0.9, cork), water(False), None),
                    (body(0.0, 0.0, 0.0, -0.9, cork), buoyant_water(0.0, 0.0), None),
                    (body(0.0, 0.0, 0.0, -0.5, cork), buoyant_water(0.05, 0.05 * DISK_WATER * 9.81), None)])
    assert [o["stage"].label for o in out if "stage" in o] == ["approach", "hit", "float"]


def test_a_stone_heavier_than_water_sinks_however_hard_the_raised_water_lifts_it():
    """Floating is decided by density, not by the reported buoyancy: that includes the level of the
    water a body raises around itself, up to twice Archimedes' force as a stone plunges in or starts
    in the water. A disk of 1500 kg/m^3 lifted at 1.4 times its weight over the submerged fraction
    (as the coupler reported at its start) sinks; one of 999 kg/m^3 lifted at half of it floats."""
    for density, lift_share, expected in ((1500.0, 1.4, "sink"), (999.0, 0.5, "float")):
        m = StageMonitor("stages", StageMonitor.Params(stop_after=0))
        mass = density / 1000.0 * DISK_WATER
        lift = lift_share * mass * 9.81 * 0.5
        out = drive(m, [(body(0.0, 0.01, 0.0, -0.1, mass), water(False), None),
                        (body(0.0, 0.0, 0.0, -0.1, mass), buoyant_water(0.5, lift), None)])
        assert [o["stage"].label for o in out if "stage" in o] == ["approach", expected]


def test_a_contact_that_never_moved_down_is_no_skip():
    """A stone started in the water, rising, leaves it in a fly-away that is no skip (docs/stages.md:
    a skip began moving down into the water); one that comes down, touches and rises again skips."""
    m = StageMonitor("stages", StageMonitor.Params(stop_after=0))
    out = drive(m, [(body(0.0, 0.0, 3.0, 1.0), water(True), None),
                    (body(0.003, 0.001, 3.0, 0.99), water(True), None),
                    (body(0.006, 0.004, 3.0, 0.98), water(False, depth=-0.004), None),
                    (body(0.009, 0.0, 3.0, -0.5), water(False, depth=-0.001), None)])
    assert [o["stage"].label for o in out if "stage" in o] == ["slide", "fly-away", "approach"]
    assert not any("skip" in o for o in out) and m.track.skips == 0
    out = drive(m, [(body(0.012, -0.001, 3.0, -0.5), water(True), None),
                    (body(0.015, 0.0, 3.0, 0.5), water(True), None),
                    (body(0.018, 0.004, 3.0, 0.5), water(False, depth=-0.004), None)])
    assert [o["skip"].index for o in out if "skip" in o] == [1]


def test_a_bounce_off_a_shallow_ponds_bed_is_no_skip_and_no_sinking():
    """A stone thrown steeply into a 3 cm pond is turned back up by the bed (a SolidGround under the
    water): the water did not bounce it, so its fly-away counts no skip but a bounce off the ground
    (it was "skips: 1, take-off 60.4 deg"); and while it rises out of the water faster than
    sink_speed, slowed along the water by the bed as it is, it has not sunk (it was "sink", which is
    final, as it flew 17 cm up)."""
    m = StageMonitor("stages", StageMonitor.Params(stop_after=0.0))
    bed = GroundContact(True, 1359.0, 0.0, False, 0.0)
    out = drive(m, [(body(0.0, 0.05, 2.0, -3.0), water(False), None),
                    (body(0.001, 0.0, 2.0, -3.0), water(True, 0.5), None),
                    (body(0.002, -0.025, 0.3, 2.6), water(True, 1.0), bed),
                    (body(0.003, -0.02, 0.3, 2.5), water(True, 0.8), None),
                    (body(0.004, 0.02, 0.3, 2.4), water(False, depth=-0.02), None)])
    assert [o["stage"].label for o in out if "stage" in o] == ["approach", "hit", "slide", "fly-away"]
    assert not any("skip" in o for o in out) and m.track.skips == 0
    assert m.metrics()["ground_bounces"] == 1
    assert "skips: 0 (1 bounce off the ground, not counted)" in "\n".join(m.summary())
    # the next contact, off the water alone, is a skip again
    out = drive(m, [(body(0.1, 0.0, 3.0, -0.5), water(True), None),
                    (body(0.1, 0.0, 3.0, 0.5), water(True), None),
                    (body(0.1, 0.004, 3.0, 0.5), water(False, depth=-0.004), None)])
    assert [o["skip"].index for o in out if "skip" in o] == [1]


def test_a_stone_on_dry_ground_is_on_the_ground_not_in_the_air():
    """A stone that glides out of the water up a beach and slides on it is on the ground (it was in
    its fly-away, then in an approach, lying on the beach); a hop off the ground flies; it rests once
    static friction holds it, and a stone let go lying on the ground is on it from the start."""
    m = StageMonitor("stages", StageMonitor.Params(stop_after=0.0))
    sliding = GroundContact(True, 1.0, 0.5, True, 0.0)
    holding = GroundContact(True, 1.0, 0.0, False, 0.0)
    out = drive(m, [(body(0.0, 0.05, 3.0, -1.0), water(False), None),
                    (body(0.01, 0.0, 3.0, -0.5), water(True), None),
                    (body(0.02, 0.001, 3.0, 0.2), water(True), None),
                    (body(0.03, 0.004, 2.5, 0.1), water(False, depth=-0.004), sliding),
                    (body(0.04, 0.006, 2.0, 0.3), water(False, depth=-0.02), None),
                    (body(0.05, 0.005, 1.5, -0.3), water(False, depth=-0.02), None),
                    *[(body(0.06, 0.004, 0.0, 0.0), water(False, depth=-0.02), holding)] * HOLD])
    assert [o["stage"].label for o in out if "stage" in o] == [
        "approach", "hit", "slide", "ground", "fly-away", "approach", "ground", "rest"]
    assert m.track.skips == 0
    lying = StageMonitor("stages")
    out = drive(lying, [(body(0, 0.003, 0.0, 0.0), None, holding)] * HOLD)
    assert [o["stage"].label for o in out if "stage" in o] == ["ground", "rest"]


def test_the_distance_ends_where_the_stone_sank():
    """A sunk stone drifts on under water until the run ends stop_after later: its distance is where
    it sank (it went on with the drift, so that the figure depended on stop_after: held_skip 7.43 m
    with 0.05 s, 7.45 m with 0.3 s)."""
    m = StageMonitor("stages", StageMonitor.Params(stop_after=0.0))
    drive(m, [(body(0.0, 0.05, 3.0, -1.0), water(False), None),
              (body(1.0, 0.0, 0.3, -0.5), water(True, 0.5), None),
              *[(body(1.0 + 0.01 * k, -0.01 * k, 0.3, -0.5), water(True, 1.0), None) for k in range(1, 30)]])
    assert m.timeline[-1][1] == "sink"
    assert m.travelled() == pytest.approx(1.0)


def test_a_contact_that_runs_off_the_waters_edge_ends_without_a_skip_or_a_hit():
    """Off the grid's edge (or over land) a dry stone's lowest point is below the rest level: the
    contact is over, without a bounce, and the stone is airborne (scenarios/ricochet.yaml's last
    slide went on as a "hit" over no water, 16 ms after it left the pond's far edge). Within the
    clearance above the surface the same dry, descending step is a flicker: the contact goes on."""
    m = StageMonitor("stages", StageMonitor.Params(stop_after=0, outside_after=0))
    out = drive(m, [(body(0.0, 0.01, 5.0, -1.0), water(False), None),
                    (body(0.005, 0.0, 5.0, -0.1), water(True), None),
                    (body(0.010, 0.0, 5.0, 0.1), water(True), None),
                    (body(0.015, -0.001, 5.0, -0.1), water(False, depth=0.001), None)])
    assert [o["stage"].label for o in out if "stage" in o] == ["approach", "hit", "slide", "approach"]
    assert m.track.skips == 0 and not m.track.in_contact
    m = StageMonitor("stages", StageMonitor.Params(stop_after=0, outside_after=0))
    out = drive(m, [(body(0.0, 0.01, 5.0, -1.0), water(False), None),
                    (body(0.005, 0.0, 5.0, -0.1), water(True), None),
                    (body(0.010, 0.0, 5.0, 0.1), water(True), None),
                    (body(0.015, 0.001, 5.0, -0.1), water(False, depth=-0.001), None)])
    assert [o["stage"].label for o in out if "stage" in o] == ["approach", "hit", "slide", "hit"]
    assert m.track.in_contact


def test_a_monitor_that_never_saw_the_body_says_so_in_words():
    """A run that failed before the monitor's first step (another component at t = 0) prints no empty
    timeline and no 'nan m': it says there is no stage and no distance yet, also once told where the
    body starts (its inputs at t = 0)."""
    expected = ["stages: no stage yet (the run ended before the monitor first stepped)",
                "skips: 0; distance travelled: none yet; final stage: none"]
    assert StageMonitor("stages", StageMonitor.Params()).summary() == expected
    told = StageMonitor("stages", StageMonitor.Params())
    told.start_inputs({"body": body(0.3, 0.1, 5.0, -1.0), "water": None, "ground": None})
    assert told.summary() == expected and math.isnan(told.metrics()["distance"])


def test_each_skip_reports_the_peak_of_the_waters_vertical_force_over_the_weight():
    """A skip's peak_g is the largest sum of the water's vertical forces (buoyancy, pressure,
    friction, wave drag) during its contact over the stone's weight (mass 0.12 kg here); a force
    before the touchdown does not count, and the next contact starts from zero."""
    m = StageMonitor("stages", StageMonitor.Params(stop_after=0.0))

    def pushed(buoyancy_z: float, pressure_z: float, wetted: bool = True) -> WaterContact:
        z = np.zeros(3)
        return WaterContact(wetted, 0.1, 0.001 if wetted else 0.0, np.array([0.0, 0.0, buoyancy_z]),
                            np.array([1.0, 0.0, pressure_z]), np.array([-0.5, 0.0, 0.25]), z,
                            0.001 if wetted else -0.05, 0.0)

    weight = 0.12 * m.params.gravity
    script = [
        (body(0.0, 0.10, 5.0, -1.0), pushed(0.0, 50.0, wetted=False), None),  # dry: not counted
        (body(0.5, 0.00, 5.0, -1.0), pushed(0.5, 10.0), None),                 # hit
        (body(0.6, -0.001, 4.8, 0.2), pushed(1.0, 20.0), None),                # the peak: 21.25 N
        (body(0.65, 0.0, 4.7, 0.6), pushed(0.2, 3.0), None),
        (body(0.7, 0.01, 4.6, 0.8), pushed(0.0, 0.0, wetted=False), None),     # fly-away
        (body(0.9, 0.02, 4.6, -0.1), pushed(0.0, 0.0, wetted=False), None),
        (body(1.5, 0.0, 4.0, -0.5), pushed(0.1, 2.0), None),                   # second contact
        (body(1.6, 0.01, 3.9, 0.7), pushed(0.0, 0.0, wetted=False), None),     # fly-away
    ]
    skips = [o["skip"] for o in drive(m, script) if "skip" in o]
    assert [s.peak_g for s in skips] == [21.25 / weight, 2.35 / weight]
    assert "peak 18.1 g" in "\n".join(m.summary())
    assert m.metrics()["skip_peaks"] == f"{21.25 / weight:.2f} {2.35 / weight:.2f}"  # a sweep's column


def test_a_body_that_moved_back_by_less_than_the_last_digit_travelled_zero_not_minus_zero():
    """The summary rounds the distance before printing it: a body that drifted 3 mm back says
    0.00 m (not -0.00 m), one that went 6 mm back -0.01 m."""
    for back, said in ((0.003, "0.00 m"), (0.006, "-0.01 m")):
        m = StageMonitor("stages", StageMonitor.Params(stop_after=0))
        drive(m, [(body(0.5, 0.3, 0.0, 0.0), water(False), None),
                  (body(0.5 - back, 0.3, 0.0, 0.0), water(False), None)])
        assert m.summary()[1].startswith(f"skips: 0; distance travelled: {said};")


def test_rest_is_final_though_the_body_rocks_faster_than_rest_speed_now_and_then():
    """At rest on the ground (on a slope, say) the body jitters just above rest_speed from step to
    step: it stays at rest (it flipped from rest to approach some thirty times and the run never
    ended), as docs/stages.md says of rest."""
    touching = GroundContact(True, 1.0, 0.0, False, 0.0)
    m = StageMonitor("stages", StageMonitor.Params(stop_after=0.004))
    still = (body(1.0, 0.005, 0.0, 0.0), None, touching)
    out = drive(m, [still] * HOLD + [(body(1.0, 0.005, 0.02, 0.0), None, touching), still,
                                     (body(1.0, 0.005, 0.03, 0.0), None, touching), still, still])
    assert [o["stage"].label for o in out if "stage" in o] == ["ground", "rest"]
    assert m.stop_reason is not None and "rest" in m.stop_reason


def test_a_floating_stone_that_comes_to_rest_on_the_ground_rests_and_only_then():
    """Float is final but for the ground: a light stone floating in water too shallow for it, on the
    bed and slower than rest_speed, rests (docs/stages.md); one still moving, or off the ground,
    floats on."""
    from components.stages import classify

    light = body(1.0, 0.0, 0.01, 0.0, mass=0.5 * DISK_WATER)
    wet = WaterContact(True, 0.5, 0.001, np.array([0.0, 0.0, 1.0]), *([np.zeros(3)] * 3), 0.001, 0.0)
    touching = GroundContact(True, 1.0, 0.0, False, 0.0)
    assert classify(StageId.FLOAT, light, wet, None, sink_speed=0.1, rest_speed=0.05) is StageId.FLOAT
    assert classify(StageId.FLOAT, light, wet, touching, sink_speed=0.1, rest_speed=0.05) is StageId.REST
    moving = body(1.0, 0.0, 0.2, 0.0, mass=0.5 * DISK_WATER)
    assert classify(StageId.FLOAT, moving, wet, touching, sink_speed=0.1, rest_speed=0.05) is StageId.FLOAT


def test_the_distance_of_a_stone_that_left_the_pond_ends_where_it_left():
    """A monitor that ends no run (stop_after 0, one of several bodies'): once its stone has left the
    pond, its distance travelled stays where it left (it went on counting the stone's fall beside the
    water: 10.17 m for a stone that left a 9 m pond at x = 2.94 m), and the summary says so; one that
    never touched the water says that too. It ends where the stone came down beside the water
    (x = 1.0 m), not where it was when the spell below the level was long enough to tell."""
    m = StageMonitor("stages", StageMonitor.Params(stop_after=0.0, outside_after=0.002))
    outside = water(False, depth=0.05)  # dry, its lowest point below the water level: off the grid
    script = [(body(0.0, 0.10, 5.0, -1.0), water(False), None),
              (body(0.5, 0.00, 5.0, -1.0), water(True), None),
              (body(0.7, 0.01, 4.6, 0.8), water(False), None),
              (body(1.0, -0.05, 4.6, -0.5), outside, None),
              (body(1.2, -0.10, 4.6, -1.0), outside, None),
              (body(1.4, -0.20, 4.6, -1.5), outside, None)]  # found to have left here, at x = 1.4
    drive(m, script + [(body(x, -1.0 - x, 4.6, -5.0), outside, None) for x in (3.0, 6.0, 9.0)])
    assert m.timeline[-1][1] == "left-pond"
    assert m.travelled() == pytest.approx(1.0)
    assert "distance travelled: 1.00 m; final stage: left-pond" in "\n".join(m.summary())
    missed = StageMonitor("stages", StageMonitor.Params(stop_after=0.0, outside_after=0.002))
    drive(missed, [(body(0.2 * k, 0.1 - 0.1 * k, 5.0, -1.0), outside if k else water(False), None) for k in range(6)])
    assert "final stage: left-pond (it never touched the water)" in "\n".join(missed.summary())


def test_a_body_held_still_by_the_ground_rests_at_a_coarse_step():
    """A body on the ground is reported with up to a step of gravity's speed (the ground's answer
    reaches it at its next step): at a 2 ms step a ball on a pond's bed, 12 mm/s, never came to rest
    against rest_speed 10 mm/s (float_sphere.yaml at dt 2 ms never said rest). At rest means slower
    than rest_speed or |g| dt, whichever is more; at 0.5 ms, rest_speed still decides."""
    from components.stages import classify

    touching = GroundContact(True, 1.0, 0.0, False, 0.0)
    held = body(1.0, 0.0, 0.0, -0.012)
    assert classify(StageId.SINK, held, None, touching, sink_speed=0.1, rest_speed=0.01, step=0.002) is StageId.REST
    assert classify(StageId.SINK, held, None, touching, sink_speed=0.1, rest_speed=0.01, step=0.0005) is StageId.SINK
    falling = body(1.0, 0.0, 0.0, -0.03)
    assert classify(StageId.SINK, falling, None, touching, sink_speed=0.1, rest_speed=0.01, step=0.002) is StageId.SINK


def test_the_summary_places_the_skips_of_a_throw_along_y_along_the_throw():
    """The held skip thrown along +y: each touchdown is said by how far along the throw it is, the
    same as the throw along +x's x less its start (it said "x = 0.50 m" at every skip: true, and
    nothing of where they were); the throw along x keeps its x."""
    from cosim.runner import run_scene
    from cosim.scenario import load
    from tests.turned_throw import ALONG_Y, HELD_SKIP

    along_x = ["until=0.4", "record.visual_rate=0"]
    said = []
    for sets in (along_x, [*along_x, *ALONG_Y]):
        summary = run_scene(load(HELD_SKIP, sets), None, progress=False).summary
        said.append([line.split(", t = ")[0].strip() for line in summary if line.strip().startswith("skip ")])
    xs = [float(line.split("x = ")[1].removesuffix(" m")) for line in said[0]]
    assert len(xs) == 2 and said[1] == [f"skip {k + 1}: touchdown {x - 0.3:.2f} m along the throw"
                                         for k, x in enumerate(xs)]


def test_the_stop_line_names_the_body_the_monitor_watches():
    """A monitor's stop line names its body as the scene does (a floating ball's monitor said "stone
    float", the granite ball's "stone sink"); one driven by hand says "stone"."""
    from pathlib import Path

    from cosim.scenario import load
    from cosim.scheduler import Simulation

    scene = load(Path(__file__).resolve().parents[1] / "scenarios" / "float_sphere.yaml",
                 ["components.granite_stages.stop_after=0.3", "until=1"])
    result = Simulation(scene).run()
    assert result.status == "stopped" and "granite_stages: granite sink since t = 0 s" in result.reason
    m = StageMonitor("stages", StageMonitor.Params(stop_after=0.001))
    drive(m, [(body(0.0, 0.01, 0.0, -0.5), water(True, 0.5), None)] * 3)
    assert m.stop_reason.startswith("stone sink since t = ")


def test_a_light_stone_whose_sliver_under_water_reads_no_buoyancy_is_not_sunk():
    """A light ball landing slowly on water it stirred: at its first wetted step the coupler reported a
    sliver under water (5.6e-5 of it) and no buoyancy (its own raised water counted), and the monitor
    took that for water without buoyancy: 'sink', final, for a ball that floats. A light stone goes
    on until a hundredth of it is under and the buoyancy tells; a heavy one still sinks at once."""
    light = 0.2 * DISK_WATER
    m = StageMonitor("stages", StageMonitor.Params(stop_after=0))
    out = drive(m, [(body(0.0, 0.02, 0.0, -2.3, light), water(False), None),
                    (body(0.0, 0.01, 0.0, -2.3, light), buoyant_water(6e-5, 0.0), None),
                    (body(0.0, 0.005, 0.0, -2.2, light), buoyant_water(0.02, 0.02 * DISK_WATER * 9.81), None)])
    assert [o["stage"].label for o in out if "stage" in o] == ["approach", "hit", "float"]


def test_a_stone_started_at_rest_in_the_water_and_rising_out_is_no_skip():
    """A light ball started under water at 2 m/s: its first step in a scene is under gravity alone (the
    water's answer reaches it a step later), so it reports -g dt, and the monitor took that for the
    contact's descent: its rise out of the water was 'skip 1', touchdown at the start.
    A descent is faster than a step of gravity's speed; a stone that comes down into the water skips."""
    light = 0.2 * DISK_WATER
    under = buoyant_water(1.0, DISK_WATER * 9.81)
    m = StageMonitor("stages", StageMonitor.Params(stop_after=0))
    out = drive(m, [(body(0.0, -0.02, 2.0, -9.81e-3, light), under, None),
                    *[(body(0.002 * k, -0.02 + 0.002 * k, 2.0, 0.5 * k, light), under, None) for k in range(1, 5)],
                    (body(0.01, 0.02, 2.0, 2.5, light), water(False, depth=-0.005), None)])
    assert [o["stage"].label for o in out if "stage" in o] == ["hit", "slide", "fly-away"]
    assert m.track.skips == 0 and m.records == []
    m = StageMonitor("stages", StageMonitor.Params(stop_after=0))
    drive(m, [(body(0.0, 0.01, 3.0, -0.5), water(False), None), (body(0.003, 0.0, 3.0, -0.2), water(True), None),
              (body(0.006, 0.0, 3.0, 0.3), water(True), None), (body(0.009, 0.01, 3.0, 0.4), water(False), None)])
    assert m.track.skips == 1


def test_each_stage_message_says_when_its_stage_began_as_the_summary_does():
    """Rest is known REST_HOLD after its slow spell began and the run's first stage at the end of the
    first step, and the Stage messages were published then: `cosim inspect`, the plots and Foxglove,
    which had only the message's time, said rest at 0.7105 s where the summary said 0.6905 s. Each
    message carries since [s], the time the summary gives."""
    m = StageMonitor("stages", StageMonitor.Params(stop_after=0))
    holding = GroundContact(True, 1.0, 0.0, False, 0.0)
    still = (body(0.0, 0.003, 0.0, 0.0), None, holding)
    out = drive(m, [(body(0.0, 0.05, 0.0, -1.0), None, None)] + [still] * (HOLD + 8))
    published = [(o["stage"].label, o["stage"].since) for o in out if "stage" in o]
    assert [label for label, _ in published] == ["approach", "ground", "rest"]
    assert published == [(label, t) for t, label in m.timeline]
    assert published[0][1] == 0.0 and published[2][1] == pytest.approx(0.002)  # rest from its spell's start


def test_rest_and_a_descent_are_judged_on_the_bodys_step_not_the_monitors():
    """The rules about a step of gravity's speed (a body the ground holds is reported with up to |g|
    step; a descent is faster than that) are about the body's step, which the scene tells the monitor
    (Component.source_steps). A body stepping every 4 ms under a monitor stepping every 1 ms: held
    still at 4 ms of gravity's speed it rests (it never did: 39 mm/s against the monitor's 10 mm/s),
    and its first step under water, -g 4 ms, is no descent (its rise out was a skip). A monitor
    stepping every 10 ms over a body at 1 ms: 20 mm/s on the ground is no rest (|g| 10 ms let it be)."""
    holding = GroundContact(True, 1.0, 0.0, False, 0.0)
    m = StageMonitor("stages", StageMonitor.Params(stop_after=0))
    m.source_steps["body"] = 0.004
    drive(m, [(body(0.0, 0.003, 0.0, -0.035), None, holding)] * HOLD)
    assert m.stage is StageId.REST
    light = 0.2 * DISK_WATER
    under = buoyant_water(1.0, DISK_WATER * 9.81)
    m = StageMonitor("stages", StageMonitor.Params(stop_after=0))
    m.source_steps["body"] = 0.004
    drive(m, [(body(0.0, -0.02, 2.0, -9.81 * 0.004, light), under, None),
              *[(body(0.002 * k, -0.02 + 0.002 * k, 2.0, 0.5 * k, light), under, None) for k in range(1, 5)],
              (body(0.01, 0.02, 2.0, 2.5, light), water(False, depth=-0.005), None)])
    assert m.track.skips == 0
    m = StageMonitor("stages", StageMonitor.Params(stop_after=0))
    m.source_steps["body"] = 0.001
    for k in range(3 * HOLD):
        m.step(k * 10 * MS, 10 * MS, {"body": body(0.0, 0.003, 0.02, 0.0), "water": None, "ground": holding})
    assert m.stage is StageId.GROUND


def test_the_scene_tells_a_monitor_its_bodys_step(tmp_path):
    """Through the scheduler: a ball resting on a floor, the ball and its floor stepping every 4 base
    steps (2 ms) and its monitor every step, comes to rest (it stayed on the ground for good), and
    a replay of the monitor alone is told the same step (bit for bit)."""
    from cosim.record.reader import Recording
    from cosim.replay import replay_component
    from cosim.runner import run_scene
    from cosim.scenario import loads
    from cosim.scheduler import Simulation

    scene = loads("""
name: resting
dt: 0.0005
until: 0.25
components:
  ball: {type: RigidBody, shape: sphere, radius: 0.02, density: 2700.0, position: [0, 0, 0.02], every: 4}
  floor: {type: SolidGround, every: 4}
  stages: {type: StageMonitor, stop_after: 0}
connections:
  - ball.state -> floor.body
  - from: floor.impulse
    to: ball.impulse
    delay: 1
    initial: {linear: [0, 0, 0], angular: [0, 0, 0], correction: [0, 0, 0]}
  - ball.state -> stages.body
  - floor.contact -> stages.ground
""")
    sim = Simulation(scene)
    assert sim.components["stages"].source_steps == {"body": 0.002, "ground": 0.002}
    outcome = run_scene(scene, tmp_path / "resting.mcap", progress=False, simulation=sim)
    assert outcome.result.status == "ok" and sim.components["stages"].stage is StageId.REST
    report = replay_component(Recording(tmp_path / "resting.mcap"), "stages")
    assert report.ok and report.messages_compared >= 2, str(report)


def test_leaving_the_pond_is_decided_when_outside_after_has_passed_whatever_the_rounding():
    """outside_after 10 ms at 1 ms steps from t = 0: 0.011 - 0.001 is a hair under 0.01 in floating
    point, and the stone was found to have left the pond a step late (11 ms) for some starts."""
    m = StageMonitor("stages", StageMonitor.Params(outside_after=0.01, stop_after=0))
    out = drive(m, [(body(0.1 * k, -0.01, 5.0, -0.5), water(False, depth=0.004), None) for k in range(12)])
    left = [k for k, o in enumerate(out) if "stage" in o and o["stage"].label == "left-pond"]
    assert left == [10] and m.timeline[-1] == (pytest.approx(0.011), "left-pond")


def test_the_first_stage_is_placed_where_the_run_began():
    """The first stage is dated t = 0, the run's start; its place is the body's there, not a step
    later (an inspect of the reference skip said approach at 0 s, x 0.3055, its stone thrown from 0.3)."""
    m = StageMonitor("stages", StageMonitor.Params(stop_after=0))
    m.start_inputs({"body": body(0.3, 0.1, 11.0, -1.0)})
    out = drive(m, [(body(0.3055, 0.1, 11.0, -1.0), water(False), None)])
    assert (out[0]["stage"].since, out[0]["stage"].x) == (0.0, 0.3)


def _floating_disk(angular_velocity: tuple[float, float, float], speed: float = 0.001) -> BodyState:
    """A wooden disk (R = 5 cm, e = 2 cm, 500 kg/m^3) lying flat, its centre moving at ``speed``
    [m/s] and turning at ``angular_velocity`` [rad/s]."""
    mass = 500.0 * math.pi * 0.05**2 * 0.02
    across = mass * (0.05**2 / 4 + 0.02**2 / 12)
    v, w = np.array([speed, 0.0, 0.0]), np.array(angular_velocity)
    return BodyState(np.zeros(3), np.array([1.0, 0, 0, 0]), v, w, Shape.DISK, 0.05, 0.02, mass,
                     np.array([across, across, mass * 0.05**2 / 2]), 0.0, speed, 0.0, 0.0)


@pytest.mark.parametrize("angular_velocity, is_settled", [
    ((1.2, 0.0, 0.0), False),  # rocking at 1.2 rad/s: 3.1 cm/s weighed by its radius of gyration (2.6 cm)
    ((0.0, 0.3, 0.0), True),  # 0.3 rad/s: 0.8 cm/s, with its centre's 0.1 cm/s under 1 cm/s
    ((0.0, 0.0, 5.0), True),  # spinning about its axis moves no water up or down
])
def test_a_floating_disk_has_settled_once_it_no_longer_rocks(angular_velocity, is_settled):
    """The run ends stop_after once a floating body has settled: a disk let go tilted ended the run
    at 0.67 s, its centre slower than 1 cm/s for 0.3 s, while it still rocked at 3.5 deg and
    1.2 rad/s."""
    from components.stages import settled
    assert settled(_floating_disk(angular_velocity)) is is_settled
    m = StageMonitor("stages", StageMonitor.Params(stop_after=0.002))
    fraction = 0.5
    lift = 1000.0 * math.pi * 0.05**2 * 0.02 * 9.81 * fraction
    disk = _floating_disk(angular_velocity)
    for k in range(6):
        m.step(k * MS, MS, {"body": disk, "water": buoyant_water(fraction, lift), "ground": None})
    assert [label for _, label in m.timeline] == ["float"]
    assert bool(m.stop_reason) is is_settled
