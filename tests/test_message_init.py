"""Building a message: the generated ``__init__`` of :func:`cosim.messages.message` behaves as the frozen
dataclass's own (signature, defaults, factories, ``__post_init__``, frozen afterwards)."""

from __future__ import annotations

import dataclasses
import inspect
import pickle
from typing import Annotated

import numpy as np
import pytest

from cosim.messages import Array, Message, message

Grid = Annotated[np.ndarray, Array("float64", (None, None))]


@message
class Sample(Message):
    """A message with a plain field, a default and a default factory."""

    count: int
    level: float = 1.5
    grid: Grid = dataclasses.field(default_factory=lambda: np.zeros((0, 0)))


@message
class Checked(Message):
    """A message whose ``__post_init__`` refuses a negative value."""

    value: float

    def __post_init__(self) -> None:
        if self.value < 0:
            raise ValueError(f"value must be >= 0, got {self.value}")


@message
class Derived(Sample):
    """A message extending another: the inherited fields come first."""

    label: str = "x"


def test_fields_defaults_and_factories():
    a = Sample(3)
    assert (a.count, a.level, a.grid.shape) == (3, 1.5, (0, 0))
    b = Sample(count=4, level=2.0, grid=np.ones((1, 2)))
    assert (b.count, b.level, b.grid.shape) == (4, 2.0, (1, 2))
    assert Sample(1).grid is not Sample(1).grid  # a fresh default from the factory each time


def test_same_signature_and_errors_as_the_dataclass():
    assert list(inspect.signature(Sample).parameters) == ["count", "level", "grid"]
    with pytest.raises(TypeError, match="missing 1 required positional argument: 'count'"):
        Sample()  # type: ignore[call-arg]
    with pytest.raises(TypeError, match="unexpected keyword argument 'size'"):
        Sample(1, size=2)  # type: ignore[call-arg]
    with pytest.raises(TypeError):
        Sample(1, 2.0, np.zeros((0, 0)), 4)  # type: ignore[call-arg]


def test_frozen_after_init():
    a = Sample(3)
    with pytest.raises(dataclasses.FrozenInstanceError):
        a.count = 4  # type: ignore[misc]


def test_post_init_runs():
    assert Checked(1.0).value == 1.0
    with pytest.raises(ValueError, match=r"value must be >= 0, got -1\.0"):
        Checked(-1.0)


def test_replace_pickle_and_inheritance():
    a = Sample(3, 2.5)
    b = a.replace(count=7)
    assert (b.count, b.level) == (7, 2.5) and a.count == 3
    c = pickle.loads(pickle.dumps(a))
    assert (c.count, c.level, c.grid.shape) == (3, 2.5, (0, 0))
    d = Derived(2, label="y")
    assert (d.count, d.level, d.label) == (2, 1.5, "y")
    assert [f.name for f in dataclasses.fields(Derived)] == ["count", "level", "grid", "label"]


def test_a_keyword_only_field_keeps_the_dataclass_init():
    @message
    class Keyed(Message):
        """A keyword-only field: built by the dataclass's own __init__."""

        value: float = dataclasses.field(default=0.0, kw_only=True)

    assert Keyed(value=2.0).value == 2.0
    with pytest.raises(TypeError):
        Keyed(2.0)  # type: ignore[misc]


def test_a_class_with_its_own_init_keeps_it():
    @message
    class Doubled(Message):
        """A message type that builds itself."""

        value: float

        def __init__(self, value: float) -> None:
            object.__setattr__(self, "value", 2.0 * value)

    assert Doubled(1.5).value == 3.0


def test_an_init_only_variable_keeps_the_dataclass_init():
    @message
    class Scaled(Message):
        """A field set from an init-only scale."""

        value: float
        scale: dataclasses.InitVar[float] = 1.0

        def __post_init__(self, scale: float) -> None:
            object.__setattr__(self, "value", self.value * scale)

    assert Scaled(2.0, 3.0).value == 6.0
    assert Scaled(2.0).value == 2.0


def test_fields_named_like_the_generated_codes_own_names_keep_the_dataclass_init():
    @message
    class Odd(Message):
        """Field names the generated __init__ would clash with."""

        _d: float
        self: float = 2.0

    odd = Odd(1.0)
    assert (odd._d, odd.self) == (1.0, 2.0)
