"""Contact response for colliding spheres as taichi functions, and the kernel that runs a
sphere scene: per step, kick-drift (gravity, drag, springs to anchors: `particle_accel`),
contacts found on the drifted positions (contact_detection), Gauss-Seidel passes over the
contact list, each approaching contact getting Newton's impulse J_n = -(1 + e) u.n /
(1/m_a + 1/m_b) and Coulomb friction by Guendelman, Bridson & Fedkiw 2003 (stick if the
impulse stopping the slip is within mu J_n, else slide with mu J_n), until a pass finds
nothing approaching (at most max_passes); then one pass of positional projection out of
overlap, split by inverse mass (velocities untouched). Every impulse is a full binary impact,
so at e = 1, mu = 0 energy is conserved to round-off however many contacts a step holds, and
the cradle's impacts propagate as the ideal sequence. Walls' impulses are summed into
C.wall_impulse.
No `from __future__ import annotations` here: taichi reads `ti.template()` annotations as objects.
"""
from .contact_detection import find_contacts
from .kernel_types import f64, i32, nd_f64, nd_i32, nd_i64, nd_vec3, ti, vec3
from .particle_kernels import particle_accel, particles_t

contacts_t = ti.types.argpack(
    radius=nd_f64, inv_inertia=nd_f64, wall_point=nd_vec3, wall_normal=nd_vec3,
    n_walls=i32, restitution=f64, friction=f64, slop=f64, approach_tol=f64, cell_min=f64,
    max_passes=i32, toi_normal=i32, cell_count=nd_i32, cell_start=nd_i32, cell_of=nd_i32,
    order=nd_i32, sorted_x=nd_vec3, contact_a=nd_i32, contact_b=nd_i32, contact_n=nd_vec3,
    wall_impulse=nd_vec3, stats=nd_i64, depth_max=nd_f64)


# -- impulses -------------------------------------------------------------------------------
@ti.func
def contact_impulse(u, n, kn, kt, e, mu):
    """Impulse on b for a relative contact velocity u (b minus a), normal n. Sphere
    contacts decouple: du = kn J_n n + kt J_t (kn = 1/m_a + 1/m_b, kt = kn + r_a^2/I_a +
    r_b^2/I_b). Newton: J_n = -(1 + e) u.n / kn. Coulomb (Guendelman 2003): stick with
    J_t = -u_t / kt when |J_t| <= mu J_n, else slide with mu J_n against u_t."""
    un = u.dot(n)
    jn = -(1.0 + e) * un / kn
    J = jn * n
    if mu > 0.0:
        ut = u - un * n
        jt = -ut / kt
        if jt.norm() <= mu * jn:
            J += jt
        else:
            J -= (mu * jn / ut.norm()) * ut
    return J


@ti.func
def apply_contact(v: ti.template(), w: ti.template(), P: ti.template(), C: ti.template(), c):
    """One Gauss-Seidel update of contact c when it approaches (u.n below -approach_tol
    times the contact points' speeds); returns 1 if an impulse was applied."""
    a, b, n = C.contact_a[c], C.contact_b[c], C.contact_n[c]
    rb = C.radius[b]
    ub = v[b] - rb * w[b].cross(n)
    ra, inv_ma, inv_ia, ua = 0.0, 0.0, 0.0, vec3(0.0, 0.0, 0.0)
    if a >= 0:
        ra, inv_ma, inv_ia = C.radius[a], P.inv_m[a], C.inv_inertia[a]
        ua = v[a] + ra * w[a].cross(n)
    u = ub - ua
    hit = 0
    if u.dot(n) < -C.approach_tol * (ub.norm() + ua.norm()):
        inv_mb, inv_ib = P.inv_m[b], C.inv_inertia[b]
        kn = inv_ma + inv_mb
        J = contact_impulse(u, n, kn, kn + ra * ra * inv_ia + rb * rb * inv_ib,
                            C.restitution, C.friction)
        v[b] += inv_mb * J
        w[b] -= (rb * inv_ib) * n.cross(J)
        if a >= 0:
            v[a] -= inv_ma * J
            w[a] -= (ra * inv_ia) * n.cross(J)
        else:
            C.wall_impulse[0] += J
        hit = 1
    return hit


@ti.func
def resolve(v: ti.template(), w: ti.template(), P: ti.template(), C: ti.template(), nc):
    """Gauss-Seidel passes over the contact list until a pass finds no approaching
    contact, at most C.max_passes. Returns (passes, impulses, still approaching)."""
    passes, impulses, active = 0, 0, 0
    for _ in range(C.max_passes):
        active = 0
        for c in range(nc):
            active += apply_contact(v, w, P, C, c)
        passes += 1
        impulses += active
        if active == 0:
            break
    return passes, impulses, active


@ti.func
def project(x: ti.template(), P: ti.template(), C: ti.template(), nc):
    """One pass, contact by contact: overlapping spheres are pushed apart along the
    current centre line, the depth split by inverse mass; a sphere in a wall is moved out
    along the wall normal. Velocities are untouched. C.depth_max keeps the deepest
    overlap met (before its projection)."""
    for c in range(nc):
        a, b = C.contact_a[c], C.contact_b[c]
        if a >= 0:
            d = x[b] - x[a]
            dist = d.norm()
            depth = C.radius[a] + C.radius[b] - dist
            if depth > 0.0 and dist > 0.0:
                C.depth_max[0] = ti.max(C.depth_max[0], depth)
                share = P.inv_m[a] / (P.inv_m[a] + P.inv_m[b])
                x[a] -= (depth * share / dist) * d
                x[b] += (depth * (1.0 - share) / dist) * d
        else:
            nw = C.wall_normal[-1 - a]
            gap = (x[b] - C.wall_point[-1 - a]).dot(nw) - C.radius[b]
            if gap < 0.0:
                C.depth_max[0] = ti.max(C.depth_max[0], -gap)
                x[b] -= gap * nw


@ti.func
def record(C: ti.template(), nc, passes, impulses, active):
    """stats: 0 dropped contacts, 1 steps without a grid (non-finite), 2 most passes in a
    step, 3 steps ending at the pass cap with a contact still approaching, 4 impulses,
    5 contacts found, 6 steps."""
    C.stats[2] = ti.max(C.stats[2], passes)
    if active > 0:
        C.stats[3] += 1
    C.stats[4] += impulses
    C.stats[5] += nc
    C.stats[6] += 1


@ti.kernel
def advance_spheres(x: nd_vec3, v: nd_vec3, w: nd_vec3, P: particles_t, C: contacts_t,
                    h: f64, n: ti.i32):
    ti.loop_config(serialize=True)  # the time loop: serial, and so is everything inside
    for _ in range(n):
        for i in range(x.shape[0]):  # kick-drift, refsim's symplectic_euler
            v[i] = v[i] + h * particle_accel(P, i, x[i], v[i])
            x[i] = x[i] + h * v[i]
        nc = find_contacts(x, v, C, h)
        passes, impulses, active = resolve(v, w, P, C, nc)
        project(x, P, C, nc)
        record(C, nc, passes, impulses, active)
