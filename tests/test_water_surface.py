"""The WaterSurface component: ports, parameters, patches, displacement input, field frames, state."""

from __future__ import annotations

import math

import numpy as np
import pytest

from components.messages import HeightPatch, OccupiedHeight, PatchRequest, WaterField
from components.water import GaussianBump, WaterParams, WaterSurface
from components.water.grid import GRAVITY, wave_speed_of
from cosim.codec.json_codec import codec_for, decode_state, encode_state
from cosim.messages import messages_equal
from cosim.params import build

MS = 1_000_000  # one millisecond in ns


def pond(**kw) -> WaterSurface:
    defaults = dict(nx=20, ny=16, cell=0.01, depth=0.2, origin_x=-0.1, origin_y=-0.05,
                    initial=GaussianBump(x=0.0, y=0.02, amplitude=0.005, width=0.02))
    return WaterSurface("pond", WaterParams(**{**defaults, **kw}))


def problems_of(data: dict) -> list[str]:
    problems: list[str] = []
    build(WaterParams, data, "components.pond", problems)
    return problems


# --- ports and parameters --------------------------------------------------------------------------

def test_ports_are_declared_with_their_message_types():
    """Inputs occupied/request and outputs patch/field carry the shared physics messages."""
    assert WaterSurface.inputs["occupied"].type is OccupiedHeight
    assert WaterSurface.inputs["request"].type is PatchRequest
    assert WaterSurface.outputs["patch"].type is HeightPatch
    assert WaterSurface.outputs["field"].type is WaterField


def test_unknown_model_and_boundary_list_the_choices():
    """An unknown model or boundary name is reported with the valid names and the YAML path."""
    problems = problems_of({"model": "navier_stokes", "boundary": "periodic"})
    assert "components.pond.model: must be one of 'wave', 'shallow_water', 'airy' (got 'navier_stokes')" in problems
    assert "components.pond.boundary: must be one of 'reflecting', 'absorbing' (got 'periodic')" in problems


def test_a_wave_length_sets_the_one_wave_speed():
    """``wave_length`` gives the one-speed models the speed of waves that long at the rest depth
    (grid.wave_speed_of); with ``wave_speed`` too it is refused; airy, which runs every length at its
    own speed, keeps its own."""
    pond = WaterSurface("pond", WaterParams(nx=8, ny=8, cell=0.01, depth=0.5, wave_length=0.1))
    assert pond.grid.c2_uniform == wave_speed_of(0.1, 0.5) ** 2
    assert np.all(pond.grid.kx == wave_speed_of(0.1, 0.5) ** 2)
    long = WaterSurface("pond", WaterParams(nx=8, ny=8, cell=0.01, depth=0.5))
    assert long.grid.c2_uniform == GRAVITY * 0.5
    airy = WaterParams(nx=8, ny=8, cell=0.01, depth=0.5, model="airy", wave_length=0.1)
    assert airy.check() == [] and WaterSurface.wave_speed(airy) is None
    assert problems_of({"nx": 8, "ny": 8, "wave_speed": 0.3, "wave_length": 0.1}) == [
        "components.pond.wave_length: give wave_speed or wave_length, not both (got wave_speed 0.3 m/s, "
        "wave_length 0.1 m)"]
    assert problems_of({"nx": 8, "ny": 8, "wave_length": 0.0}) == ["components.pond.wave_length: must be > 0 m (got 0)"]


def test_parameter_rules_are_all_reported():
    """Bounds, both field rates at once and a sponge wider than the pond are each reported."""
    problems = problems_of({"cell": 0.0, "nx": 10, "ny": 10})
    assert problems == ["components.pond.cell: must be >= 1e-06 m (got 0)"]
    problems = problems_of({"nx": 10, "ny": 10, "boundary": "absorbing", "sponge_cells": 5,
                            "field_every": 2, "field_rate": 30.0})
    assert any("field_rate: give field_every or field_rate, not both" in p for p in problems)
    assert any("sponge_cells: must be < min(nx, ny) / 2 = 5" in p for p in problems)


def test_a_sponge_is_refused_on_a_closed_basin():
    """The sponge is a layer of the absorbing edges: asked of reflecting ones it was taken and ignored."""
    assert problems_of({"nx": 10, "ny": 10, "sponge_cells": 4}) == [
        "components.pond.sponge_cells: must be 0 with boundary reflecting: the sponge is a layer of absorbing "
        "edges (got 4)"]
    assert problems_of({"nx": 10, "ny": 10, "sponge_cells": 0}) == []


def test_initial_bump_is_a_nested_mapping():
    """initial: {x, y, amplitude, width} builds a Gaussian bump; a missing width is reported."""
    assert problems_of({"initial": {"x": 0.0, "y": 0.0, "amplitude": 0.01, "width": 0.02}}) == []
    assert problems_of({"initial": {"x": 0.0, "y": 0.0, "amplitude": 0.01}}) == [
        "components.pond.initial.width: missing (required, a number)"]


def test_initial_trough_shallower_than_the_depth():
    """A trough reaching the bed leaves no water there: refused, with the depth it was compared with; a
    bump may be higher than the pond is deep, up to 1 km (one of 1e300 m overflowed the energy's
    squares and printed numpy's warning before the run failed)."""
    assert problems_of({"initial": {"x": 0.0, "y": 0.0, "amplitude": -0.49, "width": 0.02}}) == []
    assert problems_of({"initial": {"x": 0.0, "y": 0.0, "amplitude": 2.0, "width": 0.02}}) == []
    assert problems_of({"initial": {"x": 0.0, "y": 0.0, "amplitude": 1000.0, "width": 0.02}}) == []
    assert problems_of({"initial": {"x": 0.0, "y": 0.0, "amplitude": 1e300, "width": 0.02}}) == [
        "components.pond.initial: a bump must be at most 1000 m high, no pond's waves are higher (got amplitude "
        "1e+300 m)"]
    assert problems_of({"depth": 0.2, "initial": {"x": 0.0, "y": 0.0, "amplitude": -0.2, "width": 0.02}}) == [
        "components.pond.initial: a trough must be shallower than the depth 0.2 m: one reaching the bed leaves "
        "no water (got amplitude -0.2 m)"]
    # a slope whose bed overflows was refused with numpy's "overflow encountered in multiply"
    assert problems_of({"bottom_slope": [1e308, 0.0]}) == [
        "components.pond.bottom_slope: each part at most 1000 m/m, a cliff, in size (got [1e+308, 0.0])"]
    assert problems_of({"bottom_slope": [-1000.0, 1000.0]}) == []
    # a width whose square underflows filled the water with NaN and the run said ok
    assert problems_of({"initial": {"x": 0.0, "y": 0.0, "amplitude": 0.01, "width": 1e-300}}) == [
        "components.pond.initial.width: must be >= 1e-06 m (got 1e-300)"]


def test_a_trough_reaching_the_bed_up_a_slope_is_refused_at_load():
    """On a sloped bed the trough is compared with the water where it reaches, not at the centre: 4 cm
    deep 0.1 m up a 1:10 slope from the centre of a 5 cm pond, it started 0.5 mm below the bed."""
    from cosim.errors import ScenarioError
    from cosim.scenario import loads

    scene = """
dt: 0.001
until: 0.01
components:
  pond: {type: WaterSurface, nx: 120, ny: 8, cell: 0.01, depth: 0.05, bottom_slope: [0.1, 0.0],
         initial: {x: X, y: 0.04, amplitude: -0.04, width: 0.03}}
"""
    with pytest.raises(ScenarioError) as err:
        loads(scene.replace("X", "0.7"))
    assert ("components.pond: initial: the trough reaches the bed at x = 0.7 m, y = 0.04 m, where the water is "
            "0.0395 m deep and the trough -0.04 m") in str(err.value)
    assert loads(scene.replace("X", "0.5")).components["pond"]  # there the water is 4.05 cm deep


def test_direct_construction_checks_the_parameters():
    """Building the component in code with a bad name fails with the same message."""
    with pytest.raises(ValueError, match="model: must be one of 'wave', 'shallow_water'"):
        WaterSurface("pond", WaterParams(model="lattice_boltzmann"))


def test_initial_bump_has_its_amplitude_and_volume():
    """The Gaussian bump peaks at its amplitude above the rest level; volume includes it."""
    p = pond(rest_level=1.0)
    assert p.height.max() == pytest.approx(1.005, abs=1e-4)
    bump = 0.005 * 2 * np.pi * 0.02**2  # integral of the Gaussian over the plane
    assert p.volume() == pytest.approx(20 * 16 * 0.01**2 * 0.2 + bump, rel=1e-3)


# --- outputs ---------------------------------------------------------------------------------------

def test_initial_outputs_hold_an_empty_patch_and_the_field_when_enabled():
    """At t = 0 the water publishes an empty patch, plus the field only if frames are enabled."""
    assert set(pond().initial_outputs()) == {"patch"}
    out = pond(field_every=5).initial_outputs()
    assert out["patch"].height.shape == (0, 0)
    field = out["field"]
    assert field.height.shape == (16, 20)
    assert field.volume == pytest.approx(pond().volume(), rel=1e-15)
    assert field.energy == pytest.approx(pond().energy(), rel=1e-15)


def test_a_patch_says_the_crest_over_its_window_and_a_crest_request_gets_that_alone():
    """A patch says how high the water stands over its window (rounded up to the millimetre), with
    its columns or alone for a request of the crest only (columns False); nothing asked, it is not
    known (-1), but at t = 0 the whole water's is said, so that a body let go inside a wave meets it."""
    w = pond(initial=GaussianBump(x=0.0, y=0.02, amplitude=0.0123, width=0.02))
    assert w.initial_outputs()["patch"].crest == 0.013
    assert w.patch(None).crest == -1.0
    near = PatchRequest(-0.02, 0.02, 0.0, 0.04)
    full = w.patch(near)
    top = np.max(full.height) - full.rest_level
    assert full.height.size and top <= full.crest < top + 0.001
    alone = w.patch(PatchRequest(-0.02, 0.02, 0.0, 0.04, columns=False))
    assert alone.height.size == 0 and alone.crest == full.crest
    assert w.patch(PatchRequest(-0.02, 0.02, 0.0, 0.04, columns=False)) is alone  # held while it holds
    aside = w.patch(PatchRequest(0.07, 0.08, -0.04, -0.03, columns=False))  # far from the bump
    assert 0.0 <= aside.crest <= 0.001  # the bump's tail, rounded up


def test_patch_covers_the_requested_rectangle_plus_margin():
    """The patch holds the columns touching the request plus patch_margin cells, with their geometry."""
    p = pond(patch_margin=2)
    out = p.step(0, MS, {"request": PatchRequest(-0.021, 0.004, 0.0, 0.01)})
    patch = out["patch"]
    # cells overlapping x in [-0.021, 0.004]: i = 8..10; y in [0, 0.01]: j = 5..6; plus 2 each side
    assert (patch.i0, patch.j0) == (6, 3)
    assert patch.height.shape == (6, 7)
    sl = (slice(3, 9), slice(6, 13))
    assert np.array_equal(patch.height, p.height[sl])
    assert np.array_equal(patch.velocity, p.velocity[sl])
    assert np.array_equal(patch.bottom, p.grid.bed[sl])
    assert (patch.cell, patch.origin_x, patch.origin_y, patch.rest_level) == (0.01, -0.1, -0.05, 0.0)


def test_patch_is_clipped_to_the_grid():
    """A request reaching past the edge is clipped: the patch starts at cell 0."""
    patch = pond().step(0, MS, {"request": PatchRequest(-5.0, -0.097, -5.0, 5.0)})["patch"]
    assert (patch.i0, patch.j0) == (0, 0)
    assert patch.height.shape == (16, 2)


@pytest.mark.parametrize("request_msg", [None, PatchRequest.empty(), PatchRequest(3.0, 4.0, 3.0, 4.0)],
                         ids=["unconnected", "empty", "off-grid"])
def test_no_request_gives_an_empty_patch(request_msg):
    """No request, an empty request or one off the grid gives a (0, 0) patch every step."""
    out = pond().step(0, MS, {"request": request_msg})
    assert out["patch"].height.shape == (0, 0)
    assert out["patch"].velocity.shape == (0, 0) and out["patch"].bottom.shape == (0, 0)


def test_patch_is_a_snapshot():
    """A published patch does not change when the water moves on."""
    p = pond()
    req = PatchRequest(-0.02, 0.02, 0.0, 0.04)
    first = p.step(0, MS, {"request": req})["patch"]
    kept = first.height.copy()
    for k in range(1, 5):
        p.step(k * MS, MS, {"request": req})
    assert np.array_equal(first.height, kept)


def test_dry_cells_report_the_bed_as_surface():
    """Over dry land the patch's surface is the bed itself (no water column)."""
    p = pond(bottom_slope=(3.0, 0.0), initial=None)
    patch = p.step(0, MS, {"request": PatchRequest(-1.0, 1.0, -1.0, 1.0)})["patch"]
    dry = ~p.grid.wet
    assert dry.any()
    assert np.array_equal(patch.height[dry], patch.bottom[dry])
    assert np.all(patch.height[~dry] == 0.0)


@pytest.mark.parametrize("every", [1, 3])
def test_field_is_published_every_n_steps(every):
    """field_every: N publishes the whole field on steps N, 2N, ... and only then."""
    p = pond(field_every=every)
    published = [k + 1 for k in range(9) if "field" in p.step(k * MS, MS, {})]
    assert published == list(range(every, 10, every))


def test_field_rate_is_converted_to_frames_in_time():
    """field_rate: 100 Hz with 3 ms steps publishes on the first step ending at or after each 10 ms."""
    p = pond(field_rate=100.0)
    ends = [(k + 1) * 3 for k in range(12) if "field" in p.step(k * 3 * MS, 3 * MS, {})]
    assert ends == [12, 21, 30]


def test_field_reports_volume_and_energy():
    """The field carries the surface, the water volume and the lattice energy of the same instant."""
    p = pond(field_every=1)
    field = p.step(0, MS, {})["field"]
    assert np.array_equal(field.height, p.height)
    assert field.volume == p.volume() and field.energy == p.energy()


def test_messages_round_trip_through_the_codec():
    """Patch and field encode to JSON and back bit for bit."""
    p = pond(field_every=1)
    out = p.step(0, MS, {"request": PatchRequest(-0.03, 0.03, 0.0, 0.03)})
    for msg in out.values():
        codec = codec_for(type(msg))
        assert messages_equal(codec.decode(codec.encode(msg)), msg)


# --- the displacement input ------------------------------------------------------------------------

def test_displacement_adds_the_change_of_occupied_height():
    """Under a body the surface rises by b - b_prev: the whole b first, then only its change."""
    p = pond(initial=None)
    p.apply_occupied(OccupiedHeight(i0=4, j0=5, b=np.full((2, 3), 0.002)))
    h = p.get_state()["h"]
    assert np.all(h[5:7, 4:7] == 0.002) and h.sum() == pytest.approx(6 * 0.002)
    p.apply_occupied(OccupiedHeight(i0=4, j0=5, b=np.full((2, 3), 0.003)))
    assert np.allclose(p.get_state()["h"][5:7, 4:7], 0.003, rtol=1e-15)


def test_repeated_occupied_message_adds_nothing():
    """The same absolute b delivered again (a slower water component) changes nothing."""
    p = pond()
    body = OccupiedHeight(i0=4, j0=5, b=np.full((2, 3), 0.002))
    p.apply_occupied(body)
    before = p.get_state()["h"]
    p.apply_occupied(body)
    assert np.array_equal(p.get_state()["h"], before)


def test_moving_window_gives_back_the_old_columns():
    """When the body moves on, its old columns get their occupied height back (union of windows)."""
    p = pond(initial=None)
    p.apply_occupied(OccupiedHeight(i0=2, j0=2, b=np.full((2, 2), 0.004)))
    p.apply_occupied(OccupiedHeight(i0=10, j0=8, b=np.full((3, 1), 0.001)))
    h = p.get_state()["h"]
    assert np.all(h[2:4, 2:4] == 0.0)
    assert np.all(h[8:11, 10] == 0.001)
    p.apply_occupied(OccupiedHeight(i0=0, j0=0, b=np.zeros((0, 0))))
    assert np.all(p.get_state()["h"] == 0.0)


def test_patch_reports_the_occupied_height_the_water_holds():
    """The patch carries, column by column, the occupied height the water applied before computing
    it (part of its height), so the body that sent it knows what the water already holds."""
    p = pond(initial=None)
    req = PatchRequest(-0.08, 0.0, 0.0, 0.05)
    first = p.step(0, MS, {"request": req})["patch"]
    assert np.array_equal(first.occupied, np.zeros_like(first.height))
    b = np.full((2, 3), 0.002)
    patch = p.step(MS, MS, {"occupied": OccupiedHeight(i0=4, j0=5, b=b), "request": req})["patch"]
    held = np.zeros((16, 20))
    held[5:7, 4:7] = b
    assert np.array_equal(patch.occupied, held[patch.j0:patch.j0 + patch.height.shape[0],
                                                patch.i0:patch.i0 + patch.height.shape[1]])
    assert patch.occupied.sum() == pytest.approx(6 * 0.002)


def test_occupied_window_off_the_grid_is_clipped():
    """Columns of an occupied window lying off the grid are ignored; the rest applies."""
    p = pond(initial=None)
    p.apply_occupied(OccupiedHeight(i0=-2, j0=14, b=np.full((4, 4), 0.001)))
    h = p.get_state()["h"]
    assert h.sum() == pytest.approx(2 * 2 * 0.001)
    assert np.all(h[14:16, 0:2] == 0.001)


def test_displacement_smoothing_spreads_the_change_conservatively():
    """Blur passes spread a displacement over neighbours without changing its volume."""
    p = pond(initial=None, displacement_smoothing=2)
    p.apply_occupied(OccupiedHeight(i0=8, j0=8, b=np.full((1, 1), 0.004)))
    h = p.get_state()["h"]
    assert h[8, 8] < 0.004 and h[8, 10] > 0.0 and h[8, 11] == 0.0
    assert h.sum() == pytest.approx(0.004, rel=1e-14)


# --- state -----------------------------------------------------------------------------------------

def _drive(p: WaterSurface, k0: int, n: int) -> list:
    outs = []
    for k in range(k0, k0 + n):
        body = OccupiedHeight(i0=3 + k % 5, j0=4, b=np.full((3, 3), 0.001 * (k % 7)))
        outs.append(p.step(k * MS, MS, {"occupied": body, "request": PatchRequest(-0.05, 0.0, 0.0, 0.05)}))
    return outs


@pytest.mark.parametrize("model", ["wave", "shallow_water"])
def test_state_round_trip_reproduces_the_run_bit_for_bit(model):
    """set_state(get_state()), even through the JSON checkpoint codec, continues the run bit for bit."""
    a = pond(model=model, field_every=4)
    _drive(a, 0, 30)
    saved = encode_state(a.get_state())
    expected = _drive(a, 30, 30)
    b = pond(model=model, field_every=4)
    b.set_state(decode_state(saved))
    got = _drive(b, 30, 30)
    for x, y in zip(expected, got, strict=True):
        assert x.keys() == y.keys()
        assert all(messages_equal(x[port], y[port]) for port in x)
    assert np.array_equal(a.get_state()["h"], b.get_state()["h"])


@pytest.mark.filterwarnings("error::RuntimeWarning")
def test_a_bump_far_off_the_grid_leaves_it_flat_without_a_warning():
    """A bump 1e308 m from its grid: the squared distance overflows to inf and the height is exactly
    0, without numpy's overflow warning on stderr. (The grid itself cannot be put there: its origin
    is held within 1000 km, as a scene holds it.)"""
    p = pond(initial=GaussianBump(x=-1e308, y=0.02, amplitude=0.005, width=0.02))
    assert not p.get_state()["h"].any()


def test_a_state_saved_by_one_model_restarts_another():
    """A checkpoint of the explicit model restored into the implicit one (a restart that switches
    models, ``cosim replay --from T --set components.pond.model=shallow_water``): the implicit model
    starts from the columns, its exact total vertical velocity that of the restored v (the wave model
    saves none of its own; the restart failed with a KeyError naming 'sum_v')."""
    a = pond(model="wave")
    _drive(a, 0, 30)
    b = pond(model="shallow_water")
    b.set_state(decode_state(encode_state(a.get_state())))
    assert np.array_equal(b.get_state()["v"], a.get_state()["v"])
    assert b.model.sum_v == pytest.approx(float(np.sum(a.get_state()["v"])), abs=1e-15)
    _drive(b, 30, 5)  # and steps on


def test_set_state_checks_the_grid_shape():
    """A state of another grid size is refused, naming the shapes."""
    p = pond()
    with pytest.raises(ValueError, match=r"state 'h' has shape \(3, 3\), the grid is \(16, 20\)"):
        p.set_state({**p.get_state(), "h": np.zeros((3, 3))})


def test_summary_names_model_grid_and_volume_change():
    """The closing summary line names the model, grid, the waves' speed and why, edges, volume
    change and energy."""
    (line,) = pond().summary()
    depth = pond().params.depth
    speed = f"{math.sqrt(GRAVITY * depth):.2g}"
    assert line.startswith(f"pond: wave on 20 x 16 cells of 0.01 m, waves at sqrt(g d) = {speed} m/s (at the "
                           "rest depth), reflecting edges; volume change")
    (ripples,) = WaterSurface("pond", WaterParams(nx=8, ny=8, depth=0.5, wave_length=0.1)).summary()
    assert "waves at 0.4 m/s (those 0.1 m long)" in ripples
    (airy,) = WaterSurface("pond", WaterParams(nx=8, ny=8, depth=0.5, model="airy")).summary()
    assert "each wave length at its own speed" in airy


def test_summary_counts_one_tile_and_one_step_in_the_singular():
    """A pond of one tile stepped once says "of 1 tile ..., over 1 step", not "1 tiles", "1 steps";
    the tile no larger than the grid (a tile of 10^12 on a 60 x 60 pond was "10^12 x 10^12 cells")."""
    p = WaterSurface("pond", WaterParams(nx=20, ny=20, depth=0.5,
                                         initial=GaussianBump(x=0.1, y=0.1, amplitude=0.001, width=0.03)))
    p.step(0, 1_000_000, {})
    (line,) = p.summary()
    assert "(of 1 tile of 20 x 20 cells, over 1 step)" in line
    p = WaterSurface("pond", WaterParams(nx=60, ny=40, depth=0.5, tile=10**12,
                                         initial=GaussianBump(x=0.1, y=0.1, amplitude=0.001, width=0.03)))
    p.step(0, 1_000_000, {})
    assert "(of 1 tile of 60 x 40 cells, over 1 step)" in p.summary()[0]


def test_a_wave_speed_whose_square_is_no_number_is_refused():
    """At 1e-300 m/s the speed's square underflowed to 0: the water stood still, and its summary said
    its waves ran at 1e-300 m/s. A fixed speed is at least a micrometre a second."""
    problems: list[str] = []
    build(WaterParams, {"wave_speed": 1e-300}, "pond", problems)
    assert problems == ["pond.wave_speed: must be >= 1e-06 m/s (got 1e-300)"]
    assert build(WaterParams, {"wave_speed": 1e-6}, "pond", problems).wave_speed == 1e-6
    assert len(problems) == 1


def test_a_wave_that_takes_the_surface_under_a_beachs_bed_is_said():
    """A 1 cm wave running up a 1:10 beach takes the surface 7.2 mm under the bed by the shore: the
    linear model keeps its shoreline where it is at rest. The summary says where and when (it said
    nothing of it); a checkpoint keeps it, and a flat pond says nothing of a bed."""
    params = WaterParams(nx=120, ny=8, cell=0.01, depth=0.05, bottom_slope=(0.1, 0.0),
                         initial=GaussianBump(x=0.3, y=0.035, amplitude=0.01, width=0.05))
    p = WaterSurface("pond", params)
    dt_ns = 2_000_000
    for k in range(1500):
        p.step(k * dt_ns, dt_ns, {})
    (line,) = p.summary()
    assert line.endswith("; the surface went 7.17 mm under the bed at x = 1.09 m, y = 0 m (t = 1.996 s): a wave "
                         "too large for the shallows of this bed, where the model, linear about the water at "
                         "rest, keeps the shoreline fixed")
    again = WaterSurface("pond", params)
    again.set_state(p.checkpoint_state())
    assert again.summary() == [line]
    assert "under the bed" not in pond().summary()[0]


def test_components_with_compiled_kernels_start_numba_when_built(monkeypatch):
    """Building a water surface on the numba backend, or a water coupler, starts numba's compiler
    (components.compiled.start), so that its half-second start-up is not counted in a run's wall
    time; the numpy backend does not."""
    from components import compiled
    from components.coupler import WaterCoupler

    started = []
    monkeypatch.setattr(compiled, "start", lambda: started.append(True))
    pond(backend="numpy")
    assert started == []
    pond(backend="numba")
    WaterCoupler("c")
    assert started == [True, True]


def test_a_windowed_fields_first_frame_is_around_the_stone_not_the_grids_middle(tmp_path):
    """The reference skip's field window (6 m of its 14 m pond) was centred on the grid at t = 0,
    before the stone had asked for any water, and stayed there until the next frame at 0.1 s: the
    viewer and the render showed the stone over no water. The first frame now waits for the first
    body to ask (a water step later) and is around it."""
    from pathlib import Path

    from cosim.record.reader import Recording
    from cosim.runner import run_scene
    from cosim.scenario import load

    skip = Path(__file__).resolve().parents[1] / "scenarios" / "skip.yaml"
    scene = load(skip, ["until=0.12", "record.visual_rate=0"])
    run_scene(scene, tmp_path / "skip.mcap", progress=False)
    fields = Recording(tmp_path / "skip.mcap").messages("/pond/field", WaterField)
    assert [round(stamp / 1e9, 3) for stamp, _ in fields] == [0.004, 0.1]
    first = fields[0][1]
    x_stone = 0.3 + 10.94 * 0.004
    assert first.origin_x <= x_stone <= first.origin_x + first.height.shape[1] * first.cell


def test_a_water_gone_non_finite_is_named_so_in_the_crest_not_a_rounding_error():
    """Rounding the crest of a window holding NaN or inf raised ValueError or OverflowError: the pond
    failed with "cannot convert float NaN to integer" where a non-finite water is named."""
    for bad in (math.nan, math.inf):
        w = pond()
        w._h[4, 9] = bad
        for columns in (True, False):
            crest = w.patch(PatchRequest(-0.02, 0.02, -0.02, 0.02, columns=columns)).crest
            assert math.isnan(crest) if math.isnan(bad) else crest == math.inf


def test_a_nan_made_by_arithmetic_is_said_in_the_crest():
    """x86 makes inf - inf and 0 * inf a NaN with its sign bit set, whose bits are below 0's: the
    crest's maximum of the bits passed it over and said 0, and a water full of NaN went on (a NaN of
    either sign, next to numbers of either sign, is said as NaN)."""
    negative_nan = -np.array([math.nan])[0]
    assert np.signbit(negative_nan)
    for others in (0.0, 0.004, -0.004):
        w = pond()
        w._h[:, :] = others
        w._h[4, 9] = negative_nan
        for columns in (True, False):
            crest = w.patch(PatchRequest(-0.02, 0.02, -0.02, 0.02, columns=columns)).crest
            assert math.isnan(crest)
