"""The visual deriver: frame rate on simulation time, the registry, trails, resending, failures."""

from __future__ import annotations

import numpy as np
import pytest

from cosim.component import Component, Port
from cosim.messages import Message, message
from cosim.view.items import (
    KEEPALIVE_NS,
    TRAIL_TIP_POINTS,
    Entity,
    LogLine,
    Sphere,
    Trail,
    Transform,
    VisualDeriver,
    VisualsWarning,
    decimation,
    every_message,
    height_field_mesh,
    register,
    type_key,
    unregister,
    visuals_for,
)

MS = 1_000_000


@message
class Blip(Message):
    """A test message: a number."""

    value: float


@message
class Other(Message):
    """Another test message."""

    value: float


def blip_visuals(component, port, msg):
    return [Entity(f"/scene/{component}", "dot", "world",
                   [Sphere((msg.value, msg.value, msg.value), (1, 0, 0, 1))])]


@pytest.fixture
def registry():
    register(Blip, blip_visuals)
    yield
    unregister(Blip)
    unregister(Other)


def times_with_frames(deriver, stamps, component="c", port="p", value=None):
    out = []
    for i, t in enumerate(stamps):
        if deriver(t, component, port, Blip(float(i + 1) if value is None else value)):
            out.append(t)
    return out


def test_frames_follow_simulation_time_at_the_rate(registry):
    """At 30 frames/s, the first message at or after each k/30 s is drawn, and no other."""
    d = VisualDeriver(30.0)
    drawn = times_with_frames(d, [k * MS for k in range(0, 201)])
    assert drawn == [0, 34 * MS, 67 * MS, 100 * MS, 134 * MS, 167 * MS, 200 * MS]


def test_a_slower_publisher_is_drawn_at_its_own_messages(registry):
    """Messages sparser than the frame rate are each drawn once (no frame is invented)."""
    d = VisualDeriver(30.0)
    stamps = [k * 50 * MS for k in range(5)]
    assert times_with_frames(d, stamps) == stamps


def test_each_port_has_its_own_frame_clock(registry):
    """Two publishers of the same type are each drawn at the frame rate."""
    d = VisualDeriver(10.0)
    for k in range(0, 201):
        a = d(k * MS, "a", "p", Blip(1.0 + k))
        b = d(k * MS, "b", "p", Blip(1.0 + k))
        assert bool(a) == bool(b) == (k % 100 == 0)


def test_fractional_rates_use_exact_frame_times(registry):
    """Frame k is due at the first integer nanosecond at or after k / rate."""
    d = VisualDeriver(29.97)
    assert d.frame_time_ns(1) == 33366701  # 1 / 29.97 s = 33366700.03... ns, rounded up
    assert d.next_frame_ns(0) == d.frame_time_ns(1)
    assert d.next_frame_ns(d.frame_time_ns(1)) == d.frame_time_ns(2)


@pytest.mark.parametrize("rate", [0.0, -1.0, float("nan"), float("inf")])
def test_rate_must_be_positive(rate):
    """A deriver needs a positive, finite frame rate."""
    with pytest.raises(ValueError, match="positive number of frames/s"):
        VisualDeriver(rate)


def test_types_without_visuals_cost_a_lookup_and_produce_nothing(registry):
    """A message type nobody registered yields no viewer messages."""
    d = VisualDeriver(30.0)
    assert d(0, "c", "q", Other(1.0)) == ()
    assert d(0, "c", "q", Other(1.0)) == ()


def test_every_message_visuals_see_every_message(registry):
    """A function marked every_message is called for each message, not at the frame rate."""
    seen = []

    @every_message
    def log(component, port, msg):
        seen.append(msg.value)
        return [LogLine("/log", "info", component, f"{msg.value}")]

    register(Other, log)
    d = VisualDeriver(1.0)
    for k in range(5):
        assert d(k * MS, "m", "stage", Other(float(k))) != []
    assert seen == [0.0, 1.0, 2.0, 3.0, 4.0]


def test_the_registry_names_types_by_module_and_class():
    """Entry points are keyed by the message type's full name; the components' types are found."""
    from components.messages import BodyState, Stage, WaterField
    from components.visuals import body_state, stage, water_field

    assert type_key(BodyState) == "components.messages.BodyState"
    assert visuals_for(BodyState) is body_state
    assert visuals_for(WaterField) is water_field
    assert visuals_for(Stage) is stage
    assert visuals_for(Other) is None


class Lamp(Component):
    """Publishes Blip and draws it itself."""

    outputs = {"out": Port(Blip)}

    def _step_impl(self, t, dt, inputs):
        return {"out": Blip(1.0)}

    def visuals(self, port, msg):
        return [Entity("/scene/lamp", "own", "world", [Sphere((9.0, 9.0, 9.0), (0, 1, 0, 1))])]


def test_a_component_override_wins_over_the_registry(registry):
    """When the producing component overrides visuals(), its items are used, not the registry's."""
    d = VisualDeriver(30.0, components={"lamp": Lamp("lamp"), "plain": Component("plain")})
    (own,) = d(0, "lamp", "out", Blip(1.0))
    (registered,) = d(0, "plain", "out", Blip(2.0))
    assert own.id == "own" and registered.id == "dot"


def _trail_frames(d, values, start_ms=0, step_ms=1):
    """Feed a trail one point a frame; return each frame's {entity id: x of its points}."""
    frames = []
    for k, value in enumerate(values):
        frames.append({e.id: e.primitives[0].points[:, 0].tolist()
                       for e in d((start_ms + k * step_ms) * MS, "c", "p", Other(float(value)))})
    return frames


def test_a_trail_holds_the_whole_path_in_its_history_and_its_tip(registry):
    """A Trail item becomes two line strips: the tip, the points since the last TRAIL_TIP_POINTS
    settled, sent each frame, and the history before them, sent when it grows (about once a
    second): together every point so far (the one strip re-sent whole every frame was 2.7 GB of a
    700 s run's 2.8); up to max_points in all, the latest (the strip stopped growing at half of
    them: 3 of 6)."""
    register(Other, lambda c, p, m: [Trail("/scene/t", "trail", "world", (m.value, 0.0, 0.0), (1, 1, 1, 1),
                                           max_points=100)])
    d = VisualDeriver(1000.0)
    frames = _trail_frames(d, range(250))
    for k, frame in enumerate(frames):
        history, tip = frame.get("trail"), frame["trail-tip"]
        if history is not None:
            last_history = history
        path = last_history[:-1] + tip if last_history else tip
        assert path == [float(v) for v in range(max(0, k + 1 - len(path)), k + 1)]  # the latest, in order
        assert len(tip) <= TRAIL_TIP_POINTS + 1 and len(last_history) <= 99
    assert len(last_history) == 99  # capped at max_points (and the tip beyond)
    sent_history = [k for k, frame in enumerate(frames) if "trail" in frame]
    assert len(sent_history) <= 250 // TRAIL_TIP_POINTS + 2


def test_a_body_at_rest_sends_no_trail(registry):
    """A point within TRAIL_STEP of the last adds nothing: a still body's trail is unchanged, so it
    is only kept alive (a disk that never moved sent 61 trail messages against 3 of its body)."""
    register(Other, lambda c, p, m: [Trail("/scene/t", "trail", "world", (m.value, 0.0, 0.0), (1, 1, 1, 1))])
    d = VisualDeriver(10.0)
    frames = _trail_frames(d, [0.0] * 21 + [0.0004] * 10, step_ms=100)
    assert [k for k, frame in enumerate(frames) if frame] == [0, 10, 20, 30]  # its first frame, then keepalives


def test_an_unchanged_entity_is_resent_only_as_a_keepalive(registry):
    """An entity equal to the last one sent on its topic and id is skipped until KEEPALIVE_NS passes;
    transforms are always sent."""
    register(Other, lambda c, p, m: [Transform("world", "c", (0, 0, 0), (1, 0, 0, 0)),
                                     Entity("/scene/c", "still", "world", [Sphere((1, 1, 1), (1, 1, 1, 1))])])
    d = VisualDeriver(10.0)
    sent = []
    for k in range(0, 2 * KEEPALIVE_NS // MS + 1, 100):
        items = d(k * MS, "c", "p", Other(0.0))
        sent.append((k, sorted(type(i).__name__ for i in items)))
    with_entity = [k for k, names in sent if "Entity" in names]
    assert with_entity == [0, 1000, 2000]
    assert all("Transform" in names for _, names in sent)


def test_a_failing_visuals_function_is_switched_off_with_a_warning(registry):
    """An exception in a visuals function never stops the run: one error log line, then silence."""
    register(Other, lambda c, p, m: [1 / 0])
    d = VisualDeriver(1000.0)
    with pytest.warns(VisualsWarning, match=r"/c/p failed at t = 0 s .* ZeroDivisionError"):
        (line,) = d(0, "c", "p", Other(0.0))
    assert isinstance(line, LogLine) and line.level == "error" and "switched off" in line.text
    assert d(5 * MS, "c", "p", Other(0.0)) == ()


def test_viewer_items_may_not_use_physics_channels(registry):
    """A visual item on a physics channel's topic is refused (the function is switched off)."""
    register(Other, lambda c, p, m: [LogLine("/c/p", "info", c, "clash")])
    d = VisualDeriver(30.0, reserved_topics=frozenset({"/c/p"}))
    with pytest.warns(VisualsWarning, match="'/c/p' is a physics channel"):
        d(0, "c", "p", Other(0.0))


def test_unknown_log_levels_are_refused(registry):
    """Log lines take one of the Foxglove levels."""
    register(Other, lambda c, p, m: [LogLine("/log", "loud", c, "x")])
    with pytest.warns(VisualsWarning, match="log level 'loud'"):
        VisualDeriver(30.0)(0, "c", "p", Other(0.0))


@pytest.mark.parametrize(("n", "max_n"), [(10, 64), (64, 64), (65, 64), (1000, 64), (513, 33)])
def test_decimation_keeps_both_ends_and_at_most_max(n, max_n):
    """Decimation picks at most max_n distinct, increasing indices including 0 and n - 1."""
    idx = decimation(n, max_n)
    assert idx[0] == 0 and idx[-1] == n - 1
    assert len(idx) == min(n, max_n) and np.all(np.diff(idx) > 0)


def test_height_field_mesh_samples_cells_exactly():
    """Each surface vertex sits on a cell centre with that cell's exact height; triangles are indexed."""
    rng = np.random.default_rng(1)
    h = rng.normal(size=(90, 200))
    mesh = height_field_mesh(h, origin_x=-1.0, origin_y=2.0, cell=0.05, max_side=64,
                             colors=lambda z: np.tile([0.0, 0.0, 1.0, 1.0], (len(z), 1)))
    rows, cols = decimation(90, 64), decimation(200, 64)
    assert mesh.points.shape == (64 * 64, 3) and mesh.colors.shape == (64 * 64, 4)
    pts = mesh.points.reshape(64, 64, 3)
    assert np.array_equal(pts[..., 2], h[np.ix_(rows, cols)])
    assert np.allclose(pts[0, :, 0], -1.0 + 0.05 * cols) and np.allclose(pts[:, 0, 1], 2.0 + 0.05 * rows)
    assert len(mesh.indices) == 63 * 63 * 6 and mesh.indices.max() == 64 * 64 - 1


def test_height_field_mesh_needs_a_grid():
    """A surface needs at least 2 x 2 cells."""
    with pytest.raises(ValueError, match="at least 2 x 2"):
        height_field_mesh(np.zeros((1, 5)), 0.0, 0.0, 1.0)


def test_decimation_is_the_unique_rounded_spread():
    """The indices are those of np.unique over the rounded even spread, for every size up to 300 and
    every budget up to 70 (decimation drops the repeats itself, sparing np.unique's numpy.ma import)."""
    for n in range(2, 300):
        for max_n in range(2, 70):
            spread = np.round(np.linspace(0, n - 1, max_n)).astype(np.int64)
            expected = np.arange(n) if n <= max_n else np.unique(spread)
            got = decimation(n, max_n)
            assert got.dtype == expected.dtype and np.array_equal(got, expected), (n, max_n)
