"""An R-Pa arm whose carriage rides on a stiffened host: M and qddot against an independent Lagrangian
(formulation §15, docs/theory.md §6.9, §7.3).

The reference shares no code with the package: the host's cubic Hermite functions written out per
element, u_f(x) = -1/2 int_0^x v'^2 by its own Gauss-Legendre rule (exact on each element), the
carriage G = Trans(d + ubar, vbar, 0) Rz(phibar + gamma) with ubar, vbar the means of u_f, v at
d +- c and phibar = [v(d + c) - v(d - c)] / (2 c), the Jacobian of every material point by
complex-step differentiation (exact to round-off), M = sum w mu J^T J, and Lagrange's equations
M qddot = -(sum_k dM/dq_k qd_k) qd + 1/2 qd^T dM/dq qd - dV/dq with dM/dq by 4th-order central
differences (step 1e-3: error ~1e-12 relative, the carriage kept 0.03 m from the host's nodes where
v'' jumps) and dV/dq by complex step.
"""

import numpy as np

import gibbsimpact as gi

L1, MU1, EI1, NE = 1.0, 1.2, 10.0, 3      # host: 3 Hermite elements, stiffened
L2, MU2 = 0.6, 0.5                        # arm: rigid
GAMMA, C = 0.6, 0.04                      # carriage angle [rad], half-length [m]
G = np.array([0.0, -9.81, 0.0])
H_E = L1 / NE


def _model(stiffened=True):
    host = gi.Link(L1, MU1, EI1, elements=NE, geometric_stiffening=stiffened)
    arm = gi.Link(L2, MU2, 1.0)
    pa = gi.SlidingPrismatic(angle=GAMMA, half_length=C, range=(0.05, 0.95))
    return gi.Model(gi.Chain([host, arm], joints=[gi.Revolute(), pa], base=gi.FixedBase()), gravity=tuple(G))


def _gauss(a, b, n=6):
    t, w = np.polynomial.legendre.leggauss(n)
    return a + 0.5 * (b - a) * (t + 1.0), 0.5 * (b - a) * w


def _v(delta, x, der):
    """v^(der)(x) of the host (der = 0, 1) at one abscissa x, delta = (v_1, v_1', ..., v_NE, v_NE')."""
    e = min(max(int(np.ceil(x.real / H_E)), 1), NE)
    t = (x - (e - 1) * H_E) / H_E
    if der == 0:
        N = [1 - 3 * t**2 + 2 * t**3, H_E * (t - 2 * t**2 + t**3), 3 * t**2 - 2 * t**3, H_E * (-t**2 + t**3)]
    else:
        N = [(-6 * t + 6 * t**2) / H_E, 1 - 4 * t + 3 * t**2, (6 * t - 6 * t**2) / H_E, -2 * t + 3 * t**2]
    nodal = np.concatenate([np.zeros(2), delta])  # the clamped node 0 first
    return sum(N[j] * nodal[2 * (e - 1) + j] for j in range(4))


def _u_f(delta, x):
    """-1/2 int_0^x v'^2, element by element (x may carry an imaginary part through d)."""
    u = 0.0
    for e in range(NE):
        a = e * H_E
        if a >= x.real:
            break
        s, w = _gauss(a, x if x.real < a + H_E else a + H_E)
        u = u - 0.5 * sum(wj * _v(delta, sj, 1) ** 2 for sj, wj in zip(s, w))
    return u


def _rz(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]], dtype=complex)


def _trans(x, y):
    T = np.eye(4, dtype=complex)
    T[0, 3], T[1, 3] = x, y
    return T


XH = np.concatenate([_gauss(e * H_E, (e + 1) * H_E)[0] for e in range(NE)])
WH = np.concatenate([_gauss(e * H_E, (e + 1) * H_E)[1] for e in range(NE)])
XA, WA = _gauss(0.0, L2)
WMU = np.concatenate([WH * MU1, WA * MU2])


def _points(q, carriage_fs=True):
    """World points (K, 3) of the host's and the arm's quadrature points; q = (theta_1, d_2, delta (6,))."""
    th, d, delta = q[0], q[1], q[2:]
    T1 = _rz(th)
    r1 = np.array([[x + _u_f(delta, x), _v(delta, x, 0), 0.0, 1.0] for x in XH]).T
    vp, vm = _v(delta, d + C, 0), _v(delta, d - C, 0)
    ubar = 0.5 * (_u_f(delta, d + C) + _u_f(delta, d - C)) if carriage_fs else 0.0
    T2 = T1 @ _trans(d + ubar, 0.5 * (vp + vm)) @ _rz((vp - vm) / (2 * C) + GAMMA)
    r2 = np.stack([XA, 0 * XA, 0 * XA, np.ones_like(XA)])
    return np.concatenate([(T1 @ r1)[:3].T, (T2 @ r2)[:3].T])


def _mass_matrix(q, carriage_fs=True):
    """M = sum w mu J^T J, J by complex step (h = 1e-30: no cancellation)."""
    h = 1e-30
    J = np.stack([_points(q + 1j * h * e, carriage_fs).imag / h for e in np.eye(q.size)], axis=-1)  # (K, 3, N)
    return np.einsum("k,kai,kaj->ij", WMU, J, J)


def _stiffness():
    k = EI1 / H_E**3 * np.array([[12, 6 * H_E, -12, 6 * H_E], [6 * H_E, 4 * H_E**2, -6 * H_E, 2 * H_E**2],
                                 [-12, -6 * H_E, 12, -6 * H_E], [6 * H_E, 2 * H_E**2, -6 * H_E, 4 * H_E**2]])
    K = np.zeros((2 * NE + 2, 2 * NE + 2))
    for e in range(NE):
        K[2 * e:2 * e + 4, 2 * e:2 * e + 4] += k
    return K[2:, 2:]


def _potential(q, carriage_fs=True):
    return -WMU @ (_points(q, carriage_fs) @ G) + 0.5 * q[2:] @ _stiffness() @ q[2:]


def _qddot(q, qd, carriage_fs=True):
    """Lagrange: M qddot = -(sum_k dM/dq_k qd_k) qd + 1/2 qd^T dM/dq qd - dV/dq."""
    h = 1e-3
    dM = []
    for e in np.eye(q.size):
        Mp, Mm, M2p, M2m = (_mass_matrix(q + s * h * e, carriage_fs) for s in (1, -1, 2, -2))
        dM.append((8 * (Mp - Mm) - (M2p - M2m)) / (12 * h))
    dM = np.array(dM)
    dV = np.array([_potential(q + 1j * 1e-30 * e, carriage_fs).imag / 1e-30 for e in np.eye(q.size)])
    rhs = -np.einsum("kij,k,j->i", dM, qd, qd) + 0.5 * np.einsum("kij,i,j->k", dM, qd, qd) - dV
    return np.linalg.solve(_mass_matrix(q, carriage_fs), rhs)


def test_carriage_on_a_stiffened_host_matches_an_independent_lagrangian():
    model = _model()
    assert model.coordinate_names[:2] == ("theta_1", "d_2") and model.n_dof == 2 + 2 * NE
    rng = np.random.default_rng(24)
    # d +- c at least 0.03 m from the host's nodes 1/3, 2/3 (the 4th-order differences of M stay smooth)
    for d in (0.45, 0.58, 0.80):
        q = np.concatenate([[rng.uniform(-1.5, 1.5), d], rng.uniform(-0.15, 0.15, 2 * NE)])
        qd = rng.normal(scale=2.0, size=q.size)
        M_ref = _mass_matrix(q.astype(complex)).real
        np.testing.assert_allclose(model.mass_matrix(q), M_ref, rtol=0, atol=1e-12 * np.abs(M_ref).max())
        qdd_ref = _qddot(q.astype(complex), qd).real
        qdd = model.forward_dynamics(q, qd)
        np.testing.assert_allclose(qdd, qdd_ref, rtol=0, atol=1e-9 * np.abs(qdd_ref).max())
        # the carriage's own foreshortening matters: dropping ubar (the host's kept) misses by far more
        qdd_nofs = _qddot(q.astype(complex), qd, carriage_fs=False).real
        assert np.abs(qdd_nofs - qdd_ref).max() > 1e-5 * np.abs(qdd_ref).max()
