"""What the static FEM cases share: one "step" is one complete equilibrium solve (the scene's
meta solve = "static"), t_end = dt = 1, no order in dt, no energy; the observable is every
node's position x (m), the error per sample the 2-norm of x - x_ref over all nodes and
components; before the solve the reference is the initial configuration.

The bound of a converged static solve at the exact equilibrium x* (linear algebra, no
constants tuned): with K the free dofs' tangent stiffness at x*, e = x - x* satisfies
K e = r + O(|e|^2) with r the residual left at x, so ||e||_2 <= ||r||_2 / lambda_min(K) and
||r||_2 <= sqrt(n_free dofs) max |r|. A Newton solve stops at max |r| <= rtol x the force
scale (the largest of the loads and the internal forces, reactions included), or once its
update is below the positions' round-off, where max |r| is the forces' own rounding: each
nodal force is a sum of products of stiffnesses and coordinates, so its rounding is about
eps x lambda_max(K) x max |x| (times a small count of terms, ROUNDING_TERMS). The bound is
the larger of the two, through 1 / lambda_min, plus the reference's own rounding (eps max
|x| per coordinate).
"""
from __future__ import annotations

import numpy as np

from refsim.case import EPS, SteadyCase
from refsim.models.fem.assembly import Assembler
from refsim.models.fem.model import ElasticBody

NEWTON_RTOL = 1e-12  # the solve's stop where the row's settings name none (`newton_rtol`)
ROUNDING_TERMS = 64  # products summed into one nodal force (valence x element dofs) and the
#                      differences x_b - x_a each carries, a generous count for P1 meshes
DENSE_DOFS = 1200  # free dofs up to which the stiffness' extremes come from a dense solve
EIGSH_TOL = 1e-8  # ARPACK's relative tolerance on the extremes above that


def free_stiffness_extremes(mesh, x) -> tuple[float, float]:
    """(lambda_min, lambda_max) of the tangent stiffness on the free dofs at world positions x
    (n, 3): dense up to DENSE_DOFS free dofs; above, ARPACK (scipy eigsh: the largest, and
    the smallest by shift-invert about 0) to a relative EIGSH_TOL, lambda_min taken that much
    lower and lambda_max that much higher so that the bound only widens."""
    body = ElasticBody.of(mesh)
    k = Assembler(body).stiffness(body.to_local(x)).tocsr()
    free = np.repeat(np.ones(len(mesh), bool), body.d)
    free.reshape(len(mesh), body.d)[mesh.pinned] = False
    k = k[free][:, free]
    if k.shape[0] <= DENSE_DOFS:
        eig = np.linalg.eigvalsh(k.toarray())
        return float(eig[0]), float(eig[-1])
    from scipy.sparse.linalg import eigsh
    top = eigsh(k, 1, which="LA", tol=EIGSH_TOL, return_eigenvectors=False)[0]
    low = eigsh(k.tocsc(), 1, sigma=0.0, which="LM", tol=EIGSH_TOL,
                return_eigenvectors=False)[0]
    return float(low) * (1 - 10 * EIGSH_TOL), float(top) * (1 + 10 * EIGSH_TOL)


def internal_forces(mesh, x) -> np.ndarray:
    """(n, d) internal forces of the mesh's body at world positions x (N)."""
    body = ElasticBody.of(mesh)
    return body.forces(body.to_local(x))


class StaticCase(SteadyCase):
    observable, units = "x", "m"

    def mesh(self, p):
        raise NotImplementedError

    def exact(self, p) -> np.ndarray:
        """(n, 3) the exact equilibrium positions."""
        raise NotImplementedError

    def bodies(self, p):
        return len(self.mesh(p))

    def observables(self, p, obs):
        out = {"x": np.asarray(obs["x"], float)}
        for name in ("residual", "iterations"):
            if name in obs:
                out[name] = np.asarray(obs[name], float)
        return out

    def reference(self, p, t):
        solved = np.asarray(t, float) >= 1.0 - 1e-12
        initial, exact = np.asarray(self.mesh(p).positions), self.exact(p)
        return {"x": np.where(solved[:, None, None], exact, initial)}

    def motion_scale(self, p):
        """The 2-norm of the displacement from the initial to the exact configuration (m)."""
        return float(np.linalg.norm(self.exact(p) - self.mesh(p).positions))

    def error_floor(self, p):
        return self.solve_bound(p)[0]

    def extra_metrics(self, p, obs, observed, reference):
        out = {}
        if "residual" in observed:
            out["residual"] = float(observed["residual"][-1])
            out["iterations"] = int(observed["iterations"][-1])
        return out

    def loads(self, p) -> np.ndarray:
        return np.asarray(self.mesh(p).loads)

    def solve_bound(self, p, rtol=NEWTON_RTOL) -> tuple[float, str]:
        """(bound on ||x - x*||_2 in m, its reason) for a solve stopping at `rtol` of the
        force scale: module docstring."""
        mesh, exact = self.mesh(p), self.exact(p)
        lam_min, lam_max = free_stiffness_extremes(mesh, exact)
        scale = max(np.abs(self.loads(p)).max(initial=0.0),
                    np.abs(internal_forces(mesh, exact)).max(initial=0.0))
        size = float(np.abs(exact).max())
        dofs = (len(mesh) - len(mesh.pinned)) * ElasticBody.of(mesh).d
        stop = rtol * scale
        rounding = ROUNDING_TERMS * EPS * lam_max * size
        bound = np.sqrt(dofs) * max(stop, rounding) / lam_min + np.sqrt(3 * len(mesh)) * EPS * size
        return float(bound), (
            f"||x - x*||_2 <= sqrt({dofs} dofs) max|r| / lambda_min(K) = "
            f"{lam_min:.4g} N/m: max|r| the larger of the solve's stop {rtol:g} x "
            f"{scale:.3g} N and the forces' rounding {ROUNDING_TERMS} eps lambda_max "
            f"{lam_max:.3g} N/m x max|x| {size:.3g} m; plus the reference's rounding")

    def tolerance(self, p, integrator, order, dt, engine_variant="", settings=None):
        """The static solve's bound at the rtol the row's engine states (`newton_rtol`)."""
        return self.solve_bound(p, float((settings or {}).get("newton_rtol", NEWTON_RTOL)))
