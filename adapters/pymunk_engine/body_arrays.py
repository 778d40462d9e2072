"""Every dynamic body of a pymunk Space read and written as numpy arrays (pymunk.batch).

pymunk 7.3.1's `pymunk.batch` (marked experimental upstream) copies body fields in C, in the
order of the space's dynamic-body array (cpSpaceEachBody: insertion order while no body is
removed; sleeping is off) and, per body, in field order position, angle, velocity, angular
velocity, force, torque (pymunk_cffi/extensions.c `pmSpaceBody{Get,Set}IteratorFuncBatched`).
The space's own static body is iterated too once a constraint holds it (after the dynamic
ones): rows past `count` are dropped on read and written as zeros (the set call reads one row
per iterated body, unchecked). One call reads or writes every body: no Python loop over bodies.
"""
from __future__ import annotations

import numpy as np

WIDTHS = {"POSITION": 2, "ANGLE": 1, "VELOCITY": 2, "ANGULAR_VELOCITY": 1, "FORCE": 2,
          "TORQUE": 1}
ORDER = tuple(WIDTHS)


class BodyArrays:
    """Batched access to the `count` dynamic bodies of `space` (added in the order wanted)."""

    def __init__(self, pymunk, space, count: int):
        from pymunk import batch
        self._batch, self.space, self.count = batch, space, count
        self._read_buffer, self._write_buffer = batch.Buffer(), batch.Buffer()
        self._written = None  # keeps the array behind the write buffer alive
        self._flag_cache = {}
        ids = self._ids()
        expected = [b.id for b in space.bodies if b.body_type == pymunk.Body.DYNAMIC]
        if ids[:count] != expected[:count] or len(expected) != count:
            raise RuntimeError("pymunk.batch: the space's dynamic bodies are not the first "
                               f"{count} bodies iterated")
        self.total = len(ids)  # dynamic bodies, then static ones held by constraints

    def _ids(self) -> list:
        buf = self._read_buffer
        buf.clear()
        self._batch.get_space_bodies(self.space, self._batch.BodyFields.BODY_ID, buf)
        return list(memoryview(buf.int_buf()).cast("P"))

    def _fields(self, names):
        """(the BodyFields flag, the names in buffer order), cached: enum.Flag arithmetic
        costs tens of microseconds a call, more than the batched copy itself."""
        key = tuple(names)
        if key not in self._flag_cache:
            self._flag_cache[key] = self._make_fields(key)
        return self._flag_cache[key]

    def _make_fields(self, names):
        unknown = set(names) - set(WIDTHS)
        if unknown:
            raise ValueError(f"body fields must be among {list(ORDER)}, got {sorted(unknown)}")
        flags = self._batch.BodyFields(0)
        for name in names:
            flags |= getattr(self._batch.BodyFields, name)
        return flags, [n for n in ORDER if n in names]

    def read(self, *names) -> dict:
        """{field: (count, width) array} for the fields named (copies)."""
        flags, ordered = self._fields(names)
        buf = self._read_buffer
        buf.clear()
        self._batch.get_space_bodies(self.space, flags, buf)
        flat = np.frombuffer(buf.float_buf(), float)
        width = sum(WIDTHS[n] for n in ordered)
        if flat.size != self.total * width:
            raise RuntimeError(f"pymunk.batch returned {flat.size} values for {self.total} "
                               f"bodies x {width} (bodies added outside this adapter?)")
        table = flat.reshape(self.total, width)[: self.count]
        out, col = {}, 0
        for name in ordered:
            out[name] = table[:, col:col + WIDTHS[name]].copy()
            col += WIDTHS[name]
        return out

    def write(self, **fields) -> None:
        """Set the named fields (each (count, width)) on every body in one call."""
        flags, ordered = self._fields(fields)
        width = sum(WIDTHS[n] for n in ordered)
        table = np.zeros((self.total, width))
        table[: self.count] = np.concatenate(
            [np.asarray(fields[n], float).reshape(self.count, WIDTHS[n]) for n in ordered],
            axis=1)
        table = table.reshape(-1)
        self._written = table
        self._write_buffer.set_float_buf(table)
        self._batch.set_space_bodies(self.space, flags, self._write_buffer)
