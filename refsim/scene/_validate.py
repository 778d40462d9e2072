"""Validation helpers shared by the scene parts.

Every check raises `ValueError` naming the field (`part.field`) and its valid range. Arrays are
copied once into float64 (or int64) and made read-only; a part never hands out a writable view.
"""
from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

Vec = tuple[float, float, float]

# a row whose norm is within this of 1 is a unit vector to round-off and is stored unchanged
# (renormalising it could move its last bit; records normalised once must keep their values;
# v / |v| is unit within a few eps, far inside this)
UNIT_ROUND_OFF = 1e-14


def _set(obj, name: str, value) -> None:
    object.__setattr__(obj, name, value)


def _vec(name: str, value) -> Vec:
    arr = np.asarray(value, dtype=float).reshape(-1)
    if arr.shape != (3,):
        raise ValueError(f"{name} must have 3 components, got {arr.size}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite, got {tuple(arr)}")
    return tuple(float(c) for c in arr)


def _positive(name: str, value: float) -> float:
    value = float(value)
    if not math.isfinite(value) or value <= 0:
        raise ValueError(f"{name} must be a finite number > 0, got {value}")
    return value


def _nonnegative(name: str, value: float) -> float:
    value = float(value)
    if not math.isfinite(value) or value < 0:
        raise ValueError(f"{name} must be a finite number >= 0, got {value}")
    return value


def read_only(arr: np.ndarray) -> np.ndarray:
    arr.flags.writeable = False
    return arr


def _shape_text(shape) -> str:
    dims = ["*" if d is None else str(d) for d in shape]
    return "(" + ", ".join(dims) + ("," if len(dims) == 1 else "") + ")"


def _check_shape(name: str, arr: np.ndarray, shape) -> None:
    if arr.ndim != len(shape) or any(w is not None and w != d for w, d in zip(shape, arr.shape)):
        raise ValueError(f"{name} must have shape {_shape_text(shape)}, got {arr.shape}")


def float_array(name: str, value, shape) -> np.ndarray:
    """A finite float64 copy of `value` with `shape` (None = any length), read-only."""
    try:
        arr = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be an array of numbers of shape "
                         f"{_shape_text(shape)}") from None
    _check_shape(name, arr, shape)
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite")
    return read_only(arr)


def positive_array(name: str, value, shape) -> np.ndarray:
    arr = float_array(name, value, shape)
    if np.any(arr <= 0):
        raise ValueError(f"{name} must be > 0, got min {arr.min()}")
    return arr


def nonnegative_array(name: str, value, shape) -> np.ndarray:
    arr = float_array(name, value, shape)
    if arr.size and arr.min() < 0:
        raise ValueError(f"{name} must be >= 0, got min {arr.min()}")
    return arr


def per_item(name: str, value, count: int, check=float_array) -> np.ndarray:
    """One value per item: a scalar is broadcast to (count,), an array must be (count,)."""
    arr = np.asarray(value, dtype=float)
    if arr.ndim == 0:
        arr = np.full(count, float(arr))
    return check(name, arr, (count,))


def zeros_or(name: str, value, shape) -> np.ndarray:
    """`value` validated as a finite array of `shape`, or zeros of `shape` when None."""
    return float_array(name, np.zeros(shape) if value is None else value, shape)


def index_array(name: str, value, width: int | None, count: int) -> np.ndarray:
    """Integer indices into `count` items: shape (m,) when width is None, else (m, width);
    each in [0, count - 1] and, in a row, all distinct."""
    arr = np.array(value if value is not None else [], dtype=float)
    shape = (None,) if width is None else (None, width)
    if arr.size == 0:
        arr = arr.reshape((0,) if width is None else (0, width))
    _check_shape(name, arr, shape)
    if not np.all(np.isfinite(arr)) or np.any(arr != np.round(arr)):
        raise ValueError(f"{name} must hold integer indices")
    idx = arr.astype(np.int64)
    if idx.size and (idx.min() < 0 or idx.max() >= count):
        raise ValueError(f"{name} must be in [0, {count - 1}], got {idx.min()}..{idx.max()}")
    if width is not None and idx.size:
        ordered = np.sort(idx, axis=1)
        if np.any(ordered[:, 1:] == ordered[:, :-1]):
            raise ValueError(f"{name} must name {width} distinct indices in each row")
    return read_only(idx)


def unit_rows(name: str, value) -> np.ndarray:
    """(m, 3) non-zero vectors, normalised; rows already unit to round-off kept unchanged."""
    arr = np.array(float_array(name, value, (None, 3)))
    norm = np.linalg.norm(arr, axis=1)
    if np.any(norm == 0):
        raise ValueError(f"{name} must be non-zero vectors")
    off = np.abs(norm - 1.0) > UNIT_ROUND_OFF
    arr[off] /= norm[off, None]
    return read_only(arr)


def choice(name: str, value, allowed) -> str:
    if value not in allowed:
        raise ValueError(f"{name} must be one of {list(allowed)}, got {value!r}")
    return value


def _hashable(value):
    if isinstance(value, np.ndarray):
        return (value.shape, value.dtype.str, value.tobytes())
    if isinstance(value, Mapping):
        return tuple(sorted((k, _hashable(v)) for k, v in value.items()))
    if isinstance(value, (tuple, list)):
        return tuple(_hashable(v) for v in value)
    return value


class ArrayPart:
    """Base of the array-holding parts: equality and hash by value (arrays compared exactly,
    so that a frozen dataclass holding numpy arrays can be compared and hashed).

    A subclass sets `kind` (one of PART_KINDS) and returns its features from `features()`."""

    kind = ""

    def _values(self) -> tuple:
        return tuple(getattr(self, f) for f in self.__dataclass_fields__)

    def __eq__(self, other):
        if type(other) is not type(self):
            return NotImplemented
        return _hashable(self._values()) == _hashable(other._values())

    def __hash__(self):
        return hash(_hashable(self._values()))

    def features(self) -> set[str]:
        return set()

    @classmethod
    def of(cls, value):
        """The part itself, or the part built from a tuple of its records (`from_records`)."""
        return value if isinstance(value, cls) else cls.from_records(tuple(value))
