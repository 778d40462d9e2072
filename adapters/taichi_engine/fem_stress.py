"""Float64 taichi functions of the hyperelastic laws of refsim.models.fem.laws, in the same
formulas and (where the arithmetic allows) the same operation order: the first Piola stress
P(F) and its directional derivative dP = (dP/dF) : dF (the static Newton solve's tangent),
for one element's constant F (d x d, d = F.n = 2 or 3).

- linear (Cauchy as printed): eps = 1/2 (F + F^T) - I, P = 2 mu eps + lam tr(eps) I;
- green (St Venant-Kirchhoff): E = 1/2 (F^T F - I), P = F (2 mu E + lam tr(E) I);
- corotated: P = 2 mu (F - R) + lam (tr S - d) R, F = R S, R the rotation maximising
  tr(R^T F) (refsim's rotation-variant SVD: a rotation even for an inverted element);
- neo_hookean (Smith et al. 2018's stable energy, refsim's reparametrised mu, lam, alpha):
  P = mu (1 - 1/(I_C + 1)) F + lam (J - alpha) cof F;
- plane strain: the 3D law on diag(F, 1), its in-plane block (`law_functions`).

The rotation R (`rotation`), ti.polar_decompose not used (taichi 1.7.4, measured):
- 2D in closed form: (c, s) = (F00 + F11, F10 - F01) / r, r = |(F00 + F11, F10 - F01)|, and
  tr S = r. ti.polar_decompose agrees to 1e-15 for det F >= 0, but for det F < 0 it returns
  the orthogonal polar factor, a reflection (det U = -1), where refsim's corotated law takes
  the rotation (|R - R_refsim| = 2).
- 3D: `svd3`, a one-sided (Hestenes) Jacobi SVD in f64 run to convergence, R = U V^T.
  ti.polar_decompose (U V^T of taichi's Sifakis-McAdams 3x3 SVD, a fixed 8 sweeps in f64)
  does return a rotation, also for inverted F, but only within 1.2e-10 of the exact factor
  on F = I + 0.2 N(0, 1) (R S = F to 2e-10; 12 to 40 sweeps give the same 1.2e-10): far
  above round-off. It also compiles slowly: 0.7-1.6 s for a kernel holding it alone, and
  with a Newton polish to round-off on top of it a tetrahedral stepper kernel took 7-14 s
  of JIT, against 2.8 s with svd3 (wall time, on the same loaded machine).
A rotation is not unique where s_j + s_k = 0 for two singular values (an element flattened
to a point or a line, or inverted to s_2 = -s_3): tr S I - S is singular there, and so is the
corotated tangent (refsim's too); an element flattened to a line or a point (two zero
singular values) makes svd3 divide by zero: NaN forces, a run reported as diverged.
No `from __future__ import annotations` here: taichi reads annotations as objects.
"""
from .kernel_types import f64, ti

MAX_SWEEPS = 12  # one-sided Jacobi sweeps at most (quadratic convergence: 4-6 suffice)
ORTHOGONAL = 2.0 ** -52  # columns p, q with |a_p . a_q| <= this x |a_p| |a_q| count as orthogonal


@ti.func
def eye(d: ti.template()):
    return ti.Matrix.identity(f64, d)


@ti.func
def linear_stress(F, mu, lam, alpha):
    eps = 0.5 * (F + F.transpose()) - eye(F.n)
    return 2.0 * mu * eps + lam * eps.trace() * eye(F.n)


@ti.func
def linear_differential(F, dF, mu, lam, alpha):
    return mu * (dF + dF.transpose()) + lam * dF.trace() * eye(F.n)


@ti.func
def pk2(E, mu, lam):
    return 2.0 * mu * E + lam * E.trace() * eye(E.n)


@ti.func
def green_stress(F, mu, lam, alpha):
    return F @ pk2(0.5 * (F.transpose() @ F - eye(F.n)), mu, lam)


@ti.func
def green_differential(F, dF, mu, lam, alpha):
    dE = 0.5 * (dF.transpose() @ F + F.transpose() @ dF)
    return dF @ pk2(0.5 * (F.transpose() @ F - eye(F.n)), mu, lam) + F @ pk2(dE, mu, lam)


@ti.func
def rotation2(F):
    """(R, tr S) of a 2x2 F (module docstring); R = I, tr S = 0 where F00 + F11 = F10 - F01
    = 0 (no rotation is preferred there)."""
    x, y = F[0, 0] + F[1, 1], F[1, 0] - F[0, 1]
    r = ti.sqrt(x * x + y * y)
    c, s = 1.0, 0.0
    if r > 0.0:
        c, s = x / r, y / r
    return ti.Matrix([[c, -s], [s, c]], f64), r


@ti.func
def skew3(w):
    return ti.Matrix([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]], f64)


@ti.func
def axial3(k):
    return ti.Vector([k[2, 1], k[0, 2], k[1, 0]], f64)


@ti.func
def svd3(F):
    """(U, s, V) with F = U diag(s) V^T, U and V rotations and the smallest |s_k| carrying
    det F's sign (refsim's rotation-variant SVD; module docstring): one-sided Jacobi on the
    columns of A = F V until a sweep rotates nothing (at most MAX_SWEEPS), then s_i = |A_i|,
    U_i = A_i / s_i for the two larger, U_k their cross product (det U = 1),
    s_k = A_k . U_k."""
    A, V = F, eye(3)
    for _sweep in range(MAX_SWEEPS):
        rotated = 0
        for pair in range(3):
            p, q = 0, 1
            if pair == 1:
                q = 2
            elif pair == 2:
                p, q = 1, 2
            alpha, beta, gamma = 0.0, 0.0, 0.0
            for i in range(3):
                alpha += A[i, p] * A[i, p]
                beta += A[i, q] * A[i, q]
                gamma += A[i, p] * A[i, q]
            if abs(gamma) > ORTHOGONAL * ti.sqrt(alpha * beta):
                rotated += 1
                zeta = (beta - alpha) / (2.0 * gamma)
                t = 1.0 / (abs(zeta) + ti.sqrt(1.0 + zeta * zeta))
                if zeta < 0.0:
                    t = -t
                c = 1.0 / ti.sqrt(1.0 + t * t)
                s = c * t
                for i in range(3):
                    ap, aq, vp, vq = A[i, p], A[i, q], V[i, p], V[i, q]
                    A[i, p], A[i, q] = c * ap - s * aq, s * ap + c * aq
                    V[i, p], V[i, q] = c * vp - s * vq, s * vp + c * vq
        if rotated == 0:
            break
    sv = ti.Vector([0.0, 0.0, 0.0], f64)
    for j in range(3):
        sv[j] = ti.sqrt(A[0, j] * A[0, j] + A[1, j] * A[1, j] + A[2, j] * A[2, j])
    k = 2
    if sv[0] <= sv[1] and sv[0] <= sv[2]:
        k = 0
    elif sv[1] <= sv[2]:
        k = 1
    a, b = (k + 1) % 3, (k + 2) % 3  # (k, a, b) cyclic: U_k = U_a x U_b keeps det U = 1
    ua = ti.Vector([A[0, a], A[1, a], A[2, a]], f64) / sv[a]
    ub = ti.Vector([A[0, b], A[1, b], A[2, b]], f64) / sv[b]
    uk = ua.cross(ub)
    U = eye(3)
    for r in range(3):
        U[r, a], U[r, b], U[r, k] = ua[r], ub[r], uk[r]
    sv[k] = A[0, k] * uk[0] + A[1, k] * uk[1] + A[2, k] * uk[2]
    return U, sv, V


@ti.func
def rotation(F):
    """(R, tr S): 2D closed form, 3D U V^T of `svd3` with tr S = sum s."""
    R, trace = F, 0.0
    if ti.static(F.n == 2):
        R, trace = rotation2(F)
    else:
        U, sv, V = svd3(F)
        R, trace = U @ V.transpose(), sv.sum()
    return R, trace


@ti.func
def corotated_stress(F, mu, lam, alpha):
    R, trace = rotation(F)
    return 2.0 * mu * (F - R) + lam * (trace - F.n) * R


@ti.func
def corotated_differential(F, dF, mu, lam, alpha):
    """dR = R W, W skew with W S + S W = A - A^T, A = R^T dF (refsim's rotation_differential:
    2D w = (A - A^T)_10 / tr S; 3D axial(W) = V diag(1 / (tr S - s_i)) V^T axial(A - A^T))."""
    R, trace, W = F, 0.0, ti.Matrix.zero(f64, F.n, F.n)
    if ti.static(F.n == 2):
        R, trace = rotation2(F)
        A = R.transpose() @ dF
        w = (A[1, 0] - A[0, 1]) / trace
        W = ti.Matrix([[0.0, -w], [w, 0.0]], f64)
    else:
        U, sv, V = svd3(F)  # once: R and V, s for dR
        R, trace = U @ V.transpose(), sv.sum()
        A = R.transpose() @ dF
        inv = 1.0 / (trace - sv)
        W = skew3(V @ (inv * (V.transpose() @ axial3(A - A.transpose()))))
    A = R.transpose() @ dF
    dR = R @ W
    return 2.0 * mu * dF + lam * A.trace() * R + (lam * (trace - F.n) - 2.0 * mu) * dR


@ti.func
def cofactor(F):
    """cof F = J F^-T (2D [[f11, -f10], [-f01, f00]]; 3D columns c1 x c2, c2 x c0, c0 x c1)."""
    out = F
    if ti.static(F.n == 2):
        out = ti.Matrix([[F[1, 1], -F[1, 0]], [-F[0, 1], F[0, 0]]], f64)
    else:
        c0, c1, c2 = F[:, 0], F[:, 1], F[:, 2]
        a, b, c = c1.cross(c2), c2.cross(c0), c0.cross(c1)
        out = ti.Matrix.cols([a, b, c])
    return out


@ti.func
def cofactor_differential(F, dF):
    out = F
    if ti.static(F.n == 2):
        out = cofactor(dF)
    else:
        c0, c1, c2 = F[:, 0], F[:, 1], F[:, 2]
        d0, d1, d2 = dF[:, 0], dF[:, 1], dF[:, 2]
        out = ti.Matrix.cols([d1.cross(c2) + c1.cross(d2), d2.cross(c0) + c2.cross(d0),
                              d0.cross(c1) + c0.cross(d1)])
    return out


@ti.func
def neo_hookean_stress(F, mu, lam, alpha):
    ic = (F * F).sum()
    return (mu * (1.0 - 1.0 / (ic + 1.0))) * F + (lam * (F.determinant() - alpha)) * cofactor(F)


@ti.func
def neo_hookean_differential(F, dF, mu, lam, alpha):
    ic, cof = (F * F).sum(), cofactor(F)
    return ((mu * (1.0 - 1.0 / (ic + 1.0))) * dF
            + (2.0 * mu * (F * dF).sum() / (ic + 1.0) ** 2) * F
            + (lam * (cof * dF).sum()) * cof
            + (lam * (F.determinant() - alpha)) * cofactor_differential(F, dF))


STRESS = {"linear": linear_stress, "green": green_stress, "corotated": corotated_stress,
          "neo_hookean": neo_hookean_stress}
DIFFERENTIAL = {"linear": linear_differential, "green": green_differential,
                "corotated": corotated_differential, "neo_hookean": neo_hookean_differential}


@ti.func
def pad(F, corner):
    """diag(F, corner) of a 2x2 F."""
    return ti.Matrix([[F[0, 0], F[0, 1], 0.0], [F[1, 0], F[1, 1], 0.0], [0.0, 0.0, corner]], f64)


@ti.func
def block(P):
    return ti.Matrix([[P[0, 0], P[0, 1]], [P[1, 0], P[1, 1]]], f64)


def law_functions(law: str, plane_strain: bool):
    """(stress(F, mu, lam, alpha), differential(F, dF, mu, lam, alpha)) ti.funcs of a law;
    plane strain: the 3D law on diag(F, 1) (dF padded with 0), the in-plane block."""
    stress, differential = STRESS[law], DIFFERENTIAL[law]
    if not plane_strain:
        return stress, differential

    @ti.func
    def strain_stress(F, mu, lam, alpha):
        return block(stress(pad(F, 1.0), mu, lam, alpha))

    @ti.func
    def strain_differential(F, dF, mu, lam, alpha):
        return block(differential(pad(F, 1.0), pad(dF, 0.0), mu, lam, alpha))

    return strain_stress, strain_differential
