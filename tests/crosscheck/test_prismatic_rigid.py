"""Rigid limit of planar chains with R, Pa and Pb joints on a fixed base (docs/design-notes.md, Tests).

With every elastic coordinate and its rate zero (``delta = 0``, ``delta_dot = 0``) each link's
deflection ``v`` vanishes identically, so the position map (10.1) is that of a chain of rigid
uniform rods. Then

* the frame origins and the tip (``joint_positions``) are the rigid robot's;
* the joint block of ``M``, the joint entries of ``h`` and of ``dV/dq`` are the rigid robot's:
  ``dp/dj`` and ``d2p/dj dj'`` at ``delta = 0`` are the rigid ones, the convective terms that
  couple joint and elastic rates are multiplied by ``delta_dot = 0``, and the strain energy
  ``1/2 delta^T K(d) delta`` has zero gradient at ``delta = 0``.

The reference below is written by hand from the rigid two-body (n-body) kinematics of
docs/theory.md §7.1 with ``v = 0``; it shares no code with the package. It is checked
here against textbook closed forms (pendulum, double pendulum, cart-pendulum, telescoping arm,
rod in a guide) and against a second route (the transforms of section 10 multiplied out,
derivatives by finite differences), and was checked once, outside the suite, against Lagrange's equations derived
by symbolic differentiation (sympy) of the exactly integrated rigid ``T`` and ``V`` for all nine
two-link combinations and three three-link chains (largest difference 5e-15).

Rigid kinematics (planar; ``e(a) = (cos a, sin a)``, ``n(a) = (-sin a, cos a) = de/da``). Link i
has frame origin ``O_i`` and absolute angle ``phi_i``; base: ``O_0 = b``, ``phi_0 = beta``,
``l_0 = 0``. A material point of link i is ``p = O_i + x e(phi_i)``, ``x in [0, l_i]``.

    R  (theta_i):  O_i = O_(i-1) + l_(i-1) e(phi_(i-1)),                     phi_i = phi_(i-1) + theta_i
    Pa (d_i):      O_i = O_(i-1) + d_i e(phi_(i-1)),                         phi_i = phi_(i-1) + gamma_i
    Pb (d_i):      O_i = O_(i-1) + l_(i-1) e(phi_(i-1)) + (d_i - l_i) e(phi_i),  phi_i = phi_(i-1) + gamma_i
    tip:           O_n + l_n e(phi_n)

Equations of motion of rigid uniform rods (mass m_i = mu_i l_i, mass centre c_i = O_i +
(l_i/2) e(phi_i), central moment of inertia I_i = m_i l_i^2 / 12; no rotary inertia of the
section): with ``c_i_dot = Jc_i q_dot`` and ``phi_i_dot = s_i . q_dot`` (``s_i`` a constant
0/1 vector: phi_i is linear in q),

    T = 1/2 sum_i ( m_i |Jc_i q_dot|^2 + I_i (s_i . q_dot)^2 ),   V = - sum_i m_i g . c_i

and Lagrange's equations ``M q_ddot + h + dV/dq = 0`` give (``d/dt dc/dq_k = d c_dot/dq_k``)

    M     = sum_i m_i Jc_i^T Jc_i + I_i s_i s_i^T
    h     = sum_i m_i Jc_i^T a_i,     a_i = d/dt(Jc_i) q_dot  (acceleration of c_i at q_ddot = 0)
    dV/dq = - sum_i m_i Jc_i^T g

(the rotational term contributes nothing to h because s_i is constant). The columns of
``Jc_i`` and the vectors ``a_i`` follow from differentiating the recursion above:
with ``w_i = phi_i_dot``,

    R : dO_i = dO_(i-1) + l_(i-1) n_(i-1) s_(i-1)^T
        a(O_i) = a(O_(i-1)) - l_(i-1) w_(i-1)^2 e_(i-1)
    Pa: dO_i = dO_(i-1) + d_i n_(i-1) s_(i-1)^T + e_(i-1) u_i^T
        a(O_i) = a(O_(i-1)) + 2 d_i_dot w_(i-1) n_(i-1) - d_i w_(i-1)^2 e_(i-1)
    Pb: dO_i = dO_(i-1) + l_(i-1) n_(i-1) s_(i-1)^T + (d_i - l_i) n_i s_i^T + e_i u_i^T
        a(O_i) = a(O_(i-1)) - l_(i-1) w_(i-1)^2 e_(i-1) + 2 d_i_dot w_i n_i - (d_i - l_i) w_i^2 e_i
    Jc_i = dO_i + (l_i/2) n_i s_i^T,    a_i = a(O_i) - (l_i/2) w_i^2 e_i

(``u_i`` = unit vector of coordinate i; for Pa/Pb ``s_i = s_(i-1)``, ``w_i = w_(i-1)``).
"""

import functools
import itertools
import re
import zlib

import numpy as np
import pytest

import gibbsimpact as gi

G = 9.81
GRAVITY = (0.0, -G, 0.0)
BASE, BETA = (0.3, -0.2), 0.4
C = 0.05  # carriage half-length of every Pa joint
# Link (length, mass per length, EI, elements) for two- and three-link chains.
LINKS2 = [(1.0, 1.2, 25.0, 3), (0.6, 0.5, 8.0, 2)]
LINKS3 = [(1.0, 1.2, 25.0, 3), (0.8, 0.9, 12.0, 2), (0.6, 0.5, 8.0, 2)]
GAMMA = {"Pa": (0.5, -0.7, 0.9), "Pb": (0.3, -0.4, 0.6)}  # gamma_i per joint type and position i
COMBOS = [a + "-" + b for a, b in itertools.product(("R", "Pa", "Pb"), repeat=2)]


# --------------------------------------------------------------------------- the rigid reference
def _e(a):
    return np.array([np.cos(a), np.sin(a)])


def _n(a):
    return np.array([-np.sin(a), np.cos(a)])


def rigid_reference(spec, q, qd, base=BASE, beta=BETA, gravity=GRAVITY):
    """Rigid uniform-rod chain (module docstring): points (n+1, 2), M (n, n), h (n,), dV/dq (n,).

    spec: list of (kind, gamma, length, mass) with kind "R", "Pa" or "Pb" (gamma unused for R).
    """
    nj = len(spec)
    g = np.asarray(gravity, dtype=float)[:2]
    O, phi, l_host = np.asarray(base, dtype=float), beta, 0.0
    dO, s, aO = np.zeros((2, nj)), np.zeros(nj), np.zeros(2)  # dO_i/dq, dphi_i/dq, acceleration of O_i
    M, h, dV, points = np.zeros((nj, nj)), np.zeros(nj), np.zeros(nj), []
    for i, (kind, gamma, l, m) in enumerate(spec):
        u = np.eye(nj)[i]
        w = s @ qd  # host's angular velocity
        eh, nh = _e(phi), _n(phi)
        if kind == "R":
            O = O + l_host * eh
            dO = dO + l_host * np.outer(nh, s)
            aO = aO - l_host * w**2 * eh
            phi, s = phi + q[i], s + u
        elif kind == "Pa":
            d, dd = q[i], qd[i]
            O = O + d * eh
            dO = dO + d * np.outer(nh, s) + np.outer(eh, u)
            aO = aO + 2 * dd * w * nh - d * w**2 * eh
            phi = phi + gamma
        elif kind == "Pb":
            d, dd = q[i], qd[i]
            ei, ni = _e(phi + gamma), _n(phi + gamma)
            O = O + l_host * eh + (d - l) * ei
            dO = dO + l_host * np.outer(nh, s) + (d - l) * np.outer(ni, s) + np.outer(ei, u)
            aO = aO - l_host * w**2 * eh + 2 * dd * w * ni - (d - l) * w**2 * ei
            phi = phi + gamma
        else:
            raise ValueError(kind)
        points.append(O)
        w = s @ qd  # this link's angular velocity
        ei, ni = _e(phi), _n(phi)
        Jc = dO + l / 2 * np.outer(ni, s)  # mass centre c_i = O_i + (l_i/2) e_i
        ac = aO - l / 2 * w**2 * ei
        M += m * Jc.T @ Jc + m * l**2 / 12 * np.outer(s, s)
        h += m * Jc.T @ ac
        dV -= m * Jc.T @ g
        l_host = l
    points.append(O + l_host * _e(phi))
    return np.array(points), M, h, dV


# --------------------------------------------------------------------------- package chains
def _ranges(kinds, lengths):
    """(d_min, d_max) of each prismatic joint: Pa on the base any range, on a host inside
    [c, l_host - c]; Pb inside (0, l_i] (d_max = l_i: the rear end reaches the guide)."""
    out = []
    for i, k in enumerate(kinds):
        if k == "Pa":
            out.append((0.1, 0.8) if i == 0 else (C + 0.1, lengths[i - 1] - C - 0.05))
        elif k == "Pb":
            out.append((0.3 * lengths[i], lengths[i]))
        else:
            out.append(None)
    return out


def _joint(kind, i, rng_):
    if kind == "R":
        return gi.Revolute()
    if kind == "Pa":
        return gi.SlidingPrismatic(angle=GAMMA["Pa"][i], half_length=C, range=rng_)
    return gi.FixedPrismatic(angle=GAMMA["Pb"][i], range=rng_)


@functools.lru_cache(maxsize=None)
def build(combo, rigid=False, gravity=GRAVITY):
    """(model, spec, ranges) of the chain combo ("R-Pb", "R-Pa-Pb", ...) on the fixed base."""
    kinds = combo.split("-")
    params = LINKS2 if len(kinds) == 2 else LINKS3
    lengths = [p[0] for p in params]
    ranges = _ranges(kinds, lengths)
    links = [gi.Link(length=l, mass_per_length=mu, EI=EI, elements=0 if rigid else ne, geometric_stiffening=False) for l, mu, EI, ne in params]
    joints = [_joint(k, i, r) for i, (k, r) in enumerate(zip(kinds, ranges))]
    chain = gi.Chain(links, joints=joints, base=gi.FixedBase(position=BASE, angle=BETA))
    model = gi.Model(chain, gravity=gravity)
    spec = [(k, GAMMA.get(k, (None,) * 3)[i], l, mu * l) for i, (k, (l, mu, _, _)) in enumerate(zip(kinds, params))]
    return model, spec, ranges


def joint_names(kinds):
    return tuple(("theta_" if k == "R" else "d_") + str(i) for i, k in enumerate(kinds, start=1))


def random_joints(spec, ranges, rng):
    """Joint values: angles in (-pi, pi), d inside its range; a carriage on a Pb link stays on
    the protruding part, d_i - c_i >= l_(i-1) - d_(i-1) (docs/theory.md §7.3)."""
    q = np.empty(len(spec))
    for i, ((kind, _, _, _), r) in enumerate(zip(spec, ranges)):
        if kind == "R":
            q[i] = rng.uniform(-np.pi, np.pi)
            continue
        lo, hi = r
        if kind == "Pa" and i > 0 and spec[i - 1][0] == "Pb":
            lo = max(lo, spec[i - 1][2] - q[i - 1] + C)
        q[i] = rng.uniform(lo + 0.01 * (hi - lo), hi - 0.01 * (hi - lo))
    return q


def elastic_state(model, nj, rng, w=0.02, t=0.05):
    """Random elastic coordinates: node deflections (odd k) ~ w [m], node slopes (even k) ~ t [rad]."""
    q = np.zeros(model.n_dof)
    for k, name in enumerate(model.coordinate_names[nj:], start=nj):
        q[k] = rng.uniform(-w, w) if int(name.rsplit("_", 1)[1]) % 2 else rng.uniform(-t, t)
    return q


def _close(actual, expected, rel=1e-12, floor=0.0):
    scale = max(np.abs(expected).max(), floor)
    np.testing.assert_allclose(actual, expected, rtol=0, atol=rel * scale)


# --------------------------------------------------------------------------- the reference itself
def test_reference_reproduces_textbook_closed_forms():
    """The hand-written reference against explicit formulas (independent of the package)."""
    rng = np.random.default_rng(7)
    b, beta = BASE, BETA
    for _ in range(5):
        qd = rng.normal(size=2)
        # One rigid rod on a revolute joint (pendulum): M = m l^2/3, h = 0, dV = m g (l/2) cos(phi).
        l, m, th = 0.9, 1.3, rng.uniform(-3, 3)
        P, M, h, dV = rigid_reference([("R", None, l, m)], [th], qd[:1])
        _close(M, [[m * l**2 / 3]])
        _close(h, [0.0], floor=1.0)
        _close(dV, [m * G * l / 2 * np.cos(beta + th)])
        _close(P, [b, np.add(b, l * _e(beta + th))], floor=1.0)
        # A rod of mass m sliding through a fixed Pb guide at gamma on the base: M = m, h = 0,
        # dV = -m g . e(beta + gamma); rear end at b + (d - l) e, tip at b + d e.
        gam, d = 0.3, rng.uniform(0.2, 0.9)
        P, M, h, dV = rigid_reference([("Pb", gam, l, m)], [d], qd[:1])
        _close(M, [[m]])
        _close(h, [0.0], floor=1.0)
        _close(dV, [m * G * np.sin(beta + gam)])
        _close(P, [b + (d - l) * _e(beta + gam), b + d * _e(beta + gam)], floor=1.0)

        # Double pendulum of uniform rods, theta_2 relative (the formulas of tests/test_fixed_base.py).
        l1, l2, m1, m2 = 1.0, 0.7, 2.0, 1.4
        q = rng.uniform(-3, 3, 2)
        c2, s2 = np.cos(q[1]), np.sin(q[1])
        k = m2 * l1 * l2 / 2
        Mx = np.array([[m1 * l1**2 / 3 + m2 * l1**2 + m2 * l2**2 / 3 + 2 * k * c2, m2 * l2**2 / 3 + k * c2],
                       [m2 * l2**2 / 3 + k * c2, m2 * l2**2 / 3]])
        hx = [-k * s2 * (2 * qd[0] * qd[1] + qd[1] ** 2), k * s2 * qd[0] ** 2]
        p1, p2 = beta + q[0], beta + q[0] + q[1]
        dVx = G * np.array([m1 * l1 / 2 * np.cos(p1) + m2 * (l1 * np.cos(p1) + l2 / 2 * np.cos(p2)), m2 * l2 / 2 * np.cos(p2)])
        _, M, h, dV = rigid_reference([("R", None, l1, m1), ("R", None, l2, m2)], q, qd)
        _close(M, Mx)
        _close(h, hx, floor=1.0)
        _close(dV, dVx)

        # Cart-pendulum (Pa-R): a carriage on the base rail e(beta) carries rod 1 at gamma_1, rod 2
        # swings at its tip with phi_2 = beta + gamma_1 + theta_2. Only d_1 moves rod 1:
        # c_2_dot = d_1_dot e(beta) + (l2/2) theta_2_dot n(phi_2), e(beta) . n(phi_2) = -sin(gamma_1 + theta_2).
        g1 = 0.5
        q = np.array([rng.uniform(0.1, 0.8), rng.uniform(-3, 3)])
        a = g1 + q[1]
        Mx = np.array([[m1 + m2, -m2 * l2 / 2 * np.sin(a)], [-m2 * l2 / 2 * np.sin(a), m2 * l2**2 / 3]])
        hx = [-m2 * l2 / 2 * qd[1] ** 2 * np.cos(a), 0.0]
        dVx = G * np.array([(m1 + m2) * np.sin(beta), m2 * l2 / 2 * np.cos(beta + a)])
        _, M, h, dV = rigid_reference([("Pa", g1, l1, m1), ("R", None, l2, m2)], q, qd)
        _close(M, Mx)
        _close(h, hx, floor=1.0)
        _close(dV, dVx)

        # Telescoping arm (R-Pb): rod 1 turns about the base origin, rod 2 slides through a guide at
        # its tip at gamma_2; c_2 = O_1 + l1 e_1 + s e_2 with s = d_2 - l2/2, so
        # c_2_dot = theta_1_dot (l1 n_1 + s n_2) + d_2_dot e_2 and, with n_1 . e_2 = sin(gamma_2),
        # T = 1/2 M11(d_2) theta_1_dot^2 + m2 l1 sin(gamma_2) theta_1_dot d_2_dot + 1/2 m2 d_2_dot^2,
        # M11 = m1 l1^2/3 + m2 (l1^2 + s^2 + 2 l1 s cos gamma_2) + m2 l2^2/12, dM11/dd_2 = 2 m2 (s + l1 cos gamma_2).
        g2 = -0.4
        q = np.array([rng.uniform(-3, 3), rng.uniform(0.2, 0.7)])
        sc = q[1] - l2 / 2
        f = m2 * (sc + l1 * np.cos(g2))
        Mx = np.array([[m1 * l1**2 / 3 + m2 * (l1**2 + sc**2 + 2 * l1 * sc * np.cos(g2)) + m2 * l2**2 / 12,
                        m2 * l1 * np.sin(g2)], [m2 * l1 * np.sin(g2), m2]])
        hx = [2 * f * qd[0] * qd[1], -f * qd[0] ** 2]
        p1, p2 = beta + q[0], beta + q[0] + g2
        dVx = G * np.array([m1 * l1 / 2 * np.cos(p1) + m2 * (l1 * np.cos(p1) + sc * np.cos(p2)), m2 * np.sin(p2)])
        _, M, h, dV = rigid_reference([("R", None, l1, m1), ("Pb", g2, l2, m2)], q, qd)
        _close(M, Mx)
        _close(h, hx, floor=1.0)
        _close(dV, dVx)


def _transform_product_model(spec, q, qd, base=BASE, beta=BETA, gravity=GRAVITY, eps=1e-6, eps2=1e-4):
    """A second, cruder route to the same rigid robot: the 3x3 homogeneous transforms of
    docs/theory.md §7.1 multiplied out (T_i = T_(i-1) G_i), p = T_i (x, 0, 1), the rod integrals by
    2-point Gauss (exact: quadratic in x), dp/dq by central differences and the velocity-product
    acceleration by a second central difference along q_dot. Accuracy ~1e-8."""
    def Rz(a):
        return np.array([[np.cos(a), -np.sin(a), 0.0], [np.sin(a), np.cos(a), 0.0], [0.0, 0.0, 1.0]])

    def Tr(x):
        return np.array([[1.0, 0.0, x], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])

    def frames(q):
        T = np.array([[1.0, 0.0, base[0]], [0.0, 1.0, base[1]], [0.0, 0.0, 1.0]]) @ Rz(beta)
        out, l_host = [], 0.0
        for (kind, gamma, l, _), qi in zip(spec, q):
            G = {"R": lambda: Tr(l_host) @ Rz(qi), "Pa": lambda: Tr(qi) @ Rz(gamma),
                 "Pb": lambda: Tr(l_host) @ Rz(gamma) @ Tr(qi - l)}[kind]()
            T = T @ G
            out.append(T)
            l_host = l
        return out

    gp = 0.5 + np.array([-0.5, 0.5]) / np.sqrt(3.0)  # Gauss points on [0, 1], weights 1/2

    def points(q):  # (links, 2 Gauss points, 2)
        return np.array([[(T @ [x * l, 0.0, 1.0])[:2] for x in gp] for T, (_, _, l, _) in zip(frames(q), spec)])

    nj = len(spec)
    J = np.stack([(points(q + eps * u) - points(q - eps * u)) / (2 * eps) for u in np.eye(nj)], axis=-1)
    a0 = (points(q + eps2 * qd) - 2 * points(q) + points(q - eps2 * qd)) / eps2**2
    mass = np.array([m for *_, m in spec])[:, None] / 2  # Gauss weight x link mass
    M = np.einsum("ig,igak,igal->kl", np.broadcast_to(mass, J.shape[:2]), J, J)
    h = np.einsum("ig,igak,iga->k", np.broadcast_to(mass, J.shape[:2]), J, a0)
    dV = -np.einsum("ig,igak,a->k", np.broadcast_to(mass, J.shape[:2]), J, np.asarray(gravity)[:2])
    Ts = frames(q)
    P = np.array([T[:2, 2] for T in Ts] + [(Ts[-1] @ [spec[-1][2], 0.0, 1.0])[:2]])
    return P, M, h, dV


@pytest.mark.parametrize("combo", COMBOS + ["R-Pa-Pb", "Pb-Pa-R"])
def test_reference_agrees_with_multiplied_out_transforms(combo):
    """The hand-derived reference (exact) against the transform-product route (finite differences)."""
    kinds = combo.split("-")
    params = LINKS2 if len(kinds) == 2 else LINKS3
    spec = [(k, GAMMA.get(k, (None,) * 3)[i], l, mu * l) for i, (k, (l, mu, _, _)) in enumerate(zip(kinds, params))]
    ranges = _ranges(kinds, [p[0] for p in params])
    rng = np.random.default_rng(zlib.crc32(combo.encode()))
    for _ in range(5):
        q, qd = random_joints(spec, ranges, rng), rng.normal(size=len(kinds))
        P, M, h, dV = rigid_reference(spec, q, qd)
        P2, M2, h2, dV2 = _transform_product_model(spec, q, qd)
        np.testing.assert_allclose(P, P2, rtol=0, atol=1e-14)
        _close(M, M2, rel=1e-8)
        _close(h, h2, rel=1e-6, floor=1.0)
        _close(dV, dV2, rel=1e-8)


# --------------------------------------------------------------------------- (a), (b): nine combinations
@pytest.mark.parametrize("rigid", [False, True], ids=["fe", "rigid"])
@pytest.mark.parametrize("combo", COMBOS + ["R-Pa-Pb", "Pb-Pa-R"])
def test_rigid_limit_equals_rigid_robot(combo, rigid):
    """(a) frame origins and tip, (b) joint block of M, joint entries of h and dV/dq at delta = 0,
    delta_dot = 0, against the rigid reference (FE links: the flexible code path; elements=0: rigid)."""
    model, spec, ranges = build(combo, rigid)
    kinds = combo.split("-")
    nj = len(kinds)
    assert model.coordinate_names[:nj] == joint_names(kinds)
    assert model.n_dof == nj + (0 if rigid else sum(2 * p[3] for p in (LINKS2 if nj == 2 else LINKS3)))
    rng = np.random.default_rng(zlib.crc32(f"{combo}{rigid}".encode()))
    for _ in range(6):
        q, qd = np.zeros(model.n_dof), np.zeros(model.n_dof)
        q[:nj] = random_joints(spec, ranges, rng)
        qd[:nj] = rng.normal(size=nj)
        P, M, h, dV = rigid_reference(spec, q[:nj], qd[:nj])
        # the frame origins and the tip (the contact points after them, tips of the hosts of
        # prismatic joints, are checked against the planar oracle in test_planar_oracle.py)
        O = model.joint_positions(q)[:nj + 1]
        assert O.shape == (nj + 1, 3)
        np.testing.assert_allclose(O[:, :2], P, rtol=0, atol=1e-13)
        np.testing.assert_allclose(O[:, 2], 0.0, rtol=0, atol=1e-13)
        _close(model.mass_matrix(q)[:nj, :nj], M)
        _close(model.bias_forces(q, qd)[:nj], h, floor=1.0)  # h = 0 identically for Pa-Pa
        _close(model.potential_forces(q)[:nj], dV)


@pytest.mark.parametrize("combo", ["R-Pa", "Pa-Pa"])
def test_zero_half_length_allowed_on_rigid_host_and_base_rail(combo):
    """c = 0 is allowed when the host's deflection is C^2 (rigid host, base rail; docs/theory.md §7.3)."""
    kinds = combo.split("-")
    lengths = [p[0] for p in LINKS2]
    ranges = _ranges(kinds, lengths)
    links = [gi.Link(length=l, mass_per_length=mu, EI=EI, elements=0, geometric_stiffening=False) for l, mu, EI, _ in LINKS2]
    joints = [gi.Revolute() if k == "R" else gi.SlidingPrismatic(angle=GAMMA["Pa"][i], half_length=0.0, range=r)
              for i, (k, r) in enumerate(zip(kinds, ranges))]
    model = gi.Model(gi.Chain(links, joints=joints, base=gi.FixedBase(position=BASE, angle=BETA)), gravity=GRAVITY)
    spec = [(k, GAMMA["Pa"][i] if k == "Pa" else None, l, mu * l) for i, (k, (l, mu, _, _)) in enumerate(zip(kinds, LINKS2))]
    rng = np.random.default_rng(11)
    for _ in range(5):
        q, qd = random_joints(spec, ranges, rng), rng.normal(size=2)
        P, M, h, dV = rigid_reference(spec, q, qd)
        np.testing.assert_allclose(model.joint_positions(q)[:len(P), :2], P, rtol=0, atol=1e-13)
        _close(model.mass_matrix(q), M)
        _close(model.bias_forces(q, qd), h, floor=1.0)
        _close(model.potential_forces(q), dV)


# --------------------------------------------------------------------------- (c) named closed forms
@pytest.mark.parametrize("beta", [0.0, 0.7])
@pytest.mark.parametrize("elements", [0, 3])
def test_rod_sliding_through_a_fixed_guide_on_the_base(beta, elements):
    """A rod of mass m through a fixed Pb guide at gamma: M = m, h = 0, dV/dd = -m g . u and, rigid,
    d_ddot = g . u, u = e(beta + gamma). Gravity has both components so that cos and sin both count."""
    l, mu, gamma = 0.8, 0.75, 0.3
    m, gravity = mu * l, np.array([2.0, -G, 0.0])
    u = _e(beta + gamma)
    link = gi.Link(length=l, mass_per_length=mu, EI=5.0, elements=elements, geometric_stiffening=False)
    chain = gi.Chain([link], joints=[gi.FixedPrismatic(angle=gamma, range=(0.1, l))], base=gi.FixedBase(position=BASE, angle=beta))
    model = gi.Model(chain, gravity=tuple(gravity))
    assert model.coordinate_names[0] == "d_1"
    assert model.n_dof == 1 + 2 * elements
    rng = np.random.default_rng(3)
    for d in rng.uniform(0.12, l, 5):
        q, qd = np.zeros(model.n_dof), np.zeros(model.n_dof)
        q[0], qd[0] = d, rng.normal()
        np.testing.assert_allclose(model.joint_positions(q)[:2, :2], [np.add(BASE, (d - l) * u), np.add(BASE, d * u)],
                                   rtol=0, atol=1e-13)
        assert abs(model.mass_matrix(q)[0, 0] - m) <= 1e-12 * m
        assert abs(model.bias_forces(q, qd)[0]) <= 1e-12 * max(1.0, m * qd[0] ** 2)
        assert abs(model.potential_forces(q)[0] + m * gravity[:2] @ u) <= 1e-12 * m * G
        if elements == 0:
            assert abs(model.forward_dynamics(q, qd)[0] - gravity[:2] @ u) <= 1e-12 * G


@pytest.mark.parametrize("elements", [0, 3])
def test_one_link_revolute_pendulum(elements):
    """One uniform rod on a revolute joint at the base: M = m l^2/3, h = 0, dV = m g (l/2) cos(beta + theta)."""
    l, mu = 0.9, 1.1
    m = mu * l
    link = gi.Link(length=l, mass_per_length=mu, EI=5.0, elements=elements, geometric_stiffening=False)
    model = gi.Model(gi.Chain([link], joints=[gi.Revolute()], base=gi.FixedBase(position=BASE, angle=BETA)), gravity=GRAVITY)
    rng = np.random.default_rng(4)
    for th in rng.uniform(-np.pi, np.pi, 5):
        q, qd = np.zeros(model.n_dof), np.zeros(model.n_dof)
        q[0], qd[0] = th, rng.normal()
        assert abs(model.mass_matrix(q)[0, 0] - m * l**2 / 3) <= 1e-12 * m * l**2
        assert abs(model.bias_forces(q, qd)[0]) <= 1e-12
        assert abs(model.potential_forces(q)[0] - m * G * l / 2 * np.cos(BETA + th)) <= 1e-12 * m * G * l
        if elements == 0:
            assert abs(model.forward_dynamics(q, qd)[0] + 1.5 * G / l * np.cos(BETA + th)) <= 1e-12 * G / l


# --------------------------------------------------------------------------- (d) M symmetric positive definite
@pytest.mark.parametrize("combo", COMBOS + ["R-Pa-Pb"])
def test_mass_matrix_symmetric_positive_definite_at_flexible_states(combo):
    model, spec, ranges = build(combo)
    nj = len(spec)
    rng = np.random.default_rng(zlib.crc32(combo.encode()))
    for _ in range(5):
        q = elastic_state(model, nj, rng)
        q[:nj] = random_joints(spec, ranges, rng)
        M = model.mass_matrix(q)
        assert M.shape == (model.n_dof, model.n_dof)
        np.testing.assert_allclose(M, M.T, rtol=0, atol=1e-13 * np.abs(M).max())
        lam = np.linalg.eigvalsh(0.5 * (M + M.T))
        assert lam.min() > 1e-10 * lam.max(), (combo, lam.min(), lam.max())


# --------------------------------------------------------------------------- (e) constructor errors
def _make(joints, links=None):
    """Chain and Model on the fixed base: an error may be raised by either."""
    links = links or [gi.Link(length=l, mass_per_length=mu, EI=EI, elements=ne, geometric_stiffening=False) for l, mu, EI, ne in LINKS2]
    return gi.Model(gi.Chain(links, joints=joints, base=gi.FixedBase(position=BASE, angle=BETA)), gravity=GRAVITY)


@pytest.mark.parametrize("rng_", [(0.5, 0.5), (0.6, 0.4)])
def test_range_must_be_increasing(rng_):
    with pytest.raises(ValueError, match="range"):
        _make([gi.Revolute(), gi.SlidingPrismatic(angle=0.1, half_length=C, range=rng_)])
    with pytest.raises(ValueError, match="range"):
        _make([gi.Revolute(), gi.FixedPrismatic(angle=0.1, range=rng_)])


def test_pa_zero_half_length_on_a_hermite_host_is_rejected():
    with pytest.raises(ValueError) as err:
        _make([gi.Revolute(), gi.SlidingPrismatic(angle=0.1, half_length=0.0, range=(0.2, 0.8))])
    msg = str(err.value)
    assert "half_length" in msg
    assert re.search(r"jump|discontinu", msg, re.IGNORECASE), msg  # the reason: M would jump at the host's nodes


@pytest.mark.parametrize("rng_", [(0.0, 0.5), (-0.1, 0.5)])
def test_pb_range_must_start_above_zero(rng_):
    with pytest.raises(ValueError, match="range"):
        _make([gi.Revolute(), gi.FixedPrismatic(angle=0.1, range=rng_)])


def test_pb_range_cannot_exceed_the_sliding_link():
    with pytest.raises(ValueError, match="range"):
        _make([gi.Revolute(), gi.FixedPrismatic(angle=0.1, range=(0.2, LINKS2[1][0] + 0.05))])


@pytest.mark.parametrize("rng_", [(C - 0.02, 0.5), (0.3, LINKS2[0][0] - C + 0.02)])
def test_pa_range_must_keep_the_carriage_on_the_host(rng_):
    with pytest.raises(ValueError, match="range"):
        _make([gi.Revolute(), gi.SlidingPrismatic(angle=0.1, half_length=C, range=rng_)])
