"""pybullet itself: the lazy import with its C-level banner kept off stdout, the stepper's
description, and the one state read every model group uses."""
from __future__ import annotations

import contextlib
import os
import sys

INTEGRATOR = {"name": "symplectic_euler", "order": 1, "family": "symplectic Euler",
              "explicit": True, "symplectic": True,
              "native": "semi-implicit Euler (btMultiBody: velocities, then positions)"}


def import_pybullet():
    """Import lazily (refsim works without pybullet installed), with its C-level
    'pybullet build time' line kept off stdout."""
    with c_stdout_silenced():
        import pybullet
    return pybullet


@contextlib.contextmanager
def c_stdout_silenced():
    """pybullet's C code prints 'pybullet build time: ...' at import and at the first
    connect; on stdout that line would land after `refsim run`'s last line (the run
    directory). Point fds 1 and 2 at /dev/null around the call and flush C's stdio buffers
    there before restoring them (Python exceptions still propagate)."""
    import ctypes
    sys.stdout.flush()
    sys.stderr.flush()
    saved = [os.dup(1), os.dup(2)]
    try:
        with open(os.devnull, "w") as null:
            os.dup2(null.fileno(), 1)
            os.dup2(null.fileno(), 2)
            yield
            try:
                ctypes.CDLL(None).fflush(None)
            except (OSError, AttributeError):
                pass
    finally:
        os.dup2(saved[0], 1)
        os.dup2(saved[1], 2)
        for fd in saved:
            os.close(fd)


def body_state(p, cid, uid, link, velocity=True):
    """(centre-of-mass position, its velocity or None) in the world frame."""
    if link < 0:
        x = p.getBasePositionAndOrientation(uid, physicsClientId=cid)[0]
        return x, (p.getBaseVelocity(uid, physicsClientId=cid)[0] if velocity else None)
    state = p.getLinkState(uid, link, computeLinkVelocity=int(velocity),
                           computeForwardKinematics=1, physicsClientId=cid)
    return state[0], (state[6] if velocity else None)


class OwnsClient:
    """Mixin for a Sim that owns one pybullet physics client (`self.p`, `self.client`): the
    client is disconnected on `close()` and when the Sim is collected, once."""

    def close(self):
        client = getattr(self, "client", None)
        if client is None:
            return
        with contextlib.suppress(Exception):  # already gone (interpreter shutdown)
            if self.p.isConnected(physicsClientId=client):
                self.p.disconnect(physicsClientId=client)
        self.client = None

    def __del__(self):
        self.close()
