"""Typed messages exchanged between components.

A message type is a frozen dataclass decorated with :func:`message`. Its fields are ``float``,
``int``, ``bool``, ``str``, an ``enum.IntEnum`` subclass, or a numpy array declared with
:class:`Array` (dtype and shape, ``None`` for a free dimension)::

    Vec3 = Annotated[np.ndarray, Array("float64", (3,))]

    @message
    class Wrench(Message):
        '''Force [N] and torque about the centre of mass [N m], world frame.'''
        force: Vec3
        torque: Vec3

A type whose class attribute ``additive`` is true defines ``__add__``; a port fed by several edges
of such a type receives their sum.

The field layout of each type is computed once (:func:`fields_of`) and shared by the codec, the
validation of ``initial`` values in scenes, and the finiteness guard.
"""

from __future__ import annotations

import dataclasses
import enum
import math
import typing
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np


@dataclass(frozen=True)
class Array:
    """Declares a numpy array field: its dtype and shape (``None`` marks a free dimension)."""

    dtype: str
    shape: tuple[int | None, ...]

    @property
    def fixed_size(self) -> int | None:
        """Number of elements when every dimension is fixed, else None."""
        if any(d is None for d in self.shape):
            return None
        return int(np.prod(self.shape, dtype=np.int64))


Vec3 = typing.Annotated[np.ndarray, Array("float64", (3,))]
"""A 3-vector of float64."""
Quat = typing.Annotated[np.ndarray, Array("float64", (4,))]
"""A quaternion (w, x, y, z) of float64."""


class FieldKind(enum.Enum):
    FLOAT = "float"
    INT = "int"
    BOOL = "bool"
    STR = "str"
    ENUM = "enum"
    ARRAY = "array"


@dataclass(frozen=True)
class FieldSpec:
    """One field of a message type, as the codec and validators see it."""

    name: str
    kind: FieldKind
    array: Array | None = None
    enum_type: type[enum.IntEnum] | None = None


class Message:
    """Base of all exchanged messages (use the :func:`message` decorator on subclasses)."""

    additive: ClassVar[bool] = False
    __cosim_fields__: ClassVar[tuple[FieldSpec, ...]] = ()

    def __add__(self, other: Message) -> Message:  # pragma: no cover - overridden by additive types
        raise TypeError(f"{type(self).__name__} is not additive")

    def replace(self, **changes: Any) -> Message:
        """A copy with some fields changed."""
        return dataclasses.replace(self, **changes)  # type: ignore[type-var]

    def first_nonfinite(self) -> str | None:
        """Name of the first float field (or array) holding NaN or infinity, or something that is no
        number at all (a text), or None.

        Fast path (:func:`_value_check`, generated once per type, which also checks each field's
        kind, enum members and shapes for :meth:`first_invalid`): one sum over every float value (an
        array's values or their squares, :func:`_array_sum`) is finite exactly when each value is
        (barring an overflow of huge finite values, which the slow path then rules out field by
        field). A message it does not pass for another reason than a float is not finite: None.
        """
        check = _CHECKS.get(type(self))
        if check is None:
            check = _CHECKS[type(self)] = _value_check(type(self))
        if check(self):
            return None
        bad = _first_bad_number(self)
        return None if bad is None else bad[0]

    def first_invalid(self) -> tuple[str, str] | None:
        """(name, fault) of the first field holding a value no message may carry, or None; every
        output of a component is checked so. A float field or float array holding NaN or infinity
        comes first (fault :data:`NONFINITE`; one holding no number, such as a text, fault ``must be
        a number, got str``). Then a field holding a value of another kind than its own, which the
        codecs would write as something else than the receivers were given, or fail on naming no
        component (:func:`_first_bad_kind`: an int field given 1.5 was recorded as 1, a bool field
        given "no" as true, a list in an array field failed in its receiver). Then an enum field
        holding a number that none of its type's members has (fault ``7 is not a Shape (0 disk, 1
        sphere)``): the codecs would write it, and no reader could read it back. Then an array field
        whose shape is not the one its :class:`Array` declares (fault ``must have shape (3,), got
        (2,)``; a free dimension takes any length): the codecs would write a message no reader could
        read back, or fail naming no component. The fast path is :meth:`first_nonfinite`'s one
        generated expression, which checks all of these for the usual values; only a message it does
        not pass is looked at field by field."""
        check = _CHECKS.get(type(self))  # (written out, not a helper's call: this runs for every output)
        if check is None:
            check = _CHECKS[type(self)] = _value_check(type(self))
        if check(self):
            return None
        return _first_bad_number(self) or _first_bad_kind(self) or _first_bad_enum(self) or _first_bad_shape(self)


NONFINITE = "non-finite"
"""The fault :meth:`Message.first_invalid` gives a float field or array holding NaN or infinity."""


def _first_bad_number(msg: Message) -> tuple[str, str] | None:
    """The slow path of :meth:`Message.first_nonfinite` and :meth:`Message.first_invalid`: (name,
    fault) of the first float field, then float array, holding NaN or infinity (fault
    :data:`NONFINITE`) or something that is no number (a text: ``must be a number, got str``; the
    fast path cannot sum it, and math.isfinite's TypeError was an internal error), or None."""
    floats, arrays = _finiteness_plan(type(msg))
    for name in floats:
        value = getattr(msg, name)
        try:
            if not math.isfinite(value):
                return name, NONFINITE
        except (TypeError, ValueError):
            return name, f"must be a number, got {type(value).__name__}"
    for name in arrays:
        given = getattr(msg, name)
        try:
            value = np.asarray(given)  # as given: an array, or a list where one was declared
            if value.size and not np.isfinite(value).all():
                return name, NONFINITE
        except (TypeError, ValueError):  # texts, objects, or a ragged list, which numpy cannot test
            return name, f"must be an array of numbers, got {_array_kind(given)}"
    return None


INT64_RANGE = (-(2 ** 63), 2 ** 63 - 1)  # an int field's values: the recording's sfixed64


def _first_bad_kind(msg: Message) -> tuple[str, str] | None:
    """(name, fault) of the first field holding a value of another kind than the field's, or None:
    an int field a whole number within 64 bits (Python's or numpy's integers; a float, 1.5 or 2.0,
    is refused: the recording would hold int(value), the receivers the float), a bool field true or
    false (Python's or numpy's bool), a str field a text, an array field a numpy array whose dtype
    the declared one takes without changing kind (an int64 array for float64, not a float array for
    int32 nor a complex one for float64), not a list or a tuple."""
    for spec in type(msg).__cosim_fields__:
        value = getattr(msg, spec.name)
        if spec.kind is FieldKind.INT:
            # (a bool is refused too: recorded as 1 while its receivers had True, and no decoder takes it)
            if isinstance(value, bool | np.bool_) or not isinstance(value, int | np.integer):
                return spec.name, f"must be an int (a whole number), got {_value_kind(value)}"
            if not INT64_RANGE[0] <= value <= INT64_RANGE[1]:
                return spec.name, f"must fit in 64 bits (-2^63 to 2^63 - 1), got {value}"
        elif spec.kind is FieldKind.BOOL:
            if not isinstance(value, bool | np.bool_):
                return spec.name, f"must be true or false (a bool), got {_value_kind(value)}"
        elif spec.kind is FieldKind.STR:
            if not isinstance(value, str):
                return spec.name, f"must be a str, got {_value_kind(value)}"
        elif spec.kind is FieldKind.ARRAY and spec.array is not None:
            declared = np.dtype(spec.array.dtype)
            if not isinstance(value, np.ndarray):
                return spec.name, f"must be a numpy array of {declared}, got {_value_kind(value)}"
            if value.dtype == declared or np.can_cast(value.dtype, declared, "safe"):
                continue
            if not np.can_cast(value.dtype, declared, "same_kind"):
                return spec.name, f"must be an array of {declared}, got an array of {value.dtype}"
            # a narrower type of the same kind (int64 for int32): the codecs cast it, its values
            # wrapped (2**40 recorded as 0) unless each fits
            with np.errstate(all="ignore"):
                if value.size and not (value.astype(declared) == value).all():
                    return spec.name, (f"must be an array of {declared}, got an array of {value.dtype} holding "
                                       f"values beyond {declared}'s range")
    return None


def _value_kind(value: Any) -> str:
    """A value for a fault: its type, and the value itself when it is short (``float 1.5``)."""
    text = repr(value)
    return f"{type(value).__name__} {text}" if len(text) <= 40 else type(value).__name__


def _array_kind(given: Any) -> str:
    """What an array field was given, for its fault: an array's dtype (``an array of <U3``), else the
    value's type (``str``, ``list``)."""
    return f"an array of {given.dtype}" if isinstance(given, np.ndarray) else _value_kind(given)


def _first_bad_enum(msg: Message) -> tuple[str, str] | None:
    """(name, fault) of the first enum field of ``msg`` holding a value no member of its type has
    (one the codecs' decoders refuse: ``Shape(value)`` fails), or None."""
    for spec in type(msg).__cosim_fields__:
        if spec.enum_type is None:
            continue
        value = getattr(msg, spec.name)
        try:
            spec.enum_type(value)
        except ValueError:
            members = ", ".join(f"{int(m)} {m.name.lower()}" for m in spec.enum_type)
            return spec.name, f"{value!r} is not a {spec.enum_type.__name__} ({members})"
    return None


def _first_bad_shape(msg: Message) -> tuple[str, str] | None:
    """(name, fault) of the first array field of ``msg`` whose shape is not its declared one (fault
    ``must have shape (3,), got (2,)``; ``n`` in the declared shape marks a free dimension), or
    None. A list given for an array is judged by the shape numpy gives it."""
    for spec in type(msg).__cosim_fields__:
        if spec.array is None:
            continue
        shape = np.shape(getattr(msg, spec.name))
        if not _shape_fits(shape, spec.array.shape):
            return spec.name, f"must have shape {_shape_text(spec.array.shape)}, got {_shape_text(shape)}"
    return None


def _shape_fits(shape: tuple[int, ...], declared: tuple[int | None, ...]) -> bool:
    """Whether an array of ``shape`` fits the ``declared`` one (None: any length there)."""
    return len(shape) == len(declared) and all(d is None or d == n for n, d in zip(shape, declared, strict=True))


def _shape_text(shape: tuple[int | None, ...]) -> str:
    """A shape as Python writes a tuple, ``n`` for a free dimension: ``(3,)``, ``(n, 3)``."""
    parts = ["n" if d is None else str(d) for d in shape]
    return f"({parts[0]},)" if len(parts) == 1 else f"({', '.join(parts)})"


def _shape_term(name: str, declared: tuple[int | None, ...]) -> str:
    """The generated check's test of array field ``name``'s shape: one tuple comparison when every
    dimension is fixed (a few tens of nanoseconds), else its number of dimensions and fixed ones."""
    if all(d is not None for d in declared):
        return f"m.{name}.shape == {tuple(declared)!r}"
    fixed = [f"m.{name}.shape[{i}] == {d}" for i, d in enumerate(declared) if d is not None]
    return " and ".join([f"m.{name}.ndim == {len(declared)}", *fixed])


_CHECKS: dict[type, typing.Callable[[Message], bool]] = {}
_SMALL_ARRAY = 16  # a fixed 1-D array of at most this many floats is summed as Python floats
# The most values whose squares are summed as a dot product. OpenBLAS (numpy's wheels) computes a
# longer dot product on its worker threads, which then keep spinning, waiting for more work: one
# water field checked ten times a second kept a second core busy for the whole run, taken from the
# recording's writer or from another job.
_DOT_MAX = 10_000
_vdot = np.vdot
_reduce = np.add.reduce


def _array_sum(values: Any) -> float:
    """A number that is finite when every value of the float array ``values`` is (barring an
    overflow of huge finite values): up to _DOT_MAX values the dot product with itself (``np.vdot``:
    the vectorised product takes half the time of a reduction on a water patch's 27 x 66 values),
    beyond that their sum (``np.add.reduce``, on this thread)."""
    if values.size <= _DOT_MAX:
        return _vdot(values, values)
    return _reduce(values, None)


def _finiteness_plan(message_type: type[Message]) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """(float field names, float array field names) of a message type."""
    specs = message_type.__cosim_fields__
    return (tuple(s.name for s in specs if s.kind is FieldKind.FLOAT),
            tuple(s.name for s in specs if s.kind is FieldKind.ARRAY and s.array is not None
                  and np.dtype(s.array.dtype).kind == "f"))


def _value_check(message_type: type[Message]) -> typing.Callable[[Message], bool]:
    """A function generated for ``message_type``: whether the sum of all its float values (fields
    and float arrays) is finite, each enum field holds one of its type's values, each other field a
    value of its own kind and each array its declared shape, in one expression, with no loop over
    the fields (it runs for every output of every step). A small fixed 1-D array (at most 16 values)
    is summed as Python floats, far cheaper than a numpy reduction, any other by :func:`_array_sum`;
    an enum field adds the 0.0 its value finds in a dict of its type's members (one lookup: an int
    that is none of theirs finds nothing); an int, bool or str field adds 0.0 when its value is of
    its kind, else None, and a non-float array 0.0 when its dtype is the declared one. A value it
    cannot sum or find so (a nested list, a scalar where an array was declared) makes it answer
    False, and :meth:`Message.first_nonfinite` and :meth:`Message.first_invalid` look field by
    field (:func:`_first_bad_kind` accepts some values this refuses: an int64 array whose values fit
    an int32 field)."""
    floats, arrays = _finiteness_plan(message_type)
    specs = {s.name: s for s in message_type.__cosim_fields__}
    env: dict[str, Any] = {"_isfinite": math.isfinite, "_array_sum": _array_sum, "_ints": (int, np.integer),
                           "_bools": (bool, np.bool_)}
    terms = [f"m.{name}" for name in floats]
    for name in arrays:
        array = specs[name].array
        assert array is not None
        small = array.fixed_size is not None and len(array.shape) == 1 and array.fixed_size <= _SMALL_ARRAY
        terms.append(f"sum(m.{name}.tolist())" if small else f"_array_sum(m.{name})")
    for i, spec in enumerate(message_type.__cosim_fields__):
        if spec.enum_type is not None:
            # keyed by the members (found by identity, as a component passes them), which an int finds
            # by its equal value
            env[f"_members{i}"] = dict.fromkeys(spec.enum_type, 0.0)
            terms.append(f"_members{i}[m.{spec.name}]")
        # each field of its own kind (_first_bad_kind): a term of 0.0 when it is, else None, whose sum
        # fails; numpy's scalars pass here too (a bool set as depth > 0 is numpy's: looked at field by
        # field, its message took 20 us a check instead of 1)
        elif spec.kind is FieldKind.INT:
            terms.append(f"(0.0 if isinstance(m.{spec.name}, _ints) and not isinstance(m.{spec.name}, _bools) "
                         f"and {INT64_RANGE[0]} <= m.{spec.name} <= {INT64_RANGE[1]} else None)")
        elif spec.kind is FieldKind.BOOL:
            terms.append(f"(0.0 if isinstance(m.{spec.name}, _bools) else None)")
        elif spec.kind is FieldKind.STR:
            terms.append(f"(0.0 if type(m.{spec.name}) is str else None)")
        elif spec.array is not None and spec.name not in arrays:
            # a non-float array (a float one is summed above, which a list or a complex array fails)
            env[f"_dtype{i}"] = np.dtype(spec.array.dtype)
            terms.append(f"(0.0 if m.{spec.name}.dtype == _dtype{i} else None)")
    body = " + ".join(["0.0", *terms])
    # each array's shape as declared: a 2-vector where (3,) was declared sums to a finite number too
    shapes = "".join(f" and {_shape_term(s.name, s.array.shape)}" for s in message_type.__cosim_fields__
                     if s.array is not None)
    exec("def check(m):\n"
         "    try:\n"
         f"        return _isfinite({body}){shapes}\n"
         "    except (AttributeError, TypeError, ValueError, KeyError):\n"
         "        return False\n", env)
    return env["check"]


def _field_spec(name: str, annotation: Any, owner: str) -> FieldSpec:
    origin = typing.get_origin(annotation)
    if origin is typing.Annotated:
        base, *extras = typing.get_args(annotation)
        arrays = [e for e in extras if isinstance(e, Array)]
        if base is np.ndarray and arrays:
            return FieldSpec(name, FieldKind.ARRAY, array=arrays[0])
        annotation = base
    if annotation is float:
        return FieldSpec(name, FieldKind.FLOAT)
    if annotation is bool:
        return FieldSpec(name, FieldKind.BOOL)
    if annotation is int:
        return FieldSpec(name, FieldKind.INT)
    if annotation is str:
        return FieldSpec(name, FieldKind.STR)
    if isinstance(annotation, type) and issubclass(annotation, enum.IntEnum):
        return FieldSpec(name, FieldKind.ENUM, enum_type=annotation)
    raise TypeError(
        f"{owner}.{name}: unsupported message field type {annotation!r} "
        "(use float, int, bool, str, an IntEnum, or Annotated[np.ndarray, Array(dtype, shape)])"
    )


_T = typing.TypeVar("_T", bound=type)


def message(cls: _T) -> _T:
    """Class decorator: make ``cls`` a frozen dataclass message and record its field layout."""
    own_init = "__init__" in vars(cls)  # a class's own __init__ is kept, as dataclass keeps it
    cls = dataclass(frozen=True, eq=False)(cls)
    hints = typing.get_type_hints(cls, include_extras=True)
    specs = tuple(
        _field_spec(f.name, hints[f.name], cls.__name__) for f in dataclasses.fields(cls)
    )
    cls.__cosim_fields__ = specs
    fast = None if own_init else _fast_init(cls)
    if fast is not None:
        cls.__init__ = fast
    return cls


def _fast_init(cls: type) -> Any:
    """An ``__init__`` for a frozen message type that stores each field in the instance's dict.

    The frozen dataclass's own ``__init__`` goes through ``object.__setattr__`` once per field,
    up to 3.5 times the cost of this one (a 14-field body state: 2.52 us against 0.72 us), and
    every component builds messages every step. The instances stay frozen: only
    ``__init__`` writes the dict, as ``dataclasses`` documents for frozen classes. Same signature,
    defaults and ``__post_init__``; None (keep the dataclass's) for a field this does not handle
    (``init=False``, keyword-only, an ``InitVar`` or ``ClassVar``, a name starting with ``_`` or
    ``self``, which the generated code uses) or a class whose instances have no dict.
    """
    if any("__slots__" in vars(c) for c in cls.__mro__[:-1]):
        return None
    fields = dataclasses.fields(cls)
    if any(f.name == "self" or f.name.startswith("_") for f in fields):
        return None
    # __dataclass_fields__ also holds the pseudo-fields (InitVar, ClassVar) that fields() leaves out
    if any(not f.init or f.kw_only for f in fields) or len(cls.__dataclass_fields__) != len(fields):
        return None
    env: dict[str, Any] = {"_MISSING": dataclasses.MISSING}
    params, body = [], []
    for f in fields:
        if f.default is not dataclasses.MISSING:
            env[f"_default_{f.name}"] = f.default
            params.append(f"{f.name}=_default_{f.name}")
        elif f.default_factory is not dataclasses.MISSING:
            env[f"_factory_{f.name}"] = f.default_factory
            params.append(f"{f.name}=_MISSING")
            body.append(f"    if {f.name} is _MISSING: {f.name} = _factory_{f.name}()")
        else:
            params.append(f.name)
        body.append(f"    _d[{f.name!r}] = {f.name}")
    if hasattr(cls, "__post_init__"):
        body.append("    self.__post_init__()")
    exec(f"def __init__(self, {', '.join(params)}):\n    _d = self.__dict__\n" + "\n".join(body) + "\n", env)
    init = env["__init__"]
    init.__qualname__ = f"{cls.__qualname__}.__init__"
    init.__module__ = cls.__module__
    return init


def fields_of(message_type: type[Message]) -> tuple[FieldSpec, ...]:
    """The field layout of a message type."""
    specs = message_type.__dict__.get("__cosim_fields__")
    if specs is None:
        raise TypeError(f"{message_type.__name__} is not a message type (missing @message)")
    return specs


def messages_equal(a: Message, b: Message) -> bool:
    """Exact equality, bit for bit on floats and arrays (NaN equals NaN of the same bits)."""
    return first_difference(a, b) is None


def first_difference(a: Message, b: Message) -> str | None:
    """Name of the first field where ``a`` and ``b`` differ bit for bit, or None if identical."""
    if type(a) is not type(b):
        return "<type>"
    for spec in fields_of(type(a)):
        x, y = getattr(a, spec.name), getattr(b, spec.name)
        if spec.kind is FieldKind.ARRAY:
            x, y = np.asarray(x), np.asarray(y)
            if x.shape != y.shape or x.dtype != y.dtype or x.tobytes() != y.tobytes():
                return spec.name
        elif spec.kind is FieldKind.FLOAT:
            if np.float64(x).tobytes() != np.float64(y).tobytes():
                return spec.name
        elif x != y:
            return spec.name
    return None
