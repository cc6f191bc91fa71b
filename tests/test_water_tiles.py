"""Stepping the water by tiles (components.water.tiles): the dense step's result, bit for bit, at a
cost only where the water moves."""

from pathlib import Path

import numpy as np
import pytest

from components.messages import OccupiedHeight
from components.water import GaussianBump, WaterParams, WaterSurface
from components.water.diagnostics import energy, volume
from components.water.tiles import Tiles, _rescan_edges
from cosim.runner import run_scene
from cosim.scenario import load

NS = 10**9
DT_NS = 2_000_000  # a 2 ms water step, as the reference skip's
ROOT = Path(__file__).resolve().parents[1]


def pond(tile: int, **overrides) -> WaterSurface:
    """A pond stepped by tiles of ``tile`` cells (0: densely); only exact zeros rest unless
    ``rest_below`` is given, so that the tiled step is the dense one bit for bit."""
    params = dict(nx=160, ny=70, cell=0.01, depth=0.5, boundary="absorbing", tile=tile, rest_below=0.0) | overrides
    return WaterSurface("pond", WaterParams(**params))


def stone_input(k: int) -> OccupiedHeight | None:
    """A small body sliding along x, pressing in and out, from step 20 to step 120 (then gone)."""
    if not 20 <= k < 120:
        return None if k < 20 else OccupiedHeight(i0=0, j0=0, b=np.zeros((0, 0)))
    return OccupiedHeight(i0=30 + k // 4, j0=30, b=np.full((4, 6), 2e-3 * (1 + k % 5)))


def run(surface: WaterSurface, steps: int, inputs=lambda k: None) -> WaterSurface:
    for k in range(steps):
        surface.step(k * DT_NS, DT_NS, {"occupied": inputs(k), "request": None})
    return surface


CASES = {
    "reflecting": dict(boundary="reflecting"),
    "absorbing": dict(boundary="absorbing"),
    "absorbing with a sponge": dict(boundary="absorbing", sponge_cells=6),
    "damped": dict(boundary="reflecting", damping=0.8),
    "tiles not dividing the grid": dict(boundary="absorbing", nx=150, ny=67),
}


@pytest.mark.parametrize("case", CASES, ids=list(CASES))
def test_a_stone_throw_tiled_is_the_dense_step_bit_for_bit(case):
    """A body pressing in, sliding and leaving: h, v and the volume equal the dense step's exactly."""
    dense = run(pond(0, **CASES[case]), 220, stone_input)
    tiled = run(pond(16, **CASES[case]), 220, stone_input)
    assert dense.tiles is None and tiled.tiles is not None
    assert np.array_equal(tiled.get_state()["h"], dense.get_state()["h"])
    assert np.array_equal(tiled.get_state()["v"], dense.get_state()["v"])
    assert tiled.volume() == pytest.approx(dense.volume(), rel=1e-14)  # the same columns, summed by tiles


@pytest.mark.parametrize("tile", [1, 3, 5])
def test_absorbing_edges_visit_only_moving_tiles_and_match_the_dense_step(tile):
    """The absorbing edges (one-way condition and sponge) of a tiled step visit only the tiles that
    may hold moving water; with tiles of 1, 3 and 5 cells on a 151 x 67 grid (a last tile one or
    two cells wide, so an edge cell's inner neighbour lies in another tile) the waves reach the
    edges, which were at rest, and the state is the dense step's exactly."""
    edges = dict(boundary="absorbing", sponge_cells=4, nx=151, ny=67)
    dense = run(pond(0, **edges), 220, stone_input)
    tiled = run(pond(tile, **edges), 220, stone_input)
    assert np.array_equal(tiled.get_state()["h"], dense.get_state()["h"])
    assert np.array_equal(tiled.get_state()["v"], dense.get_state()["v"])
    assert 0.0 < tiled.tiles.mean_fraction() < 1.0  # some of the edge was at rest some of the time


@pytest.mark.parametrize(("cell", "corner"), [((2, 1), (0, 0)), ((1, 2), (0, 0)), ((2, 6), (0, 7)),
                                             ((6, 5), (7, 7)), ((5, 1), (7, 0))])
def test_a_corner_moved_only_through_the_cell_diagonally_inside_it_matches_the_dense_step(cell, corner):
    """With tiles of one cell, a corner's edge condition reads its neighbour's new value, which
    reads the cell diagonally inside the corner: water set next to that cell moves the corner in
    the very first step although no tile beside the corner was stepped."""
    h = np.zeros((8, 8))
    h[cell] = 1e-3
    states = []
    for tile in (0, 1):
        surface = pond(tile, nx=8, ny=8)
        surface.set_state(surface.get_state() | {"h": h})
        states.append(run(surface, 1).get_state())
    assert states[0]["h"][corner] != 0.0  # the dense step moves the corner in the first step
    assert np.array_equal(states[1]["h"], states[0]["h"])
    assert np.array_equal(states[1]["v"], states[0]["v"])


@pytest.mark.parametrize("cell", [(0, 9), (20, 0), (20, 29), (22, 13), (1, 28)])
def test_the_edge_rescan_finds_what_an_edge_condition_wrote_into_a_tile_flagged_at_rest(cell):
    """After the edge condition, a tile the step left flagged at rest is read in its band of edge
    cells only, and flagged moving if one of them now moves; a tile flagged moving is read whole and
    flagged at rest if the condition brought it to rest. Tiles of 8 on a 23 x 30 grid (a last row
    and column of narrower tiles), a band of 2 cells."""
    h, v = np.zeros((23, 30)), np.zeros((23, 30))
    h[cell] = 1e-6
    everywhere = np.ones((3, 4), dtype=np.bool_)
    flags = np.zeros((3, 4), dtype=np.bool_)
    _rescan_edges(h, v, 8, flags, everywhere, 2)
    expected = np.zeros((3, 4), dtype=np.bool_)
    expected[cell[0] // 8, cell[1] // 8] = True
    assert np.array_equal(flags, expected)
    h[cell] = 0.0
    _rescan_edges(h, v, 8, flags, everywhere, 2)
    assert not flags.any()


def test_a_bump_tiled_is_the_dense_step_bit_for_bit():
    """An initial bump spreading to the edges gives the dense field exactly, step after step."""
    bump = dict(initial=GaussianBump(x=0.4, y=0.3, amplitude=2e-3, width=0.02), boundary="reflecting")
    dense, tiled = pond(0, **bump), pond(16, **bump)
    for k in range(150):
        run(dense, 1), run(tiled, 1)
        if k % 30 == 0:
            assert np.array_equal(tiled.get_state()["h"], dense.get_state()["h"])
    assert np.array_equal(tiled.get_state()["v"], dense.get_state()["v"])


def test_a_tile_at_rest_costs_nothing():
    """Water at rest steps no tile at all; a touch wakes its tile and the four around it only."""
    still = run(pond(16), 10)
    assert still.tiles.stepped == 0 and still.active_fraction() == 0.0
    surface = pond(16)
    surface.step(0, DT_NS, {"occupied": OccupiedHeight(i0=40, j0=40, b=np.full((2, 2), 1e-3)), "request": None})
    assert surface.tiles.last == 5  # tile (2, 2) and its four neighbours, of 10 x 5 tiles
    assert surface.tiles.count == 50


def test_the_wave_wakes_tiles_only_as_it_reaches_them():
    """A small bump in one corner: far tiles stay at rest for the first steps, then wake."""
    corner = dict(initial=GaussianBump(x=0.05, y=0.05, amplitude=1e-3, width=0.004), boundary="reflecting",
                  nx=320, ny=160)
    surface = pond(16, **corner)
    run(surface, 3)
    first = surface.tiles.last
    assert 0 < first < surface.tiles.count // 4
    run(surface, 200)
    assert surface.tiles.last > first
    assert surface.tiles.peak_fraction() >= surface.tiles.mean_fraction() > 0.0


def test_the_summary_and_the_field_say_how_much_water_was_active():
    """The summary line names the active share (peak and mean); the field carries the last one."""
    surface = run(pond(16, field_every=1), 40, stone_input)
    (line,) = surface.summary()
    assert "active water" in line and "at most" in line and "on average" in line
    field = surface.step(40 * DT_NS, DT_NS, {"occupied": None, "request": None})["field"]
    assert field.active_fraction == surface.active_fraction()
    assert 0.0 < field.active_fraction < 1.0
    dense = run(pond(0, field_every=1), 2)
    assert "active fraction 1" in dense.summary()[0]


@pytest.mark.parametrize("settings", [dict(model="shallow_water"), dict(smoothing=2.0),
                                      dict(bottom_slope=(0.1, 0.0)), dict(backend="numpy"),
                                      dict(parallel=True)])
def test_the_paths_where_tiling_is_not_exact_step_every_column(settings):
    """Implicit shallow water, smoothing, a sloped bed and the reference or parallel kernels stay dense."""
    assert pond(16, **settings).tiles is None


def test_a_state_set_from_outside_is_stepped_where_it_moves():
    """set_state: the tiles follow the given field (and the result is still the dense one)."""
    dense, tiled = pond(0), pond(16)
    h = np.zeros((70, 160))
    h[10:14, 100:104] = 1e-3
    for surface in (dense, tiled):
        surface.set_state(surface.get_state() | {"h": h})
    run(dense, 60), run(tiled, 60)
    assert np.array_equal(tiled.get_state()["h"], dense.get_state()["h"])
    assert 0 < tiled.tiles.mean_fraction() < 1


def test_touch_marks_the_tiles_of_a_window():
    """Cells [j0:j1, i0:i1] mark exactly the tiles they overlap."""
    tiles = Tiles((70, 160), 16)
    tiles.touch(15, 17, 31, 33)
    assert sorted(zip(*np.nonzero(tiles.nz), strict=True)) == [(1, 0), (1, 1), (2, 0), (2, 1)]


def test_the_reference_skip_tiled_is_the_dense_skip():
    """The coupled throw (stone, coupler, water) over its first skips: the stone's state is the same
    bit for bit whether the pond is stepped by tiles (only exact zeros resting) or densely."""
    finals = []
    for tile in (0, 32):
        scene = load(ROOT / "scenarios" / "skip.yaml",
                     overrides=["until=0.45", "components.pond.field_rate=0", f"components.pond.tile={tile}",
                                "components.pond.rest_below=0"])
        outcome = run_scene(scene, None, progress=False)
        stone = outcome.simulation.components["stone"].get_state()
        water = outcome.simulation.components["pond"].get_state()
        finals.append((stone, water["h"]))
    (stone_d, h_d), (stone_t, h_t) = finals
    assert np.array_equal(h_d, h_t)
    for key, value in stone_d.items():
        assert np.array_equal(np.asarray(value), np.asarray(stone_t[key])), key


@pytest.mark.parametrize("boundary", ["absorbing", "reflecting"])
def test_the_precursor_rests_below_rest_below_and_the_water_stays_the_dense_waters(boundary):
    """On water as slow as a stone's ripples (0.4 m/s) most of the tiles the explicit step's vanishing
    precursor reaches hold nothing above 1e-30 m. The default ``rest_below`` sets them to rest: the
    tiled step then steps far fewer tiles than with exact rest, and every column is still the dense
    step's to round-off (a wave set to rest by mistake would be off by its whole height), the volume
    its own to 1e-14."""
    slow = dict(nx=320, ny=160, wave_speed=0.4, boundary=boundary,
                initial=GaussianBump(x=0.5, y=0.8, amplitude=2e-3, width=0.03))
    dense, exact = pond(0, **slow), pond(16, **slow)
    resting = pond(16, **slow, rest_below=WaterParams().rest_below)
    for surface in (dense, exact, resting):
        run(surface, 300)
    assert WaterParams().rest_below == 1e-30
    assert resting.tiles.stepped < 0.6 * exact.tiles.stepped
    h, v = dense.get_state()["h"], dense.get_state()["v"]
    assert np.abs(resting.get_state()["h"] - h).max() <= 1e-15 * np.abs(h).max()
    assert np.abs(resting.get_state()["v"] - v).max() <= 1e-15 * np.abs(v).max()
    assert resting.volume() == pytest.approx(dense.volume(), rel=1e-14)


def test_the_held_skip_with_its_resting_tiles_is_the_dense_skip():
    """The held skip as its scene is (tiles, ``rest_below`` 1e-30 m, its ripple-speed water) and
    stepped densely: the same four skips and the stone's state at the end the same bit for bit,
    since the planing law reads the water the stone met, not the far water's round-off."""
    finals = []
    for tile in (0, 32):
        scene = load(ROOT / "scenarios" / "held_skip.yaml",
                     overrides=["components.pond.field_rate=0", f"components.pond.tile={tile}"])
        outcome = run_scene(scene, None, progress=False)
        sim = outcome.simulation
        finals.append((sim.components["stone"].get_state(), sim.components["stages"].track.skips))
    (stone_d, skips_d), (stone_t, skips_t) = finals
    assert skips_d == skips_t == 4
    for key, value in stone_d.items():
        assert np.array_equal(np.asarray(value), np.asarray(stone_t[key])), key


def test_the_field_window_follows_the_water_a_body_asks_for():
    """With field_window the field is that size around the last request, inside the grid, its
    corner on whole steps; the heights are the surface's own there."""
    from components.messages import PatchRequest

    surface = pond(16, nx=400, ny=100, field_every=1, field_window=(0.64, 0.32))
    field = surface.step(0, DT_NS, {"occupied": None, "request": None})["field"]
    assert field.height.shape == (32, 64)  # before any request: around the grid's centre
    request = PatchRequest(x_min=3.0, x_max=3.1, y_min=0.0, y_max=0.05)
    field = surface.step(DT_NS, DT_NS, {"occupied": stone_input(30), "request": request})["field"]
    i0, i1, j0, j1 = surface.field_window()
    assert (i1 - i0, j1 - j0) == (64, 32) and i0 % 16 == 0 and j0 == 0  # (steps of a quarter of 64 columns)
    assert i0 <= 305 <= i1
    assert field.origin_x == surface.grid.origin_x + i0 * surface.grid.cell
    assert np.array_equal(field.height, surface.height[j0:j1, i0:i1])
    far = PatchRequest(x_min=99.0, x_max=99.1, y_min=0.0, y_max=0.1)  # off the grid: the window stays inside
    surface.step(2 * DT_NS, DT_NS, {"occupied": None, "request": far})
    assert surface.field_window()[1] == 400


def test_the_field_window_follows_the_body_whose_water_moved():
    """Several bodies: the field's window follows the one that asked for new water (a stone in flight),
    not the first of them, whose request stays (a floating ball held the window at its place for the
    whole run, while the stone skipped out of it); a restored state follows as the run did."""
    from components.messages import PatchRequest

    params = WaterParams(nx=400, ny=100, cell=0.01, depth=0.5, boundary="absorbing", tile=16, rest_below=0.0,
                         field_every=1, field_window=(0.64, 0.32), bodies=["ball", "stone"])
    shared = WaterSurface.configure(params, "pond", None, [])

    def made() -> WaterSurface:
        return shared("pond", params)

    surface = made()
    ball = PatchRequest(x_min=0.5, x_max=0.6, y_min=0.4, y_max=0.5)

    def step(k: int, stone_x: float, on: WaterSurface = surface) -> tuple[int, int, int, int]:
        stone = PatchRequest(x_min=stone_x, x_max=stone_x + 0.1, y_min=0.4, y_max=0.5)
        on.step(k * DT_NS, DT_NS, {"occupied_ball": None, "request_ball": ball,
                                   "occupied_stone": None, "request_stone": stone})
        return on.field_window()

    i0, i1, _, _ = step(0, 0.5)
    assert i0 <= 55 <= i1  # both ask at once: the first
    for k, x in enumerate((1.5, 2.0, 3.0), start=1):
        i0, i1, _, _ = step(k, x)
        assert i0 <= round(100 * x) + 5 <= i1, (x, i0, i1)  # the stone's, the ball's window unchanged
    restored = made()
    restored.set_state(surface.get_state())
    assert step(4, 3.0, restored) == step(4, 3.0)  # nobody asked anew: both stay with the stone


def test_the_field_window_stays_with_one_of_two_bodies_in_flight():
    """Two stones in flight ask for new water in turns (a request is held while it still covers its
    body): the field's window stays with the one it follows while that one keeps asking, and goes to
    the other once it has asked for nothing new for FOLLOW_HOLD (it jumped between them at every
    frame, so that each stone was over water in one frame of two)."""
    from components.messages import PatchRequest
    from components.water.surface import FOLLOW_HOLD

    params = WaterParams(nx=800, ny=100, cell=0.01, depth=0.5, boundary="absorbing", tile=16, rest_below=0.0,
                         field_every=1, field_window=(0.64, 0.32), bodies=["a", "b"])
    surface = WaterSurface.configure(params, "pond", None, [])("pond", params)

    def step(k: int, a_x: float, b_x: float) -> tuple[int, int]:
        asks = {f"request_{n}": PatchRequest(x_min=x, x_max=x + 0.1, y_min=0.4, y_max=0.5)
                for n, x in (("a", a_x), ("b", b_x))}
        surface.step(k * DT_NS, DT_NS, {"occupied_a": None, "occupied_b": None, **asks})
        i0, i1, _, _ = surface.field_window()
        return i0, i1

    x = {"a": 0.5, "b": 0.5}
    shown = []
    for k in range(1, 40):
        x["a"] += 0.2 if k % 2 else 0.0  # a asks anew at odd steps, b at even ones, a faster
        x["b"] += 0.05 if k % 2 == 0 else 0.0
        i0, i1 = step(k, x["a"], x["b"])
        shown.append({n for n in x if i0 <= round(100 * x[n]) + 5 <= i1})
    (followed,) = shown[-1]  # the two far apart by then: one of them in the window
    assert all(followed in seen for seen in shown[2:])  # that one throughout, once both had asked anew
    other = "b" if followed == "a" else "a"
    for k in range(40, 40 + int(FOLLOW_HOLD * 1e9 / DT_NS) + 2):  # it stops: the other, once the one
        x[other] += 0.005                                          # followed has asked nothing new for the hold
        i0, i1 = step(k, x["a"], x["b"])
    assert i0 <= round(100 * x[other]) + 5 <= i1


def test_volume_and_energy_by_tiles_are_the_whole_waters_to_round_off():
    """Volume and energy, summed over the moving water only, match the dense sums over the grid."""
    surface = run(pond(16, field_every=1, boundary="reflecting"), 60, stone_input)
    field = surface.step(60 * DT_NS, DT_NS, {"occupied": stone_input(60), "request": None})["field"]
    h, v = surface.get_state()["h"], surface.get_state()["v"]
    assert field.volume == surface.volume() == pytest.approx(volume(surface.grid, h, surface._b), rel=1e-14)
    assert field.energy == surface.energy() == pytest.approx(energy(surface.grid, h, v), rel=1e-12)


def test_a_closed_pond_stepped_by_tiles_keeps_its_volume():
    """Reflecting edges: a body pressing in and leaving again changes the volume by round-off only."""
    surface = pond(16, boundary="reflecting")
    before = surface.volume()
    run(surface, 200, stone_input)
    assert surface.volume() == pytest.approx(before, rel=1e-14)


def test_a_tiled_pond_restored_from_its_state_goes_on_as_if_never_stopped():
    """get_state mid-throw, set_state into a fresh pond: the rest of the run is the same bit for bit."""
    whole = run(pond(16), 60, stone_input)
    saved = whole.get_state()
    for k in range(60, 160):
        whole.step(k * DT_NS, DT_NS, {"occupied": stone_input(k), "request": None})
    resumed = pond(16)
    resumed.set_state(saved)
    for k in range(60, 160):
        resumed.step(k * DT_NS, DT_NS, {"occupied": stone_input(k), "request": None})
    assert np.array_equal(resumed.get_state()["h"], whole.get_state()["h"])
    assert np.array_equal(resumed.get_state()["v"], whole.get_state()["v"])
    assert resumed.tiles.stepped == whole.tiles.stepped  # the counters travel with the state
