"""Fingerprints tell values apart by content: equal values share one however they are laid out, a
changed value (an array changed in place, a nested field) gets another, and a value whose content
cannot be read has none."""

import threading

import numpy as np

from cosim.component import fingerprint


class Box:
    def __init__(self, value):
        self.value = value


def test_equal_values_laid_out_otherwise_share_a_fingerprint():
    assert fingerprint({8, 16, 24}) == fingerprint({24, 16, 8})
    assert fingerprint({"a": 1, "b": [2.0]}) == fingerprint({"b": [2.0], "a": 1})
    same = "x" * 40
    assert fingerprint([same, same]) == fingerprint(["".join(["x"] * 40), "".join(["x"] * 40)])
    assert fingerprint(np.arange(6.0).reshape(2, 3)) == fingerprint(np.arange(6.0).reshape(3, 2).T.T.reshape(2, 3))
    assert fingerprint(np.arange(6.0)[::2]) == fingerprint(np.array([0.0, 2.0, 4.0]))
    assert fingerprint(Box([1, 2])) == fingerprint(Box([1, 2]))


def test_changed_values_do_not():
    table = np.zeros(1000)
    before = fingerprint(table)
    table[999] = 1e-300
    assert fingerprint(table) != before
    assert fingerprint(1.0) != fingerprint(1) != fingerprint(True)
    assert fingerprint([1, 2]) != fingerprint((1, 2))
    assert fingerprint(np.zeros(3)) != fingerprint(np.zeros(3, dtype=np.float32))
    assert fingerprint(Box(Box(1))) != fingerprint(Box(Box(2)))
    assert fingerprint(float("nan")) == fingerprint(float("nan"))  # (a NaN kept is no change)


def test_a_cycle_is_read_once_and_an_unreadable_value_has_none():
    ring = Box(None)
    ring.value = ring
    assert fingerprint(ring) is not None
    assert fingerprint(threading.Lock()) is None
    assert fingerprint({"lock": threading.Lock()}) is None
