"""A large scene is read by libyaml's parser (PyYAML's Python scanner took 4 s for 100,000 values),
with the same constructors and resolvers, so it reads to the same data; only a clean read is taken
from it (an error is said as the Python loader says it), and text nested deeper than libyaml's
composer can take without crashing the process (it recurses in C without a limit) never reaches it."""

import math

import pytest

import cosim.scenario as scenario
from cosim.errors import ScenarioError
from cosim.scenario import read_yaml


def big_scene(n: int) -> str:
    keys = ", ".join(f"[{k * 0.001:.3f}, {2.0 + 0.001 * k:.4f}, 0.0]" for k in range(n))
    return (f"name: big\ndt: 0.0005\nuntil: 1e-3\ncomponents:\n  stone:\n    type: RigidBody\n"
            f"    scripted_velocity: [{keys}]\n    spin: 0x10\n    tilt_deg: 5e-1\n    note: 1:30\n"
            f"    yes: .nan\n    low: -.inf\n")


def python_read(text: str):
    saved = scenario._read_fast
    scenario._read_fast = lambda text: (False, None)
    try:
        return read_yaml(text, "x")
    finally:
        scenario._read_fast = saved


def same(a, b) -> bool:
    """Equal, of the same types, NaN equal to NaN."""
    if type(a) is not type(b):
        return False
    if isinstance(a, dict):
        return list(a) == list(b) and all(same(a[k], b[k]) for k in a)
    if isinstance(a, list):
        return len(a) == len(b) and all(same(x, y) for x, y in zip(a, b, strict=True))
    return a == b or (isinstance(a, float) and math.isnan(a) and math.isnan(b))


def test_a_large_scene_reads_through_libyaml_to_the_same_data():
    text = big_scene(5000)
    assert len(text) > scenario.FAST_YAML_BYTES
    clean, fast = scenario._read_fast(text)
    assert clean  # (it did go through libyaml)
    assert same(fast, python_read(text))
    stone = fast["components"]["stone"]
    assert stone["spin"] == 16 and stone["tilt_deg"] == 0.5 and stone["note"] == "1:30"  # YAML 1.2 numbers
    assert math.isnan(stone[True]) and stone["low"] == -math.inf  # (yes: a YAML 1.1 key, True)


def test_a_large_scene_with_an_error_is_said_as_the_python_loader_says_it():
    text = big_scene(5000) + "    spin: 3\n"  # a duplicate key
    with pytest.raises(ScenarioError) as refused:
        read_yaml(text, "x")
    with pytest.raises(ScenarioError) as said:
        python_read(text)
    assert str(refused.value) == str(said.value) and "duplicate key 'spin'" in str(refused.value)


@pytest.mark.parametrize("nested", ["[" * 100_000 + "]" * 100_000, "- " * 100_000 + "x"])
def test_text_nested_deeper_than_libyaml_can_take_is_read_by_python(nested):
    """200,000 nested '[' or '- ' crash a process in libyaml's composer: such text is read by the
    Python loader, which says it is nested too deeply."""
    assert scenario._nesting_bound(nested) > scenario.C_NESTING_LIMIT
    with pytest.raises(ScenarioError, match=r"nested too deeply|nested more than"):
        read_yaml(nested, "x")
