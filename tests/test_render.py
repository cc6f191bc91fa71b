"""`cosim render`: frames of the stone over the water, checked by where the stone is drawn."""

from __future__ import annotations

import itertools
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import numpy as np
import pytest
from PIL import Image

from components.analysis.render import (
    RenderError,
    RenderOptions,
    _ffmpeg,
    body_polygons,
    crop_field,
    frame_times,
    render,
    rotation_matrix,
)
from cosim.cli import main
from tests.viewer_toys import record_skip

WIDTH = 320


@pytest.fixture(scope="module")
def skip_path(tmp_path_factory):
    path = tmp_path_factory.mktemp("render") / "skip.mcap"
    record_skip(path, ["record.visual_rate=0"])
    return path


def gif_frames(path) -> list[np.ndarray]:
    frames = []
    with Image.open(path) as im:
        for i in range(im.n_frames):
            im.seek(i)
            frames.append(np.asarray(im.convert("RGB"), dtype=float) / 255)
    return frames


def stone_column(frame: np.ndarray) -> float:
    """Mean column of the stone's warm pixels (red well above blue), between the title line and the
    notes at the foot (in the stage's colour, as the title)."""
    body = frame[int(0.12 * frame.shape[0]):int(0.88 * frame.shape[0])]
    warm = (body[..., 0] - body[..., 2]) > 0.1
    assert warm.sum() >= 3, "no stone drawn"
    return float(np.nonzero(warm)[1].mean())


def test_the_stone_moves_along_x_between_frames_in_the_fixed_view(skip_path, tmp_path):
    """In the fixed view, the drawn stone moves right (+x) from frame to frame."""
    out = tmp_path / "skip.gif"
    result = render(skip_path, out, RenderOptions(fps=10, width=WIDTH, view="fixed", progress=False))
    frames = gif_frames(out)
    assert result.frames == len(frames) == 7  # t = 0, 0.1, ..., 0.6 s
    assert frames[0].shape == (result.height, WIDTH, 3) and frames[0].std() > 0.05
    columns = [stone_column(f) for f in frames]
    assert all(b > a + 5 for a, b in itertools.pairwise(columns)), columns


def test_the_follow_view_keeps_the_stone_centred_while_the_water_changes(skip_path, tmp_path):
    """In the follow view the stone stays near the middle and the surface around it changes."""
    out = tmp_path / "follow.gif"
    render(skip_path, out, RenderOptions(fps=10, width=WIDTH, view="follow", start=0.1, stop=0.4,
                                         progress=False))
    frames = gif_frames(out)
    assert len(frames) == 4
    for f in frames:
        assert abs(stone_column(f) - WIDTH / 2) < 0.15 * WIDTH
    assert np.abs(frames[0] - frames[-1]).mean() > 0.01


def test_one_png_frame_at_a_chosen_time(skip_path, tmp_path, capsys):
    """`cosim render -o frame.png --at T` writes one non-empty frame of the requested size."""
    out = tmp_path / "frame.png"
    assert main(["render", str(skip_path), "-o", str(out), "--at", "0.3", "--width", "400", "-q"]) == 0
    assert "1 frame, 400 x 224 px, t = 0.300" in capsys.readouterr().out
    image = np.asarray(Image.open(out).convert("RGB"), dtype=float) / 255
    assert image.shape == (224, 400, 3) and image.std() > 0.05
    blue = (image[..., 2] - image[..., 0]) > 0.2
    assert blue.mean() > 0.05  # the water surface fills part of the frame


def test_no_progress_bar_is_drawn_into_a_log(skip_path, tmp_path, capsys):
    """Without -q, render draws its bar only on a terminal: into a redirected stderr (a log, a pipe;
    capsys's is no terminal) it wrote some thirty redraws, as a run does not."""
    out = tmp_path / "short.gif"
    assert main(["render", str(skip_path), "-o", str(out), "--to", "0.05", "--width", "200"]) == 0
    assert out.exists() and "render short.gif" not in capsys.readouterr().err

def test_unknown_formats_and_times_are_bad_input(skip_path, tmp_path, capsys):
    """An unknown extension or times outside the recording exit 2 with a one-line reason, no file."""
    assert main(["render", str(skip_path), "-o", str(tmp_path / "x.avi"), "-q"]) == 2
    assert "unknown format '.avi'" in capsys.readouterr().err
    late = ["--from", "2", "--to", "3"]
    assert main(["render", str(skip_path), "-o", str(tmp_path / "x.gif"), *late, "-q"]) == 2
    assert "outside the recorded" in capsys.readouterr().err
    assert main(["render", str(skip_path), "-o", str(tmp_path / "x.png"), "--at", "100", "-q"]) == 2
    assert "frame time 100 s is outside the recorded" in capsys.readouterr().err  # not its last frame
    # options that do not apply to the output were ignored (a PNG at another time, a whole GIF)
    assert main(["render", str(skip_path), "-o", str(tmp_path / "x.png"), "--from", "0.2", "--to", "0.3"]) == 2
    assert "a PNG is one frame: give its time with --at" in capsys.readouterr().err
    assert main(["render", str(skip_path), "-o", str(tmp_path / "x.gif"), "--at", "0.1", "-q"]) == 2
    assert "--at is a PNG's frame time" in capsys.readouterr().err
    # the fixed view shows the whole run: a window width asked for it was dropped without a word
    assert main(["render", str(skip_path), "-o", str(tmp_path / "x.gif"), "--view", "fixed", "--span", "2"]) == 2
    assert "--span 2: the width of the follow view's window; the fixed view shows the whole run" \
           in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


def test_with_several_bodies_the_watched_stone_is_shown_over_its_own_water(tmp_path):
    """The default body is the one a stage monitor watches, not the first by name (the ball beside
    the stone); a body is drawn over the field of the water it meets, not the first pond's."""
    from components.analysis.data import body_water_topic, load_body, topics_of
    from components.messages import WaterField
    from cosim.record.reader import Recording
    from cosim.runner import run_scene
    from cosim.scenario import load

    scenes = Path(__file__).resolve().parents[1] / "scenarios"
    run_scene(load(scenes / "stone_and_ball.yaml", ["until=0.01", "record.visual_rate=0"]), tmp_path / "sab.mcap",
              progress=False)
    assert load_body(Recording(tmp_path / "sab.mcap")).name == "stone"
    run_scene(load(scenes / "float_sphere.yaml", ["until=0.05"]), tmp_path / "fs.mcap", progress=False)
    rec = Recording(tmp_path / "fs.mcap")
    fields = topics_of(rec, WaterField)
    assert fields == ["/granite_pond/field", "/pine_pond/field"]
    assert body_water_topic(rec, "pine", fields) == "/pine_pond/field"
    assert body_water_topic(rec, "granite", fields) == "/granite_pond/field"


@pytest.mark.skipif(_ffmpeg() is None, reason="no ffmpeg (pip install -e '.[video]')")
def test_mp4_when_an_encoder_is_installed(skip_path, tmp_path):
    """With ffmpeg available, .mp4 output is an MP4 file."""
    out = tmp_path / "skip.mp4"
    render(skip_path, out, RenderOptions(fps=10, width=WIDTH, stop=0.2, progress=False))
    assert out.stat().st_size > 1000 and out.read_bytes()[4:8] == b"ftyp"


def test_mp4_without_an_encoder_says_what_to_install_from_the_checkout(skip_path, tmp_path, capsys, monkeypatch):
    """Without ffmpeg an .mp4 is bad input, one line naming what to install: imageio-ffmpeg, or the
    project's [video] extra from its folder (it said pip install 'cosim[video]', which asks the
    package index for a package of that name instead of this checkout). Nothing is written."""
    import components.analysis.render as render_module

    monkeypatch.setattr(render_module, "_ffmpeg", lambda: None)
    assert main(["render", str(skip_path), "-o", str(tmp_path / "skip.mp4"), "-q"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert "pip install imageio-ffmpeg" in err and "pip install -e '.[video]'" in err and "cosim[video]" not in err
    assert list(tmp_path.iterdir()) == []


def gif_delays_read_back(path) -> list[int]:
    """Each frame's delay [ms] as stored in the GIF at ``path``."""
    with Image.open(path) as im:
        delays = []
        for i in range(im.n_frames):
            im.seek(i)
            delays.append(im.info["duration"])
    return delays


@pytest.mark.parametrize(("fps", "speed", "start", "stop"), [(50, 1.0, 0.0, 0.5), (30, 0.25, 0.0, 0.1),
                                                             (24, 0.5, 0.1, 0.4)])
def test_a_gif_plays_at_the_speed_asked(skip_path, tmp_path, fps, speed, start, stop):
    """A GIF's frames last 1/fps each on the whole (its delays are whole centiseconds, none under 20
    ms, the rounding never adding up): the last frame appears (to - from) / speed after the first,
    to 10 ms. Before, every frame lasted round(1000 / fps) ms: 30 ms at 30 fps, 11% fast."""
    out = tmp_path / "speed.gif"
    result = render(skip_path, out, RenderOptions(fps=fps, speed=speed, start=start, stop=stop, width=WIDTH // 4,
                                                  progress=False))
    delays = gif_delays_read_back(out)
    assert len(delays) == result.frames
    assert all(d % 10 == 0 and d >= 20 for d in delays), delays
    assert abs(sum(delays) - 1000 * result.frames / fps) <= 10
    assert abs(sum(delays[:-1]) - 1000 * (result.stop - result.start) / speed) <= 10


def test_a_speed_that_leaves_one_frame_is_bad_input(skip_path, tmp_path, capsys):
    """--speed 100 at 30 frames a second puts 3.3 s of the run between frames: the video would be the
    run's first frame alone (it was written, a GIF of t = 0). Exit 2 saying the speed that gives three
    frames, nothing written; frame_times itself never gives one frame for a span."""
    out = tmp_path / "fast.gif"
    assert main(["render", str(skip_path), "-o", str(out), "--speed", "100"]) == 2
    said = capsys.readouterr().err
    assert "error: --speed 100 at --fps 30 puts 3.33333 s of the run between frames" in said
    assert "for three frames" in said
    assert not out.exists()
    with pytest.raises(RenderError):
        frame_times(0.0, 0.5, 10, 10.0)


def test_a_gif_faster_than_50_frames_a_second_is_bad_input(skip_path, tmp_path, capsys):
    """A GIF cannot play more than 50 frames a second: --fps 120 exits 2 naming the limit and the
    value, and writes nothing. Before, it wrote 20 ms frames, 2.4 times too slow."""
    out = tmp_path / "fast.gif"
    assert main(["render", str(skip_path), "-o", str(out), "--fps", "120", "--to", "0.1", "-q"]) == 2
    err = capsys.readouterr().err.strip()
    assert "--fps must be at most 50 for a GIF" in err and "got 120" in err and ".mp4" in err
    assert len(err.splitlines()) == 1 and not out.exists()


def test_a_body_under_water_is_drawn_with_the_surface_above_it(tmp_path):
    """The granite ball resting on the pond's bed, 30 cm down, is drawn under the water: the follow
    view reaches up to the surface, so water is drawn above the ball. Before, the view held the
    ball alone and no water was drawn, though the header said "into the water"."""
    from cosim.runner import run_scene
    from cosim.scenario import load

    scene = Path(__file__).resolve().parents[1] / "scenarios" / "float_sphere.yaml"
    path = tmp_path / "float.mcap"
    run_scene(load(scene, ["until=0.6"]), path, progress=False)  # the ball rests on the bed from 0.43 s
    out = tmp_path / "sunk.png"
    render(path, out, RenderOptions(width=WIDTH, at=0.6, progress=False))
    image = np.asarray(Image.open(out).convert("RGB"), dtype=float) / 255
    below_header = image[int(0.12 * image.shape[0]):]
    ball_rows = np.nonzero(((below_header[..., 0] - below_header[..., 2]) > 0.1).any(axis=1))[0]
    assert len(ball_rows), "no ball drawn"
    water = (below_header[: ball_rows.min()][..., 2] - below_header[: ball_rows.min()][..., 0]) > 0.2
    assert water.mean() > 0.1  # the surface, above the ball


def test_frame_times_step_by_speed_over_fps():
    """Frames are speed/fps seconds of simulation apart, ending on the last whole step."""
    assert np.allclose(frame_times(0.0, 1.0, 10, 1.0), np.arange(11) / 10)
    assert np.allclose(frame_times(0.0, 0.1, 10, 0.25), np.arange(5) * 0.025)


def test_the_disk_is_drawn_turned_by_its_quaternion():
    """Body polygons are the disk's faces rotated by the recorded quaternion and moved to its position."""
    from tests.viewer_toys import ScriptedStone

    stone = ScriptedStone("s", ScriptedStone.Params(attack_deg=30.0, spin=0.0))
    state = stone.state_at(0.0)
    from components.analysis.data import BodyTrack

    body = BodyTrack("/s/state", np.zeros(1), state.position[None], state.velocity[None],
                     state.orientation[None], np.zeros(1), np.zeros(1), np.zeros(1), np.zeros(1),
                     int(state.shape), state.radius, state.thickness, state.mass)
    polys = body_polygons(body, state.position, state.orientation)
    assert {len(poly) for poly in polys} == {3}
    top = np.concatenate(polys[0::4])  # the top face's triangles
    normal = np.cross(polys[0][1] - polys[0][0], polys[0][2] - polys[0][0])
    normal /= np.linalg.norm(normal)
    assert np.isclose(np.degrees(np.arccos(abs(normal[2]))), 30.0)
    axis = rotation_matrix(state.orientation)[:, 2]
    assert np.allclose(top.mean(axis=0), state.position + axis * state.thickness / 2)


def test_the_surface_is_cropped_to_the_view_and_decimated():
    """Cropping keeps the cells inside the view (plus one) with their exact heights, at most 64 a side."""
    from components.messages import WaterField

    h = np.arange(300 * 200, dtype=float).reshape(200, 300)
    field = WaterField(0.01, 0.0, 0.0, h, 0.0, 0.0)
    gx, gy, gz = crop_field(field, (0.5, 1.0), (0.2, 0.4))
    assert gz.shape == (23, 53)  # rows 19..41 and columns 49..101: the view plus one cell
    i, j = np.rint(gx / 0.01).astype(int), np.rint(gy / 0.01).astype(int)
    assert np.array_equal(gz, h[j, i])
    assert crop_field(field, (5.0, 6.0), (0.0, 1.0)) is None
    gx, gy, gz = crop_field(field, (0.0, 3.0), (0.0, 2.0))
    assert gz.shape == (64, 64)


def test_the_gap_to_the_water_is_measured_from_the_lowest_point():
    """The height written in a frame is the body's lowest point above the water under it, negative
    (into the water) when that point is below the surface."""
    from components.analysis.render import Surface, height_above_water, height_caption

    cube = np.array([[[0.0, 0.0, 0.05], [0.1, 0.0, 0.07], [0.0, 0.1, 0.09]]])
    gx, gy = np.meshgrid([-1.0, 0.0, 1.0], [-1.0, 0.0, 1.0])
    surface = Surface(gx, gy, np.full(gx.shape, 0.01), np.zeros((*gx.shape, 3)))
    assert height_above_water(cube, surface, rest=0.0) == pytest.approx(0.04)
    assert height_above_water(cube, None, rest=0.06) == pytest.approx(-0.01)
    assert height_caption(0.032) == "3.2 cm above the water"
    assert height_caption(-0.011) == "1.1 cm into the water"


def test_a_frame_in_flight_says_how_high_the_stone_is_and_shows_its_shadow(skip_path):
    """Between two skips the frame's caption gives the recorded gap between the stone's lowest point
    and the water, and the water straight under the stone is darkened by its shadow."""
    from components.analysis.data import load_body, rest_level
    from components.analysis.render import FrameRenderer
    from cosim.record.reader import Recording

    rec = Recording(skip_path)
    body = load_body(rec)
    renderer = FrameRenderer(body, RenderOptions(width=WIDTH), rest_level(rec), "skip")
    i = body.index_at(0.2)  # in flight after the first skip
    lowest = body.position[i, 2] - body.radius * np.sin(np.radians(abs(body.attack_deg[i]))) - body.thickness
    frame = renderer.draw(0.2, None).astype(float) / 255
    assert renderer.caption.endswith("cm above the water")
    gap_cm = float(renderer.caption.split()[0])
    assert abs(gap_cm - 100 * (lowest - rest_level(rec))) < 1.0
    water = frame[int(0.6 * frame.shape[0]):, :, :]  # the near water, well below the stone
    shadow_rows = frame[int(0.12 * frame.shape[0]):int(0.6 * frame.shape[0]), WIDTH // 2 - 5:WIDTH // 2 + 5]
    blue = (water[..., 2] - water[..., 0]) > 0.2
    water_brightness = water[blue].sum(axis=-1).mean()
    shaded = (shadow_rows[..., 2] - shadow_rows[..., 0] > 0.1) & (shadow_rows.sum(axis=-1) < 0.85 * water_brightness)
    assert shaded.sum() >= 5, "no shadow under the stone"


def test_a_scene_without_water_draws_no_water(tmp_path):
    """A bounce on a floor (no water in the scene) gets no water surface nor a gap 'to the water'."""
    from pathlib import Path

    from components.analysis.data import load_body, rest_level
    from components.analysis.render import FrameRenderer
    from cosim.record.reader import Recording
    from cosim.runner import run_scene
    from cosim.scenario import load

    scene = Path(__file__).resolve().parents[1] / "scenarios" / "ground_bounce.yaml"
    path = tmp_path / "bounce.mcap"
    run_scene(load(scene, ["until=0.3", "record.visual_rate=0"]), path, progress=False)
    out = tmp_path / "bounce.png"
    render(path, out, RenderOptions(width=WIDTH, at=0.25, progress=False))
    image = np.asarray(Image.open(out).convert("RGB"), dtype=float) / 255
    assert ((image[..., 2] - image[..., 0]) > 0.2).mean() < 0.01  # no blue water
    rec = Recording(path)
    renderer = FrameRenderer(load_body(rec), RenderOptions(width=WIDTH), rest_level(rec), "bounce", has_water=False)
    renderer.draw(0.25, None)
    assert "water" not in renderer.caption and renderer.caption.startswith("at z = ")


def test_the_solid_ground_a_body_meets_is_drawn_and_no_other(tmp_path):
    """scenarios/ramp_slide.yaml: the frame of the sliding disk shows its ramp, sand under and around
    the disk (it was drawn sliding over nothing); a skip's frames, with no ground, show no sand. Only
    the ramp its body meets: the other ramp's plane would cut through the frame."""
    from components.analysis.data import ground_planes
    from components.analysis.render import GROUND_FILL
    from cosim.record.reader import Recording
    from cosim.runner import run_scene
    from cosim.scenario import load

    scene = Path(__file__).resolve().parents[1] / "scenarios" / "ramp_slide.yaml"
    path = tmp_path / "ramp.mcap"
    run_scene(load(scene, ["until=1.5", "record.visual_rate=0"]), path, progress=False)
    rec = Recording(path)
    (normal, point), = ground_planes(rec, "disk_slides")
    assert point == (0.0, 0.3, 0.0) and normal[0] == pytest.approx(np.sin(np.radians(35.0)))
    out = tmp_path / "ramp.png"
    render(path, out, RenderOptions(width=WIDTH, at=1.0, body="disk_slides", progress=False))
    sand = np.all(np.asarray(Image.open(out).convert("RGB")) == GROUND_FILL, axis=-1)
    assert sand.mean() > 0.1
    # within the box: the plane over the box's floor, uncut in height, ran off the frame's bottom
    assert not sand[:sand.shape[0] // 20].any() and not sand[-1].any()
    rows, cols = np.nonzero(sand)
    middle = sand.shape[0] // 2, sand.shape[1] // 2  # the follow view keeps the disk near the middle
    assert rows.min() < middle[0] < rows.max() and cols.min() < middle[1] < cols.max()
    out = tmp_path / "skip.png"
    record_skip(tmp_path / "skip.mcap")
    render(tmp_path / "skip.mcap", out, RenderOptions(width=WIDTH, at=0.2, progress=False))
    assert not np.all(np.asarray(Image.open(out).convert("RGB")) == GROUND_FILL, axis=-1).any()


def test_a_recording_without_the_waters_surface_is_drawn_flat_and_said_so(tmp_path):
    """The held skip recorded with its pond's field_rate 0 (as the sweeps' scenes record): the frame
    draws flat water at the rest level, and a warning says why (it drew calm water after a skip
    without a word)."""
    from components.analysis.render import RenderWarning
    from cosim.runner import run_scene
    from cosim.scenario import load

    scene = Path(__file__).resolve().parents[1] / "scenarios" / "held_skip.yaml"
    run_scene(load(scene, ["components.pond.field_rate=0", "until=0.3", "record.visual_rate=0"]),
              tmp_path / "skip.mcap", progress=False)
    with pytest.warns(RenderWarning, match=r"holds no water surface .*: the water is drawn flat at its rest level"):
        render(tmp_path / "skip.mcap", tmp_path / "flat.png", RenderOptions(width=WIDTH, at=0.2, progress=False))


def test_water_alone_is_drawn_whole_with_its_waves_moving(tmp_path, capsys):
    """A recording without a body (the wave pulse) is drawn as the whole surface: water covers a good
    part of the frame, and the spreading ring moves between frames. Before, render refused it
    (no BodyState channel)."""
    from pathlib import Path

    from cosim.runner import run_scene
    from cosim.scenario import load

    scene = Path(__file__).resolve().parents[1] / "scenarios" / "wave_pulse.yaml"
    path = tmp_path / "pulse.mcap"
    run_scene(load(scene, ["until=0.3"]), path, progress=False)
    out = tmp_path / "pulse.gif"
    result = render(path, out, RenderOptions(width=WIDTH, fps=10, progress=False))
    frames = gif_frames(out)
    assert result.frames == len(frames) == len(frame_times(0.0, 0.3, 10, 1.0))
    water = (frames[0][..., 2] - frames[0][..., 0]) > 0.2
    assert water.mean() > 0.2
    assert np.abs(frames[-1] - frames[0]).max() > 0.1  # the pulse has spread into a ring
    assert main(["render", str(path), "-o", str(tmp_path / "pulse.png"), "--width", str(WIDTH), "-q"]) == 0
    assert "wrote" in capsys.readouterr().out


def test_a_recording_without_body_or_water_is_one_line(tmp_path, capsys):
    from pathlib import Path

    from cosim.runner import run_scene
    from cosim.scenario import load

    scene = Path(__file__).resolve().parents[1] / "scenarios" / "ping_pong.yaml"
    path = tmp_path / "pp.mcap"
    run_scene(load(scene, ["until=0.01"]), path, progress=False)
    assert main(["render", str(path), "-o", str(tmp_path / "pp.png"), "-q"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("error: ") and "no BodyState or WaterField channel, nothing to show" in err
    assert len(err.splitlines()) == 1


RAISED_PINE = ["until=0.05", "record.visual_rate=0", "components.pine_pond.rest_level=0.5",
               "components.pine_water.water_level=0.5", "components.pine.position=[0,0,0.53]"]


@pytest.fixture(scope="module")
def raised_path(tmp_path_factory):
    """float_sphere with the pine's pond raised to z = 0.5 m (the granite's stays at 0)."""
    from cosim.runner import run_scene
    from cosim.scenario import load

    scene = Path(__file__).resolve().parents[1] / "scenarios" / "float_sphere.yaml"
    path = tmp_path_factory.mktemp("raised") / "raised.mcap"
    return run_scene(load(scene, RAISED_PINE), path, progress=False).recording


def test_a_body_is_drawn_against_its_own_waters_level(raised_path, tmp_path, monkeypatch):
    """The frames of a body measure it against the level of the water it meets: the pine's pond, at
    z = 0.5 m, not the first pond by name (the granite's, at 0), which made the follow view reach
    down to z = 0 and a flat surface or a gap be drawn there."""
    from components.analysis import render as render_module

    levels = []

    class Spy(render_module.FrameRenderer):
        def __init__(self, body, options, rest, *args, **kwargs):
            levels.append((body.name, rest))
            super().__init__(body, options, rest, *args, **kwargs)

    monkeypatch.setattr(render_module, "FrameRenderer", Spy)
    render(raised_path, tmp_path / "pine.png", RenderOptions(width=WIDTH, at=0.04, body="pine", progress=False))
    render(raised_path, tmp_path / "granite.png", RenderOptions(width=WIDTH, at=0.04, body="granite", progress=False))
    assert levels == [("pine", 0.5), ("granite", 0.0)]


def test_water_alone_is_drawn_about_the_level_of_the_water_shown(tmp_path, monkeypatch):
    """Water alone, two ponds at two levels: the frames of --water /b_high/field are drawn about its
    own level (0.5 m), not the first pond's by name."""
    from components.analysis import render as render_module
    from cosim.runner import run_scene
    from cosim.scenario import loads

    pond = "{type: WaterSurface, nx: 12, ny: 12, cell: 0.02, depth: 0.1, field_rate: 100"
    scene = loads(f"dt: 0.001\nuntil: 0.02\ncomponents:\n  a_low: {pond}}}\n"
                  f"  b_high: {pond}, rest_level: 0.5, origin_x: 1.0}}\n")
    path = run_scene(scene, tmp_path / "ponds.mcap", progress=False).recording
    levels = []

    class Spy(render_module.WaterRenderer):
        def __init__(self, first, swing, options, rest, title):
            levels.append(rest)
            super().__init__(first, swing, options, rest, title)

    monkeypatch.setattr(render_module, "WaterRenderer", Spy)
    render(path, tmp_path / "high.png", RenderOptions(width=WIDTH, water="/b_high/field", progress=False))
    render(path, tmp_path / "low.png", RenderOptions(width=WIDTH, progress=False))
    assert levels == [0.5, 0.0]


def test_a_chosen_water_that_no_frame_shows_is_warned_of(raised_path, tmp_path):
    """--water naming a pond that lies outside every frame's view (the granite's, 2 m from the pine)
    is a warning naming it, its extent, the flat surface drawn instead and the water the body meets;
    the frames are still written. Before, a flat plane was drawn without a word."""
    from components.analysis.render import RenderWarning

    out = tmp_path / "pine.png"
    with pytest.warns(RenderWarning) as caught:
        render(raised_path, out, RenderOptions(width=WIDTH, at=0.04, body="pine", water="/granite_pond/field",
                                               progress=False))
    assert [str(w.message) for w in caught] == [
        "--water /granite_pond/field: no frame of pine has that water (x 1.7 .. 2.3 m, y -0.3 .. 0.3 m) in view; "
        "the frames show a flat surface at z = 0.5 m instead; leave --water out to draw /pine_pond/field, "
        "the water pine meets"]
    assert out.is_file()
    render(raised_path, out, RenderOptions(width=WIDTH, at=0.04, body="pine", water="/pine_pond/field",
                                           progress=False))  # in view: no warning (an error in this suite)


def test_an_output_under_a_file_names_that_file(skip_path, capsys):
    """-o run.mcap/x.png, where run.mcap is a file: exit 2, one line saying that run.mcap is a file,
    not a folder (it said 'File exists'), and the recording untouched."""
    before = skip_path.read_bytes()
    assert main(["render", str(skip_path), "-o", str(skip_path / "x.png"), "--width", str(WIDTH), "-q"]) == 2
    err = capsys.readouterr().err.strip()
    assert err == f"error: {skip_path / 'x.png'}: cannot be made: {skip_path} is a file, not a folder"
    assert skip_path.read_bytes() == before


def test_a_stone_beside_the_pond_is_said_to_be_beside_it_not_in_the_water(skip_path):
    """A frame whose stone has come down beside the pond (its lowest point outside the water's grid)
    gives the gap to the water's level beside the pond: "4.1 cm into the water" was said of a stone
    that had left a 3 m pond at x = 3.65 m, over no water."""
    from components.analysis.data import load_body, rest_level
    from components.analysis.render import FrameRenderer, beside_the_pond, height_caption
    from cosim.record.reader import Recording

    assert height_caption(-0.041, beside=True) == "4.1 cm below the water's level, beside the pond"
    rec = Recording(skip_path)
    body = load_body(rec)
    renderer = FrameRenderer(body, RenderOptions(width=WIDTH), rest_level(rec), "skip")
    i = body.index_at(0.2)
    x = float(body.position[i, 0])
    renderer.extent = (x + 1.0, x + 5.0, -1.0, 1.0)  # the pond begins a metre past the stone
    renderer.draw(0.2, None)
    assert renderer.caption.endswith("cm above the water's level, beside the pond")
    renderer.extent = (x - 5.0, x + 5.0, -10.0, 10.0)  # the stone over the pond
    renderer.draw(0.2, None)
    assert renderer.caption.endswith("cm above the water")
    polys = np.array([[[0.0, 0.0, 0.0], [0.1, 0.0, 0.0], [0.0, 0.1, 0.01]]])
    assert beside_the_pond(polys, (0.5, 1.0, -1.0, 1.0)) and not beside_the_pond(polys, (-1.0, 1.0, -1.0, 1.0))
    assert not beside_the_pond(polys, None)


def test_the_gap_is_the_one_reported_at_the_frames_time_not_the_drawn_fields(skip_path):
    """The surface drawn is the last field recorded (a few times a second): its gap to the stone
    could be up to a field's interval old (6.2 cm said where the stone was 5.4 cm in). The caption
    takes the gap the body's coupler reported at the frame's time, and the header says how old the
    water drawn is; with no report of that time (the coupler quiet, far above the water) the gap is
    measured to the water drawn, as before."""
    from components.analysis.data import load_body, rest_level
    from components.analysis.render import FrameRenderer
    from cosim.record.reader import Recording

    rec = Recording(skip_path)
    body = load_body(rec)
    depths = (np.array([0.1, 0.2]), np.array([-0.031, 0.054]))  # 3.1 cm above, then 5.4 cm in
    renderer = FrameRenderer(body, RenderOptions(width=WIDTH), rest_level(rec), "skip", depths=depths, step=0.0005)
    renderer.draw(0.2, None)
    assert renderer.caption == "5.4 cm into the water"
    renderer.draw(0.1004, None)
    assert renderer.caption == "3.1 cm above the water"
    renderer.draw(0.15, None)  # the last report 50 ms old: measured to the (rest) water instead
    far = FrameRenderer(body, RenderOptions(width=WIDTH), rest_level(rec), "skip",
                        depths=(np.array([0.15]), np.array([np.nan])), step=0.0005)
    far.draw(0.15, None)  # a dry report (its depth left out): measured to the water drawn
    plain = FrameRenderer(body, RenderOptions(width=WIDTH), rest_level(rec), "skip")
    plain.draw(0.15, None)
    assert renderer.caption == plain.caption == far.caption
    # a gap of a million kilometres (a stand-in depth): its drop line is drawn across the frame only
    # (its dashes were drawn one by one over the whole length: the render never ended)
    huge = FrameRenderer(body, RenderOptions(width=WIDTH), rest_level(rec), "skip",
                         depths=(np.array([0.2]), np.array([-1e9])), step=0.0005)
    huge.draw(0.2, None)
    assert huge.caption == "100000000000.0 cm above the water"
    assert FrameRenderer._field_age(0.17, 0.1) == "  (water drawn as at t = 0.100 s)"
    assert FrameRenderer._field_age(0.1, 0.1) == ""


@pytest.mark.parametrize("scene", ["held_skip", "ricochet"])
def test_the_default_picture_shows_the_stone_leaving_the_water(scene, tmp_path):
    """--at's default is "as the stone leaves the water after its first skip", snapped to a recorded
    water field: the nearest one, before the take-off, showed the stone still sliding in the water
    (the ricochet's 4 ms before it, the held skip's 4.5 ms). Now the first field at or after it."""
    from components.analysis.render import FIELD_SNAP
    from components.messages import SkipRecord
    from cosim.record.reader import Recording

    recording = tmp_path / f"{scene}.mcap"
    assert main(["run", str(Path(__file__).resolve().parents[1] / "scenarios" / f"{scene}.yaml"), "-q",
                 "-o", str(recording), "--set", "until=0.3"]) == 0
    rec = Recording(recording)
    _, first = rec.messages("/stages/skip", SkipRecord)[0]
    take_off = first.touchdown_time + first.contact_time
    result = render(recording, tmp_path / "default.png", RenderOptions(width=WIDTH))
    assert take_off <= result.start <= take_off + FIELD_SNAP


def test_a_frame_drawn_from_an_older_state_says_so():
    """In a recording thinned with --record-every the frame at a stage change (kept) drew the stone
    of the last state kept, 4.5 ms before, with its gap ("fly-away ... 0.3 cm into the water") and
    said only the water's age; now the stone's too, when more than a step older."""
    import types

    from components.analysis.render import FrameRenderer

    renderer = types.SimpleNamespace(body_step=0.0005)
    assert FrameRenderer._state_age(renderer, 0.1045, 0.100) == "  (stone as at t = 0.100 s)"
    assert FrameRenderer._state_age(renderer, 0.1005, 0.100) == ""  # the state of the frame's step
    every_two = types.SimpleNamespace(body_step=0.001)  # a body stepping every second tick: no note
    assert FrameRenderer._state_age(every_two, 0.1009, 0.100) == ""


def test_a_recording_that_left_the_water_out_says_no_water_is_drawn(tmp_path):
    """A scene with water recorded with --record '/stone/*' rendered without water and without a
    word (plot says what it skips); now a warning says the water was left out."""
    from components.analysis.render import RenderWarning

    recording = tmp_path / "stone.mcap"
    assert main(["run", str(Path(__file__).resolve().parents[1] / "scenarios" / "held_skip.yaml"), "-q",
                 "-o", str(recording), "--set", "until=0.2", "--record", "/stone/*"]) == 0
    with pytest.warns(RenderWarning, match="the scene has water, but the recording holds none of its channels"):
        render(recording, tmp_path / "stone.png", RenderOptions(width=WIDTH))


def test_a_recording_whose_scene_cannot_be_read_is_not_said_to_have_water(tmp_path, monkeypatch):
    """A ground bounce's recording with its scene attachment spoilt was rendered with the warning
    that "the scene has water" but none was recorded: a scene that cannot be read says nothing."""
    import warnings

    from cosim.record.reader import Recording

    recording = tmp_path / "bounce.mcap"
    assert main(["run", str(Path(__file__).resolve().parents[1] / "scenarios" / "ground_bounce.yaml"), "-q",
                 "-o", str(recording), "--set", "until=0.2"]) == 0

    def unreadable(self):
        raise ValueError("the scene's YAML is spoilt")

    monkeypatch.setattr(Recording, "scene", unreadable)
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always")
        render(recording, tmp_path / "bounce.png", RenderOptions(width=WIDTH))
    assert not [w for w in said if "the scene has water" in str(w.message)]


def test_notes_that_would_run_past_the_frames_edge_go_to_its_foot():
    """A thinned recording's header with two notes ran past the frame's edge; the notes that do not
    fit go to the frame's foot, the header itself stays one line at the top."""
    import types

    from components.analysis.render import FrameRenderer

    class Draw:  # each character 10 px wide; the texts drawn kept with where they went
        def __init__(self):
            self.texts = []

        def textlength(self, text, font=None):
            return 10 * len(text)

        def text(self, xy, text, fill=None, font=None):
            self.texts.append((round(xy[1]), text))

    header = "skip: stone   t = 0.104 s   fly-away  (stone as at t = 0.100 s)  (water drawn as at t = 0.000 s)"
    wide, narrow = Draw(), Draw()
    FrameRenderer._header(types.SimpleNamespace(size=(2000, 450), text_px=10), wide, header, (0, 0, 0))
    assert wide.texts == [(5, header)]
    FrameRenderer._header(types.SimpleNamespace(size=(700, 450), text_px=10), narrow, header, (0, 0, 0))
    assert narrow.texts == [(5, "skip: stone   t = 0.104 s   fly-away  (stone as at t = 0.100 s)"),
                            (435, "(water drawn as at t = 0.000 s)")]


def test_the_water_at_rest_drawn_before_any_field_stops_at_the_ponds_edge(skip_path):
    """Before a water field is recorded (or where none covers the view), the water is drawn as a
    plane at rest: it ran across the whole view, 0.2 m past the pond's edge behind a stone thrown
    from 0.3 m; it now stops at the grid's edges, read from the recorded scene."""
    import types

    from components.analysis.render import _Frames, _View, _water_extent
    from cosim.record.reader import Recording

    rec = Recording(skip_path)
    pond = rec.scene().components["pond"].params
    assert _water_extent(rec, "/pond/field") == pytest.approx(
        (pond.origin_x - pond.cell / 2, pond.origin_x + (pond.nx - 0.5) * pond.cell,
         pond.origin_y - pond.cell / 2, pond.origin_y + (pond.ny - 0.5) * pond.cell))
    frames = types.SimpleNamespace(rest=0.0, extent=(-0.005, 8.0, -0.005, 1.0))
    plane = _Frames._surface(frames, None, 0.0, _View((-0.2, 0.8), (-0.5, 0.5), (-0.1, 0.1)))
    assert plane.gx.min() == pytest.approx(-0.005) and plane.gy.min() == pytest.approx(-0.005)
    assert plane.gx.max() == pytest.approx(0.8) and plane.gy.max() == pytest.approx(0.5)
    assert _Frames._surface(frames, None, 0.0, _View((-3.0, -1.0), (-0.5, 0.5), (-0.1, 0.1))) is None


def test_the_pond_beyond_a_recorded_fields_window_is_drawn_at_rest_and_said_so(skip_path):
    """A field recorded over a window of the pond (``field_window``) was drawn alone: the fixed view of
    the reference skip showed its first two skips over nothing. The pond around it, within the view,
    is now a plane at the rest level, the field's cells as recorded inside it, and the frame says so."""
    import types

    from components.analysis.render import FIXED_MIN_ZRATIO, FrameRenderer, _Frames, _View
    from components.messages import WaterField

    frames = types.SimpleNamespace(rest=0.0, extent=(-0.005, 8.0, -0.005, 1.0))
    frames._at_rest_around = types.MethodType(_Frames._at_rest_around, frames)
    height = np.linspace(-0.002, 0.002, 21 * 6).reshape(6, 21)  # x 4 to 6 m, y 0.3 to 0.8 m
    field = WaterField(cell=0.1, origin_x=4.0, origin_y=0.3, height=height, volume=1.0, energy=0.0)
    surface = _Frames._surface(frames, field, 0.0, _View((-0.2, 8.5), (-0.5, 1.5), (-0.1, 0.1)))
    assert surface.at_rest_beyond
    assert surface.gx[0, :].tolist() == pytest.approx([-0.005, *(4.0 + 0.1 * np.arange(21)), 8.0])
    assert surface.gy[:, 0].tolist() == pytest.approx([-0.005, *(0.3 + 0.1 * np.arange(6)), 1.0])
    assert np.array_equal(surface.gz[1:-1, 1:-1], height)
    assert (surface.gz[0] == 0.0).all() and (surface.gz[:, 0] == 0.0).all() and (surface.gz[:, -1] == 0.0).all()
    # a field that covers the view is drawn as it was
    whole = _Frames._surface(frames, field, 0.0, _View((4.5, 5.5), (0.45, 0.65), (-0.1, 0.1)))
    assert not whole.at_rest_beyond and whole.gz.shape == (4, 13)

    from components.analysis.data import load_body, rest_level
    from cosim.record.reader import Recording

    rec = Recording(skip_path)
    renderer = FrameRenderer(load_body(rec), RenderOptions(width=WIDTH, view="fixed"), rest_level(rec), "skip")
    view = renderer.view_at(0.2)
    renderer.extent = (*view.x, *view.y)
    mid = 0.5 * (view.x[0] + view.x[1])  # a field over the view's far half
    renderer.draw(0.2, WaterField(cell=0.05, origin_x=mid, origin_y=view.y[0], height=np.zeros((40, 40)),
                                  volume=1.0, energy=0.0))
    stretch = FIXED_MIN_ZRATIO * view.box[0] / view.box[2]  # the fixed view's heights, stretched
    assert stretch > 1.5
    assert renderer.header.endswith(f"(water beyond the recorded window drawn at rest)  (heights x {stretch:.1f})")
    renderer.draw(0.2, None)  # no field: the plane at rest is all there is, not said
    assert renderer.header.endswith(f"above the water  (heights x {stretch:.1f})")


def test_the_header_says_where_a_throw_not_along_x_is():
    """A throw along x is told by its x, as the summary tells its touchdowns; one along y by x and y
    (the header said "x = 0.50 m" at every frame of a throw along y)."""
    from types import SimpleNamespace

    from components.analysis.render import FrameRenderer

    along_x = SimpleNamespace(body=SimpleNamespace(velocity=np.array([[7.88, 0.0, -1.39]])))
    along_y = SimpleNamespace(body=SimpleNamespace(velocity=np.array([[0.0, 7.88, -1.39]])))
    pos = np.array([0.5, 3.56, 0.01])
    assert FrameRenderer._where(along_x, pos) == "x = 0.50 m"
    assert FrameRenderer._where(along_y, pos) == "at (0.50, 3.56) m"


def test_a_grounds_plane_is_drawn_within_the_boxs_height():
    """A steep ramp's plane over the box's floor reaches far above and below the box (a 80 deg ramp
    across a 1 m box: 11 m of height) and was drawn across the header and past the frame: it is cut
    to the box's height, its corners on the cut lines, and nothing is left of a plane wholly above."""
    from components.analysis.render import _clip_z

    slope = np.tan(np.radians(80.0))
    plane = np.array([[x, y, slope * (x - 0.5)] for x, y in ((0, 0), (1, 0), (1, 1), (0, 1))])
    cut = _clip_z(plane, -0.2, 0.3)
    assert cut[:, 2].min() == pytest.approx(-0.2) and cut[:, 2].max() == pytest.approx(0.3)
    # the band's width along x, 0.5 m of height over the slope, times its 1 m along y
    xs = sorted(set(np.round(cut[:, 0], 12)))
    assert xs[-1] - xs[0] == pytest.approx(0.5 / slope) and len(cut) == 4
    assert len(_clip_z(plane + np.array([0.0, 0.0, 10.0]), -0.2, 0.3)) < 3


def test_frame_times_are_written_to_the_recordings_step(tmp_path, capsys, monkeypatch):
    """The held skip (0.5 ms steps), one message in ten kept: the frame at the hit that began at
    0.0745 s says t = 0.0745 s, and so do the line render prints and the times of the stone and the
    water drawn older than it (each said 0.074 s, 0.070 s, 0.000 s: a step before the hit)."""
    from components.analysis import render as render_module

    recording = tmp_path / "held.mcap"
    scene = Path(__file__).resolve().parents[1] / "scenarios" / "held_skip.yaml"
    assert main(["run", str(scene), "-q", "-o", str(recording), "--set", "until=0.08",
                 "--set", "record.visual_rate=0", "--set", "record.every=10"]) == 0
    headers = []
    monkeypatch.setattr(render_module._Frames, "_header", lambda self, draw, text, color: headers.append(text))
    capsys.readouterr()
    assert main(["render", str(recording), "-o", str(tmp_path / "hit.png"), "--at", "0.0745", "--width", "320",
                 "-q"]) == 0
    assert "t = 0.0745 .. 0.0745 s)" in capsys.readouterr().out
    (header,) = headers
    assert "   t = 0.0745 s   hit   " in header
    assert "(stone as at t = 0.0700 s)" in header and "(water drawn as at t = 0.0000 s)" in header
