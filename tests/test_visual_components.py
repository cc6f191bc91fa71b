"""What the physics messages look like: the stone, its trail and velocity, the water, the stage log."""

from __future__ import annotations

import numpy as np
import pytest

from components.messages import Shape, SkipRecord, Stage, StageId, WaterField
from components.visuals import (
    COLOR_LEVELS,
    SURFACE_SIDE,
    WATER_STOPS,
    WAVE_SCALE,
    body_state,
    skip_record,
    stage,
    water_colors,
    water_field,
)
from cosim.view.items import Arrow, Cube, Cylinder, Entity, LogLine, Sphere, Trail, Transform, color_ramp, decimation
from tests.viewer_toys import ScriptedStone


def state(shape: str = "disk", t: float = 0.05):
    stone = ScriptedStone("stone", ScriptedStone.Params(shape=shape))
    return stone.state_at(t)


def by_type(items, kind):
    return [i for i in items if isinstance(i, kind)]


def test_body_state_gives_the_stone_frame_on_tf():
    """The transform world -> <body> carries the state's position and quaternion unchanged."""
    msg = state()
    (tf,) = by_type(body_state("stone", "state", msg), Transform)
    assert (tf.parent, tf.child, tf.topic) == ("world", "stone", "/tf")
    assert np.array_equal(tf.position, msg.position) and np.array_equal(tf.orientation, msg.orientation)


def test_a_disk_is_a_frame_locked_cylinder_of_its_true_size():
    """A disk is drawn as a cylinder 2R wide and one thickness high, locked to the stone frame."""
    msg = state("disk")
    body = next(e for e in by_type(body_state("stone", "state", msg), Entity) if e.id == "body")
    assert body.topic == "/scene/stone" and body.frame_id == "stone" and body.frame_locked
    (cyl,) = [p for p in body.primitives if isinstance(p, Cylinder)]
    assert tuple(cyl.size) == (2 * msg.radius, 2 * msg.radius, msg.thickness)
    assert any(isinstance(p, Cube) for p in body.primitives)  # the stripe that shows the spin


def test_a_sphere_is_a_sphere_of_its_diameter():
    """A spherical body is drawn as a sphere of diameter 2R."""
    msg = state("sphere")
    assert msg.shape is Shape.SPHERE
    body = next(e for e in by_type(body_state("stone", "state", msg), Entity) if e.id == "body")
    assert tuple(body.primitives[0].size) == (2 * msg.radius,) * 3 and isinstance(body.primitives[0], Sphere)


def test_trail_and_velocity_arrow_start_at_the_body():
    """The trail point is the position; the velocity arrow starts there along the velocity."""
    msg = state()
    items = body_state("stone", "state", msg)
    (trail,) = by_type(items, Trail)
    assert trail.topic == "/scene/stone/trail" and np.array_equal(trail.point, msg.position)
    arrow_entity = next(e for e in by_type(items, Entity) if e.id == "velocity")
    (arrow,) = arrow_entity.primitives
    assert isinstance(arrow, Arrow) and np.array_equal(arrow.start, msg.position)
    direction = np.asarray(arrow.vector) / np.linalg.norm(arrow.vector)
    assert np.allclose(direction, msg.velocity / np.linalg.norm(msg.velocity))


def field(nx: int, ny: int) -> WaterField:
    x = np.arange(nx)[None, :]
    y = np.arange(ny)[:, None]
    h = 0.002 * np.sin(0.3 * x) * np.cos(0.2 * y)
    return WaterField(cell=0.01, origin_x=1.0, origin_y=-0.5, height=h, volume=1.0, energy=0.0)


@pytest.mark.parametrize(("nx", "ny"), [(40, 30), (512, 256), (65, 64)])
def test_water_surface_is_decimated_to_64_per_side_with_exact_heights(nx, ny):
    """The surface has at most 64 x 64 vertices, each at a cell centre with the cell's height."""
    msg = field(nx, ny)
    (entity,) = water_field("pond", "field", msg)
    assert entity.topic == "/scene/pond" and entity.frame_id == "world" and entity.id == "surface"
    (mesh,) = entity.primitives
    rows, cols = decimation(ny, SURFACE_SIDE), decimation(nx, SURFACE_SIDE)
    assert len(mesh.points) == len(rows) * len(cols) <= 64 * 64
    assert np.array_equal(mesh.points[:, 2], msg.height[np.ix_(rows, cols)].ravel())
    assert np.allclose(mesh.points[:, 0].reshape(len(rows), -1)[0], 1.0 + 0.01 * cols)


def test_crests_are_lighter_than_troughs():
    """Colour brightness grows with the height above the mean level."""
    colors = water_colors(np.array([-0.01, -0.002, 0.0, 0.002, 0.01]))
    brightness = colors[:, :3].sum(axis=1)
    assert np.all(np.diff(brightness) > 0)
    assert np.all(colors[:, 2] >= colors[:, 0])  # blue throughout


def test_water_shades_are_the_colour_ramp_of_the_rounded_height():
    """Each vertex's colour, looked up in the palette of shades, is the colour ramp of its height
    rounded to COLOR_LEVELS steps per WAVE_SCALE, bit for bit, in the troughs, on the crests, at the
    mean level (both zeros) and far beyond the ends of the ramp."""
    rng = np.random.default_rng(5)
    heights = np.concatenate([rng.standard_normal(2000) * WAVE_SCALE, rng.standard_normal(200) * 1.0,
                              [0.0, -0.0, WAVE_SCALE, -WAVE_SCALE, 0.5 * WAVE_SCALE / COLOR_LEVELS, 1e6, -1e6]])
    ramped = color_ramp(np.round(heights / WAVE_SCALE * COLOR_LEVELS) / COLOR_LEVELS, WATER_STOPS)
    shaded = water_colors(heights)
    assert shaded.shape == (len(heights), 4)
    assert np.array_equal(shaded.view(np.uint64), ramped.view(np.uint64))


def test_every_stage_change_is_a_log_line():
    """A stage becomes one /log line naming it; sinking is a warning."""
    (line,) = stage("monitor", "stage", Stage(StageId.HIT, "hit", 2, 3.25))
    assert isinstance(line, LogLine) and line.topic == "/log" and line.level == "info"
    assert line.name == "monitor" and line.text.startswith("hit (stage 1): skips 2, x = 3.250 m")
    # where, both ways: a throw along y said "x = 0.500 m" at every stage
    (line,) = stage("monitor", "stage", Stage(StageId.HIT, "hit", 2, 0.5, 3.25))
    assert line.text == "hit (stage 1): skips 2, at (0.500, 3.250) m"
    (sink,) = stage("monitor", "stage", Stage(StageId.SINK, "sink", 4, 9.0))
    assert sink.level == "warning"
    # a y a hair below 0 is 0.000 (it read -0.000); rest, known REST_HOLD after it began, says when
    (line,) = stage("monitor", "stage", Stage(StageId.REST, "rest", 0, 2.0, -9.436e-19, since=0.43))
    assert line.text == "rest (stage 5): skips 0, at (2.000, 0.000) m, since t = 0.430 s"
    # every digit the run's time has, as the summary gives it (0.4325 read 0.432)
    (line,) = stage("monitor", "stage", Stage(StageId.REST, "rest", 0, 2.0, 0.0, since=0.4325))
    assert line.text.endswith("since t = 0.4325 s")
    assert getattr(stage, "every_message", False) and getattr(skip_record, "every_message", False)


def test_every_skip_is_a_log_line():
    """A finished skip becomes one /log line with its figures."""
    (line,) = skip_record("monitor", "skip", SkipRecord(2, 0.31, 1.25, 0.038, 13.8, 0.88, 4.19, 4.12, peak_g=7.25))
    assert line.text.startswith("skip 2: touchdown at x = 1.250 m") and "contact 38.0 ms, peak 7.2 g" in line.text
    (line,) = skip_record("monitor", "skip", SkipRecord(2, 0.31, 0.5, 0.038, 13.8, 0.88, 4.19, 4.12, peak_g=7.25,
                                                        touchdown_y=1.25))
    assert line.text.startswith("skip 2: touchdown at (0.500, 1.250) m, t = 0.3100 s")
    # a touchdown at 0.25 ms steps to its last digit (0.00075 s read 0.0008 s)
    (line,) = skip_record("monitor", "skip", SkipRecord(1, 0.00075, 0.5, 0.038, 13.8, 0.88, 4.19, 4.12))
    assert "t = 0.00075 s;" in line.text
