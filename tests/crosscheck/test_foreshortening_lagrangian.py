"""A stiffened link's M and qddot against an independent Lagrangian (formulation §15).

The reference shares no code with the package: the clamped-free eigenfunctions in closed form,
u_f(x) = -1/2 int_0^x (v'^2 + w'^2) by its own Gauss-Legendre rule, the end transform
E = Trans(l + u_f(l), v(l), w(l)) Rot(phi) by Rodrigues' formula, the Jacobian of every
material point by complex-step differentiation (exact to round-off), M = sum w mu J^T J, and
Lagrange's equations M qddot = -(Mdot qdot - dT/dq) - dV/dq with dM/dq by 4th-order central
differences (error ~1e-12 relative) and dV/dq by complex step.
"""

import numpy as np

import gibbsimpact as gi

L1, MU1, EI_Y, EI_Z = 1.0, 1.2, 15.0, 25.0   # link 1: w bends against EI_y, v against EI_z
L2, MU2 = 0.6, 0.8                           # link 2: rigid
G = np.array([0.0, -9.81, 0.0])
BETA_L = (1.875104068711961, 4.694091132974175)
# link 1's coordinates: y-mode 1, y-mode 2, z-mode 1 (shape index, bending axis)
MODES = ((0, 1), (1, 1), (0, 2))


def _model():
    modes = [gi.Mode("clamped-free", "y", 1), gi.Mode("clamped-free", "y", 2), gi.Mode("clamped-free", "z", 1)]
    a = gi.Link(L1, MU1, (EI_Y, EI_Z), modes=modes)
    b = gi.Link(L2, MU2, 1.0)
    return gi.Model(gi.Chain([a, b], base=gi.FixedBase()), gravity=tuple(G))


def _clamped_free(k, x, der):
    """psi_k^(der)(x) of clamped-free mode k (0-based) on [0, L1], max |psi| = 1 (at the tip, positive)."""
    b = BETA_L[k] / L1
    s = (np.cosh(b * L1) + np.cos(b * L1)) / (np.sinh(b * L1) + np.sin(b * L1))
    f = [lambda t: np.cosh(t) - np.cos(t) - s * (np.sinh(t) - np.sin(t)),
         lambda t: np.sinh(t) + np.sin(t) - s * (np.cosh(t) - np.cos(t)),
         lambda t: np.cosh(t) + np.cos(t) - s * (np.sinh(t) + np.sin(t))]
    return b**der * f[der](b * x) / f[0](b * L1)


def _gauss(a, b, n=40):
    t, w = np.polynomial.legendre.leggauss(n)
    return a + 0.5 * (b - a) * (t + 1.0), 0.5 * (b - a) * w


def _rz(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]], dtype=complex)


def _rodrigues(phi):
    a = np.sqrt(phi @ phi)
    K = np.array([[0, -phi[2], phi[1]], [phi[2], 0, -phi[0]], [-phi[1], phi[0], 0]])
    return np.eye(3) + np.sin(a) / a * K + (1 - np.cos(a)) / a**2 * K @ K


def _deflection(delta, x, der):
    """(v, w)^(der) of link 1 at x (K,)."""
    out = np.zeros((2, np.size(x)), dtype=delta.dtype)
    for c, (k, ax) in enumerate(MODES):
        out[ax - 1] = out[ax - 1] + delta[c] * _clamped_free(k, x, der)
    return out


def _u_f(delta, x):
    """-1/2 int_0^x (v'^2 + w'^2) at each x (K,)."""
    u = []
    for xj in np.atleast_1d(x):
        s, w = _gauss(0.0, xj)
        d1 = _deflection(delta, s, 1)
        u.append(-0.5 * np.sum(w * (d1[0] ** 2 + d1[1] ** 2)))
    return np.array(u)


X1, W1 = _gauss(0.0, L1)
X2, W2 = _gauss(0.0, L2)


def _points(q):
    """World points (K1 + K2, 3) of both links' quadrature points; q = (theta_1, theta_2, delta (3,))."""
    th1, th2, delta = q[0], q[1], q[2:]
    T1 = _rz(th1)
    vw = _deflection(delta, X1, 0)
    r1 = np.stack([X1 + _u_f(delta, X1), vw[0], vw[1], np.ones_like(X1)])
    tip = _deflection(delta, np.array([L1]), 0)[:, 0]
    slope = _deflection(delta, np.array([L1]), 1)[:, 0]
    E = np.eye(4, dtype=complex)
    E[:3, :3] = _rodrigues(np.array([0.0, -slope[1], slope[0]]))
    E[:3, 3] = [L1 + _u_f(delta, L1)[0], tip[0], tip[1]]
    T2 = T1 @ E @ _rz(th2)
    r2 = np.stack([X2, 0 * X2, 0 * X2, np.ones_like(X2)])
    return np.concatenate([(T1 @ r1)[:3].T, (T2 @ r2)[:3].T])


WMU = np.concatenate([W1 * MU1, W2 * MU2])


def _mass_matrix(q):
    """M = sum w mu J^T J, J by complex step (h = 1e-30: no cancellation)."""
    h = 1e-30
    J = np.stack([_points(q + 1j * h * e).imag / h for e in np.eye(q.size)], axis=-1)  # (K, 3, N)
    return np.einsum("k,kai,kaj->ij", WMU, J, J)


def _potential(q):
    delta = q[2:]
    V = -WMU @ (_points(q) @ G)
    K = np.zeros((3, 3))
    xs, ws = _gauss(0.0, L1)
    for a, (ka, axa) in enumerate(MODES):
        for b, (kb, axb) in enumerate(MODES):
            if axa == axb:
                K[a, b] = (EI_Z if axa == 1 else EI_Y) * np.sum(ws * _clamped_free(ka, xs, 2) * _clamped_free(kb, xs, 2))
    return V + 0.5 * delta @ K @ delta


def _qddot(q, qd):
    """Lagrange: M qddot = -(sum_k dM/dq_k qd_k) qd + 1/2 qd^T dM/dq qd - dV/dq."""
    N = q.size
    h = 1e-3
    dM = []
    for e in np.eye(N):
        Mp, Mm, M2p, M2m = (_mass_matrix(q + s * h * e) for s in (1, -1, 2, -2))
        dM.append((8 * (Mp - Mm) - (M2p - M2m)) / (12 * h))
    dM = np.array(dM)
    dV = np.array([_potential(q + 1j * 1e-30 * e).imag / 1e-30 for e in np.eye(N)])
    rhs = -np.einsum("kij,k,j->i", dM, qd, qd) + 0.5 * np.einsum("kij,i,j->k", dM, qd, qd) - dV
    return np.linalg.solve(_mass_matrix(q), rhs)


def test_mass_matrix_and_qddot_match_an_independent_lagrangian():
    model = _model()
    assert model.coordinate_names == ("theta_1", "theta_2", "delta_1_1", "delta_1_2", "delta_1_3")
    rng = np.random.default_rng(15)
    for _ in range(3):
        q = np.concatenate([rng.uniform(-1.5, 1.5, 2), rng.uniform(-0.15, 0.15, 3)])
        qd = rng.normal(scale=2.0, size=5)
        M_ref = _mass_matrix(q.astype(complex)).real
        M = model.mass_matrix(q)
        np.testing.assert_allclose(M, M_ref, rtol=0, atol=1e-12 * np.abs(M_ref).max())
        qdd_ref = _qddot(q.astype(complex), qd).real
        qdd = model.forward_dynamics(q, qd)
        np.testing.assert_allclose(qdd, qdd_ref, rtol=0, atol=1e-9 * np.abs(qdd_ref).max())
        # the foreshortening matters here: the linear beam differs by far more than the tolerance
        lin = gi.Model(gi.Chain([gi.Link(L1, MU1, (EI_Y, EI_Z), modes=model.chain.links[0].modes,
                                         geometric_stiffening=False), model.chain.links[1]], base=gi.FixedBase()),
                       gravity=tuple(G))
        assert np.abs(lin.forward_dynamics(q, qd) - qdd_ref).max() > 1e-4 * np.abs(qdd_ref).max()
