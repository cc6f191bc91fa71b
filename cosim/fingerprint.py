"""A value's fingerprint: a short digest that two equal values share, whatever their layout in memory.

Used to tell whether a component's own attributes changed between two checkpoints
(:meth:`cosim.component.Component.unsaved_state`) without keeping a copy of them: equal values give
equal fingerprints even where their pickles differ (a set rebuilt in another order, a dict whose keys
came in another order, equal strings that are or are not one object), and an array is read in place,
never copied. A value whose content cannot be read (an open file, a lock, a native handle) has no
fingerprint: None.
"""

from __future__ import annotations

import hashlib
import types
import zlib
from typing import Any

import numpy as np

MAX_DEPTH = 8  # nesting read into; deeper, the value's content is not told (no fingerprint)

_SCALARS = (type(None), bool, int, float, complex, str, bytes)
_NAMED = (types.FunctionType, types.BuiltinFunctionType, types.MethodType, types.ModuleType, type)


class _Untold(Exception):
    """Raised inside :func:`fingerprint` for a value whose content cannot be read."""


def fingerprint(value: Any) -> str | None:
    """The hex digest of ``value``'s content, or None where it cannot be read."""
    digest = hashlib.blake2b(digest_size=16)
    try:
        _feed(digest, value, 0, set())
    except (_Untold, RecursionError):
        return None
    return digest.hexdigest()


def _feed(digest: Any, value: Any, depth: int, inside: set[int]) -> None:
    if depth > MAX_DEPTH:
        raise _Untold
    if isinstance(value, _SCALARS):
        digest.update(f"{type(value).__name__}:{value!r};".encode())
        return
    if isinstance(value, np.ndarray):
        if value.dtype.hasobject:
            _feed(digest, value.tolist(), depth + 1, inside)
            return
        # its bytes by their CRC, read in place when the array is contiguous (a CRC is about twice as
        # fast as a cryptographic digest over a large table, and a change it misses is a 2^-32 chance)
        content = zlib.crc32(np.ascontiguousarray(value).data)
        digest.update(f"array:{value.dtype.str}:{value.shape}:{content};".encode())
        return
    if isinstance(value, np.generic):
        digest.update(f"{type(value).__name__}:{value!r};".encode())
        return
    if isinstance(value, _NAMED):  # code, not data: known by its name
        digest.update(f"named:{getattr(value, '__module__', '')}.{getattr(value, '__qualname__', value)!s};".encode())
        return
    if id(value) in inside:  # a cycle: its content is being read further up
        digest.update(b"cycle;")
        return
    inside.add(id(value))
    try:
        if isinstance(value, (list, tuple)):
            digest.update(f"{type(value).__name__}[{len(value)};".encode())
            for item in value:
                _feed(digest, item, depth + 1, inside)
        elif isinstance(value, (set, frozenset)):
            digest.update(f"{type(value).__name__}{{{len(value)};".encode())
            for item in sorted(_member(v, depth, inside) for v in value):
                digest.update(item.encode())
        elif isinstance(value, dict):
            digest.update(f"{type(value).__name__}{{{len(value)};".encode())
            for pair in sorted(_member(k, depth, inside) + _member(v, depth, inside) for k, v in value.items()):
                digest.update(pair.encode())
        elif hasattr(value, "__dict__") or hasattr(type(value), "__slots__"):
            fields = dict(vars(value)) if hasattr(value, "__dict__") else {}
            for slot in getattr(type(value), "__slots__", ()):
                if hasattr(value, slot):
                    fields[slot] = getattr(value, slot)
            digest.update(f"object:{type(value).__module__}.{type(value).__qualname__};".encode())
            _feed(digest, fields, depth + 1, inside)
        else:
            raise _Untold
    finally:
        inside.discard(id(value))


def _member(value: Any, depth: int, inside: set[int]) -> str:
    """The digest of a member of a set or a dict (whose order is not the content's: the members are
    sorted by it), read within the same walk (its depth and the cycles above it)."""
    digest = hashlib.blake2b(digest_size=16)
    _feed(digest, value, depth + 1, inside)
    return digest.hexdigest()
