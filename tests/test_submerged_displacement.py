"""A submerged body's displaced water rises over a width set by its depth, not in a band at its
outline (components.coupler.kernel.depth_spread, spread_gaussian).

Seen from the surface, the water a body under it displaces is a source at its depth: an image source
at depth d sends half its flux through the surface within sqrt(3) d of the point over it. Put into
the band next to its outline, as for a body that pierces the surface, a stone swimming 10 cm down
stood a mound and a trough of 27 mm over itself.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from components.coupler import kernel
from cosim.scenario import load
from cosim.scheduler import BaseObserver, Simulation

SKIP_SCENE = Path(__file__).resolve().parents[1] / "scenarios" / "skip.yaml"


def test_the_spread_is_the_image_sources_for_the_tops_depth_up_to_a_radius():
    """sigma = 1.47 d: a Gaussian whose half-flux radius, sigma sqrt(2 ln 2), is the image
    source's sqrt(3) d; none while the body pierces the rest level; at most its radius."""
    d = 0.01
    sigma = kernel.depth_spread(d, 0.05)
    assert sigma * math.sqrt(2.0 * math.log(2.0)) == pytest.approx(math.sqrt(3.0) * d, rel=1e-12)
    assert kernel.depth_spread(0.0, 0.05) == 0.0 and kernel.depth_spread(-0.01, 0.05) == 0.0
    assert kernel.depth_spread(0.2, 0.05) == 0.05


@pytest.mark.parametrize("sigma", [0.3, 1.7, 6.0])  # a spread wider than the window reflects more than once
def test_the_spread_keeps_the_volume_and_is_its_own_adjoint(sigma):
    """Spreading keeps sum(b) (no flux through the window's edges), and reading a field through it
    gives what the deposit spread through it meets: sum(eta G b) = sum((G eta) b), which the
    buoyancy's energy balance with the water needs (WaterCoupler._add_hydrostatics)."""
    rng = np.random.default_rng(7)
    b, eta = rng.random((9, 13)), rng.standard_normal((9, 13))
    spread_b, spread_eta = b.copy(), eta.copy()
    kernel.spread_gaussian(spread_b, sigma)
    kernel.spread_gaussian(spread_eta, sigma)
    assert spread_b.sum() == pytest.approx(b.sum(), rel=1e-13)
    assert (eta * spread_b).sum() == pytest.approx((spread_eta * b).sum(), rel=1e-12)
    assert spread_b.max() < b.max()


class _Surface(BaseObserver):
    """The surface's largest departure from its rest level [m] in the water's patches, and the
    stone's depths [m]."""

    def __init__(self):
        self.eta = 0.0
        self.z: list[float] = []

    def on_exchange(self, time_ns, component, port, msg):
        if component == "pond" and port == "patch" and msg.height.size:
            self.eta = max(self.eta, float(np.abs(msg.height - msg.rest_level).max()))
        elif component == "stone" and port == "state":
            self.z.append(float(msg.position[2]))


def test_a_stone_swimming_deep_hardly_moves_the_surface():
    """The reference stone, made as dense as water, set swimming level 10 cm down at 0.5 m/s for
    0.6 s: the surface within its patch stays within 2 mm of its level (1.1 mm; 27 mm with its
    water put in the band at its outline), and the stone swims on at its depth."""
    watch = _Surface()
    scene = load(SKIP_SCENE, ["components.stone.position=[0.3, 0.3, -0.1]", "components.stone.velocity=[0.5, 0, 0]",
                              "components.stone.tilt_deg=0", "components.stone.spin=0",
                              "components.stone.density=1000", "components.pond.nx=250", "components.pond.ny=60",
                              "until=0.6", "record.visual_rate=0", "components.stages.stop_after=0"])
    assert Simulation(scene, observers=[watch]).run().status == "ok"
    assert watch.eta < 0.002
    assert -0.11 < min(watch.z) and max(watch.z) <= -0.1


def test_the_compiled_steps_shortcuts_give_the_whole_spreads_numbers_bit_for_bit():
    """The compiled step spreads a deposit without its rows of zeros, and reads the field through
    the spread in the columns it reads only: the same numbers, bit for bit, where they are used."""
    rng = np.random.default_rng(3)
    deposit = np.zeros((30, 26))
    deposit[11:17, 9:18] = rng.random((6, 9))
    whole, shortcut = deposit.copy(), deposit.copy()
    kernel.spread_gaussian(whole, 2.3)
    kernel.spread_deposit(shortcut, 2.3, 11, 16)
    assert whole.tobytes() == shortcut.tobytes()
    field = rng.standard_normal((30, 26))
    whole, shortcut = field.copy(), field.copy()
    kernel.spread_gaussian(whole, 2.3)
    kernel.spread_columns(shortcut, 2.3, 8, 19)
    assert whole[:, 8:20].tobytes() == shortcut[:, 8:20].tobytes()


def _spread_by_definition(b: np.ndarray, sigma: float) -> np.ndarray:
    """The spread as its definition reads: each value the sum of its taps, -reach..reach in turn from
    0, at columns (then rows) mirrored about the window's edges; along x, then along y."""
    reach = kernel.spread_reach(sigma)
    taps = [math.exp(-0.5 * (k / sigma) ** 2) for k in range(-reach, reach + 1)]
    total = 0.0
    for t in taps:  # summed in turn, as the kernel sums its weights
        total += t
    w = [t / total for t in taps]

    def mirror(k: int, n: int) -> int:
        k %= 2 * n
        return k if k < n else 2 * n - 1 - k

    out = b.copy()
    for axis in (1, 0):
        src = out.copy()
        nj, ni = src.shape
        for j in range(nj):
            for i in range(ni):
                acc = 0.0
                for k in range(-reach, reach + 1):
                    jj, ii = (j, mirror(i + k, ni)) if axis == 1 else (mirror(j + k, nj), i)
                    acc += w[k + reach] * src[jj, ii]
                out[j, i] = acc
    return out


@pytest.mark.parametrize("shape, sigma", [((9, 14), 2.3), ((5, 4), 3.1), ((20, 31), 5.0), ((1, 7), 1.0)],
                         ids=["wider-than-reach", "narrower-than-reach", "reach-13", "one-row"])
def test_the_spread_is_its_definition_bit_for_bit(shape, sigma):
    """The compiled spread (its taps in the outer loop, mirrored only where a tap leaves the window,
    the y pass a row at a time) gives each value its definition's sum, bit for bit, also where the
    window is narrower than the spread's reach (every tap mirrored)."""
    rng = np.random.default_rng(7)
    b = rng.random(shape) * 1e-3
    spread = b.copy()
    kernel.spread_gaussian(spread, sigma)
    assert np.array_equal(spread, _spread_by_definition(b, sigma))
