"""Linear springs between a body and a fixed anchor or between two bodies: the `Spring` record
and the `Springs` part (every spring of a scene as read-only arrays, row i = spring i)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._validate import (ArrayPart, Vec, _nonnegative, _positive, _set, _vec, float_array,
                        nonnegative_array, positive_array, read_only)


@dataclass(frozen=True)
class Spring:
    """Linear spring from body `body` to a fixed `anchor` (or to body `other` when given)."""

    body: int
    stiffness: float
    rest_length: float
    anchor: Vec = (0.0, 0.0, 0.0)
    other: int | None = None
    damping: float = 0.0

    def __post_init__(self):
        _set(self, "stiffness", _positive("spring.stiffness", self.stiffness))
        _set(self, "rest_length", _nonnegative("spring.rest_length", self.rest_length))
        _set(self, "damping", _nonnegative("spring.damping", self.damping))
        _set(self, "anchor", _vec("spring.anchor", self.anchor))


def check_spring_bodies(springs, n: int) -> None:
    """Each spring's body (and other body) must index one of the scene's n bodies."""
    for s in springs:
        for idx in (s.body, s.other):
            if idx is not None and not 0 <= idx < n:
                raise ValueError(f"spring body index must be in [0, {n - 1}], got {idx}")


@dataclass(frozen=True, eq=False)
class Springs(ArrayPart):
    """m springs. body (m,) int; other (m,) int, -1 where the spring ends at its anchor;
    anchor (m, 3) m; stiffness (m,) N/m > 0; rest_length (m,) m >= 0; damping (m,) N s/m >= 0
    (force along the spring, proportional to the rate of change of its length)."""

    body: np.ndarray
    other: np.ndarray
    anchor: np.ndarray
    stiffness: np.ndarray
    rest_length: np.ndarray
    damping: np.ndarray

    kind = "springs"

    def __post_init__(self):
        body = read_only(np.array(self.body, dtype=np.int64).reshape(-1))
        m = len(body)
        _set(self, "body", body)
        other = read_only(np.array(self.other, dtype=np.int64).reshape(m))
        if m and other.min() < -1:
            raise ValueError(f"springs.other must be a body index or -1 (anchored), got "
                             f"{other.min()}")
        _set(self, "other", other)
        _set(self, "anchor", float_array("springs.anchor", self.anchor, (m, 3)))
        _set(self, "stiffness", positive_array("springs.stiffness", self.stiffness, (m,)))
        _set(self, "rest_length",
             nonnegative_array("springs.rest_length", self.rest_length, (m,)))
        _set(self, "damping", nonnegative_array("springs.damping", self.damping, (m,)))

    def __len__(self) -> int:
        return len(self.body)

    def features(self) -> set[str]:
        return {"springs"} if len(self) else set()

    @classmethod
    def from_records(cls, springs) -> "Springs":
        return cls(body=np.array([s.body for s in springs], np.int64),
                   other=np.array([-1 if s.other is None else s.other for s in springs],
                                  np.int64),
                   anchor=np.array([s.anchor for s in springs], float).reshape(-1, 3),
                   stiffness=np.array([s.stiffness for s in springs], float),
                   rest_length=np.array([s.rest_length for s in springs], float),
                   damping=np.array([s.damping for s in springs], float))

    def to_records(self) -> tuple[Spring, ...]:
        rows = zip(self.body, self.other, self.anchor, self.stiffness, self.rest_length,
                   self.damping)
        return tuple(Spring(body=int(b), other=None if o < 0 else int(o), anchor=a,
                            stiffness=k, rest_length=r, damping=c)
                     for b, o, a, k, r, c in rows)
