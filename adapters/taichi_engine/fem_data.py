"""One P1 mesh's data for taichi's FEM kernels (adapters/taichi_engine/groups/fem.py builds
the Sims, fem_implicit the implicit ones): the argpack filled from refsim's ElasticBody (rest
shape, law constants, masses, loads) and the settings every FEM Sim of this engine reports.
Apart from the group module so that the implicit Sims import it without a cycle."""
from __future__ import annotations

import numpy as np

from refsim.models.fem.model import ElasticBody

from .kernel_store import arrays_setting, to_taichi


class FemData:
    """One mesh's kernel arguments: the argpack (rest shape from refsim's ElasticBody, law
    constants, masses and ext filled by the setup kernel) and the body for the coordinates."""

    def __init__(self, mesh, gravity):
        from .fem_kernels import kernels
        self.mesh, self.body = mesh, ElasticBody.of(mesh)
        elements, law = self.body.elements, self.body.law
        self.d, self.n = elements.d, elements.n
        self.plane_strain = getattr(mesh, "plane", "") == "strain" and self.d == 2
        plasticity = mesh.material.plasticity
        self.plastic = plasticity is not None
        inner = getattr(law, "base", law)  # von Mises wraps the (3D) elastic law
        inner = getattr(inner, "law", inner)  # plane strain wraps the 3D law
        self.law = {"name": law.name, "mu": inner.mu, "lam": inner.lam,
                    "alpha": float(getattr(inner, "alpha", 0.0))}
        self.linear = law.name == "linear" and not self.plastic  # refsim's ElasticBody.linear
        self.k = kernels(self.d, law.name, self.plane_strain, self.plastic)
        free = np.ones(self.n, bool)
        free[mesh.pinned] = False
        self.free = free
        self.free_index = np.where(free, np.cumsum(free) - 1, -1).astype(np.int32)
        d, vec = self.d, self.k.vec
        self.arrays = {
            "cells": to_taichi(elements.cells.astype(np.int32), self.k.cell),
            "dm_inv": to_taichi(elements.dm_inv, self.k.mat),
            "volume": to_taichi(elements.volume), "mass": to_taichi(np.zeros(self.n)),
            "inv_m": to_taichi(np.zeros(self.n)),
            "loads": to_taichi(self.body.to_local(mesh.loads), vec),
            "ext": to_taichi(np.zeros((self.n, d)), vec),
            "free_index": to_taichi(self.free_index), **self._fresh_state()}
        self.scalars = {"density": float(mesh.material.density),
                        "gravity": vec(*self.body.to_local(np.asarray(gravity, float))),
                        "mu": self.law["mu"], "lam": self.law["lam"], "alpha": self.law["alpha"],
                        "sigma_y": float(plasticity.yield_stress) if self.plastic else 0.0,
                        "hardening": float(plasticity.hardening) if self.plastic else 0.0}
        self.pack = self.k.pack_t(**self.arrays, **self.scalars)
        self.k.setup(self.pack)

    def _fresh_state(self) -> dict:
        """Zero plastic strain eps_p (m, 3 x 3) and equivalent plastic strain (m,) (unused
        by an elastic material's kernels)."""
        m = len(self.body.elements.cells)
        return {"eps_p": to_taichi(np.zeros((m, 3, 3)), self.k.mat3),
                "equiv": to_taichi(np.zeros(m))}

    def compile_commit(self, x):
        """Compiles the `commit` kernel on a copy of the pack with a fresh plastic state (the
        mesh's own committed state untouched)."""
        self.k.commit(self.k.pack_t(**{**self.arrays, **self._fresh_state()}, **self.scalars),
                      np.ascontiguousarray(x))

    def plastic_state(self):
        """(eps_p (m, 3, 3), equivalent plastic strain (m,)) committed so far."""
        return self.arrays["eps_p"].to_numpy(), self.arrays["equiv"].to_numpy()

    def masses(self) -> np.ndarray:
        return self.arrays["mass"].to_numpy()

    def external(self) -> np.ndarray:
        """(n, d) loads + m g in the body's coordinates."""
        return self.arrays["ext"].to_numpy()

    def local(self, world) -> np.ndarray:
        """A writable C-contiguous copy in body coordinates (the kernels write it in place;
        a read-only array, as the mesh's own, would be copied by taichi and left unchanged)."""
        return np.array(self.body.to_local(world), dtype=np.float64, order="C", copy=True)

    def world(self, x, vectors=False) -> np.ndarray:
        """(n, 3) world points (pinned nodes exactly at the mesh's positions) or vectors."""
        out = np.array(self.body.to_world(x, vectors=vectors), float)
        if not vectors:
            out[~self.free] = self.mesh.positions[~self.free]
        return out

    def forces(self, x) -> np.ndarray:
        """(n, d) elastic nodal forces at body coordinates x (the kernel; for tests)."""
        f = np.zeros((self.n, self.d))
        self.k.forces(self.pack, np.ascontiguousarray(x, dtype=np.float64), f)
        return f

    def model(self) -> dict:
        return {"law": self.law["name"], "mu": self.law["mu"], "lam": self.law["lam"],
                "alpha": self.law["alpha"], "elements": len(self.body.elements.cells),
                "nodes": self.n,
                "element": "P1 triangle" if self.d == 2 else "P1 tetrahedron",
                "plane": (getattr(self.mesh, "plane", None) if self.d == 2 else None),
                "free_nodes": int(self.free.sum()), "pinned": int(len(self.mesh.pinned)),
                "mass": "lumped (rho V / (d + 1) per element node, refsim's FemSystem's)",
                "damping": "none", "rest_shape": "Dm^-1, V from refsim's ElasticBody (numpy)",
                "plasticity": ({"rule": "von Mises, radial return (refsim's), f64 kernel",
                                "yield_stress": self.scalars["sigma_y"],
                                "hardening": self.scalars["hardening"],
                                "commit": "after every accepted step (every stepper)",
                                "tangent": "the elastic law's"} if self.plastic else None),
                "rotation": ("2D closed form (c, s) = (F00 + F11, F10 - F01) / r"
                             if self.d == 2 and not self.plane_strain else
                             "ti.polar_decompose (Sifakis SVD, ~1e-10) + 2 Newton polish "
                             "steps (round-off)") if self.law["name"] == "corotated" else None}


def base_settings(sim) -> dict:
    from .runtime import THREADS, effective_config
    return {"dtype": "float64", "threads": THREADS, **effective_config(),
            "model": sim.data.model(), "arrays": arrays_setting("x", "v"),
            "compile": "cold JIT in this build" if sim.cold else
            "kernels already compiled in this process (launch time only)",
            "force_sums": "per node in element order (atomic adds in a serialized loop)"}
