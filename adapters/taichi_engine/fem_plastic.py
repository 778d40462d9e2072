"""Float64 taichi functions of refsim.models.fem.plasticity's von Mises law: the radial return
(Simo & Hughes 1998, Box 3.2; ideal sigma_y, or linear isotropic hardening H) from an
element's COMMITTED plastic strain eps_p (3 x 3) and equivalent plastic strain a, on the
additive split of the law's own strain measure, in refsim's formulas and operation order:

    eps, factor = 1/2 (F + F^T) - I, -            ("linear": P = sigma)
                  1/2 (F^T F - I), F              ("green": P = F sigma)
                  V diag(s) V^T - I, U V^T        ("corotated": F = U diag(s) V^T by svd3,
                                                   the rotation-variant SVD; P = R sigma)
    trial = eps - eps_p, dev = trial - tr(trial)/3 I, |s| = 2 mu |dev|_F,
    over = |s| - sqrt(2/3) (sigma_y + H a), dgamma = max(over, 0) / (2 mu + 2 H / 3),
    n = 2 mu dev / |s| (0 where |s| = 0), elastic = trial - dgamma n,
    sigma = lam tr(elastic) I + 2 mu elastic;
    committed: eps_p + dgamma n, a + sqrt(2/3) dgamma.

3D only (tetrahedra) or plane strain (the triangle's F padded to diag(F, 1), the stress's
in-plane block; eps_p keeps its zz entry), the laws linear, green and corotated, as refsim's
VonMises accepts. The tangent of the implicit steppers and the static solve stays the
elastic law's (refsim's `VonMises.tangent`). The argpack P carries eps_p (m, 3 x 3), equiv
(m), sigma_y and hardening; `commit` writes them.
No `from __future__ import annotations` here: taichi reads annotations as objects.
"""
import math

from .fem_stress import block, eye, pad, svd3
from .kernel_types import f64, ti

ROOT_2_3 = math.sqrt(2.0 / 3.0)  # refsim's np.sqrt(2.0 / 3.0): the same correctly rounded value


def plastic_functions(law: str, plane_strain: bool):
    """(stress(P, F, e), commit(P, F, e)) ti.funcs of the von Mises law around `law`."""

    @ti.func
    def strain(F):
        """(eps, factor) of a 3 x 3 F (module docstring); factor = I for the linear law."""
        eps, factor = F, eye(3)
        if ti.static(law == "linear"):
            eps = 0.5 * (F + F.transpose()) - eye(3)
        elif ti.static(law == "green"):
            eps, factor = 0.5 * (F.transpose() @ F - eye(3)), F
        else:
            U, sv, V = svd3(F)
            vt = V.transpose()
            scaled = ti.Matrix.zero(f64, 3, 3)
            for i in ti.static(range(3)):
                for j in ti.static(range(3)):
                    scaled[i, j] = sv[i] * vt[i, j]
            eps, factor = V @ scaled - eye(3), U @ vt
        return eps, factor

    @ti.func
    def radial_return(P: ti.template(), F, e):
        """(sigma, factor, eps_p + dgamma n, a + sqrt(2/3) dgamma) at a 3 x 3 F."""
        eps, factor = strain(F)
        mu, hard = P.mu, P.hardening
        trial = eps - P.eps_p[e]
        dev = trial - trial.trace() / 3.0 * eye(3)
        s_norm = 2.0 * mu * ti.sqrt((dev * dev).sum())
        over = s_norm - ROOT_2_3 * (P.sigma_y + hard * P.equiv[e])
        dgamma = 0.0
        if over > 0.0:
            dgamma = over
        dgamma = dgamma / (2.0 * mu + 2.0 * hard / 3.0)
        unit = ti.Matrix.zero(f64, 3, 3)
        if s_norm > 0.0:
            unit = (2.0 * mu * dev) / s_norm
        elastic = trial - dgamma * unit
        sigma = P.lam * elastic.trace() * eye(3) + 2.0 * mu * elastic
        return sigma, factor, P.eps_p[e] + dgamma * unit, P.equiv[e] + ROOT_2_3 * dgamma

    @ti.func
    def padded(F):
        out = ti.Matrix.zero(f64, 3, 3)
        if ti.static(plane_strain):
            out = pad(F, 1.0)
        else:
            out = F
        return out

    @ti.func
    def stress(P: ti.template(), F, e):
        """The first Piola stress of element e at F (d x d) after the return."""
        sigma, factor, _, _ = radial_return(P, padded(F), e)
        full = sigma
        if ti.static(law != "linear"):
            full = factor @ sigma
        out = F
        if ti.static(plane_strain):
            out = block(full)
        else:
            out = full
        return out

    @ti.func
    def commit(P: ti.template(), F, e):
        """Make the return at F permanent (refsim's VonMises.commit)."""
        _, _, eps_p, equiv = radial_return(P, padded(F), e)
        P.eps_p[e] = eps_p
        P.equiv[e] = equiv

    return stress, commit
