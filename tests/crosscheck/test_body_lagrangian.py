"""Attached rigid bodies against an independent Lagrangian derivation (docs/theory.md §6.8).

The chain: a fixed base, link 1 a Hermite-element beam (2 elements, in-plane) carrying a
payload inside its span, link 2 rigid behind a revolute joint at link 1's deflected tip, with a
hub at its joint and a payload off its axis at its tip. The reference writes the planar position
of every mass point from the definitions (no package code: its own Hermite cubics, Gauss rule,
rotations), and takes M = d^2T/dqdot^2 and qddot from Lagrange's equations with sympy.

The payload on the beam is the beam literature's tip body in the linearised kinematics of the
beam itself: a point at the axial lever lambda from the section x_a sits at
p = O_1 + R_1 (x_a + lambda, v(x_a) + lambda v'(x_a)) (the section's rotation v' turns the lever,
to first order, as a beam point x + lambda moves by v + lambda v'). Its centre p_c has
lambda = c_x, and its in-plane inertia J_zz turns with the section: p(rho) = p_c + A rho with
A = R_1 [[1, 0], [v'(x_a), 1]] and second moments diag(J_zz, 0), so
T_body = 1/2 m |p_c'|^2 + 1/2 tr(A' diag(J_zz, 0) A'^T). (Its J_yy >= J_zz: then the package's
model is this one, docs/theory.md §6.8.) The bodies on the rigid link are rigid bodies.
"""

import numpy as np
import pytest
import sympy as sp

import gibbsimpact as gi

G = 9.81
B1, B2, BETA = 0.2, -0.1, 0.3
L1, MU1, EI1, NE = 1.0, 1.5, 40.0, 2
L2, MU2 = 0.6, 0.8
# Payload on link 1 (axial rod + disc: J about its centre), hub and payload on link 2.
PA = dict(m=0.7, at=0.6, cx=0.1, J=(0.004, 0.032, 0.03))
HUB = dict(m=2.0, J=(0.05, 0.04, 0.09))
PB = dict(m=0.9, c=(0.12, 0.05), J=(0.01, 0.02, 0.025))


def _rot(a):
    return sp.Matrix([[sp.cos(a), -sp.sin(a)], [sp.sin(a), sp.cos(a)]])


def _shape_values(x):
    """Hermite values and slopes at x: the 4 global coefficient rows (value, slope) (4,) each."""
    h = L1 / NE
    e = min(int(x / h + 1e-12), NE - 1)
    eta = (x - e * h) / h
    H = np.array([1 - 3 * eta ** 2 + 2 * eta ** 3, h * (eta - 2 * eta ** 2 + eta ** 3), 3 * eta ** 2 - 2 * eta ** 3,
                  h * (-eta ** 2 + eta ** 3)])
    dH = np.array([-6 * eta + 6 * eta ** 2, h * (1 - 4 * eta + 3 * eta ** 2), 6 * eta - 6 * eta ** 2,
                   h * (-2 * eta + 3 * eta ** 2)]) / h
    ddH = np.array([-6 + 12 * eta, h * (-4 + 6 * eta), 6 - 12 * eta, h * (-2 + 6 * eta)]) / h ** 2
    rows = []
    for vals in (H, dH, ddH):
        r = np.zeros(2 * NE + 2)
        r[2 * e:2 * e + 4] = vals
        rows.append(r[2:])
    return rows


def _lagrangian_reference():
    q = sp.symbols("th1 th2 w1 t1 w2 t2")
    qd = sp.symbols("thd1 thd2 wd1 td1 wd2 td2")
    delta = sp.Matrix(q[2:])
    g = sp.Matrix([0, -G])
    t = sp.Symbol("t")
    path = {qi: sp.Function(f"f{k}")(t) for k, qi in enumerate(q)}
    back = {sp.diff(path[qi], t): qdi for qi, qdi in zip(q, qd)}

    def rate(expr):
        return expr.subs(path).diff(t).subs(back).subs({path[qi]: qi for qi in q})

    T, V = 0, 0
    O1, a1 = sp.Matrix([B1, B2]), BETA + q[0]
    R1 = _rot(a1)
    xg, wg = np.polynomial.legendre.leggauss(4)
    for e in range(NE):  # link 1, 4-point Gauss per element: exact for |pdot|^2 (degree 6)
        h = L1 / NE
        for xi, wi in zip(xg, wg):
            x = e * h + 0.5 * h * (xi + 1)
            v = (sp.Matrix([_shape_values(x)[0]]) * delta)[0]
            p = O1 + R1 * sp.Matrix([x, v])
            dm = MU1 * 0.5 * h * wi
            T += dm * (rate(p).dot(rate(p))) / 2
            V -= dm * g.dot(p)
            curv = (sp.Matrix([_shape_values(x)[2]]) * delta)[0]
            V += EI1 * 0.5 * h * wi * curv ** 2 / 2
    va, dva = [(sp.Matrix([r]) * delta)[0] for r in _shape_values(PA["at"])[:2]]
    pc = O1 + R1 * sp.Matrix([PA["at"] + PA["cx"], va + PA["cx"] * dva])
    Ad = (R1 * sp.Matrix([[1, 0], [dva, 1]])).applyfunc(rate)
    T += PA["m"] * rate(pc).dot(rate(pc)) / 2 + (Ad * sp.diag(PA["J"][2], 0) * Ad.T).trace() / 2
    V -= PA["m"] * g.dot(pc)
    vl, dvl = [(sp.Matrix([r]) * delta)[0] for r in _shape_values(L1)[:2]]
    O2 = O1 + R1 * sp.Matrix([L1, vl])
    a2 = a1 + dvl + q[1]
    R2 = _rot(a2)
    c2 = O2 + R2 * sp.Matrix([L2 / 2, 0])  # link 2: a rigid rod, I about its centre m l^2/12
    m2 = MU2 * L2
    T += m2 * rate(c2).dot(rate(c2)) / 2 + m2 * L2 ** 2 / 12 * rate(a2) ** 2 / 2
    T += HUB["m"] * rate(O2).dot(rate(O2)) / 2 + HUB["J"][2] * rate(a2) ** 2 / 2
    pb = O2 + R2 * sp.Matrix([L2 + PB["c"][0], PB["c"][1]])
    T += PB["m"] * rate(pb).dot(rate(pb)) / 2 + PB["J"][2] * rate(a2) ** 2 / 2
    V -= m2 * g.dot(c2) + HUB["m"] * g.dot(O2) + PB["m"] * g.dot(pb)
    M = sp.hessian(T, qd)
    dTdq = sp.Matrix([sp.diff(T, qi) for qi in q])
    h = sp.Matrix([sum(sp.diff(sp.diff(T, qd[i]), qj) * qdj for qj, qdj in zip(q, qd)) for i in range(6)]) - dTdq
    dV = sp.Matrix([sp.diff(V, qi) for qi in q])
    args = list(q) + list(qd)
    return sp.lambdify(args, M, "numpy"), sp.lambdify(args, h + dV, "numpy")


@pytest.fixture(scope="module")
def reference():
    return _lagrangian_reference()


def _package_model():
    body_a = gi.RigidBody(PA["m"], center=(PA["cx"], 0, 0), inertia=PA["J"], at=PA["at"])
    links = [gi.Link(L1, MU1, EI1, elements=NE, bodies=[body_a], geometric_stiffening=False),
             gi.Link(L2, MU2, 1.0, bodies=[gi.RigidBody(HUB["m"], inertia=HUB["J"], at=0.0),
                                           gi.RigidBody(PB["m"], center=(*PB["c"], 0.0), inertia=PB["J"])])]
    return gi.Model(gi.Chain(links, base=gi.FixedBase((B1, B2), BETA)), gravity=(0.0, -G, 0.0))


def test_mass_matrix_and_accelerations_match_the_lagrangian(reference, rng):
    M_ref, f_ref = reference
    model = _package_model()
    assert model.coordinate_names[:2] == ("theta_1", "theta_2")
    for _ in range(6):
        q = np.concatenate([rng.uniform(-3, 3, 2), rng.uniform(-0.1, 0.1, 4)])
        qd = rng.normal(size=6)
        M = np.array(M_ref(*q, *qd), dtype=float)
        qdd = np.linalg.solve(M, -np.array(f_ref(*q, *qd), dtype=float).ravel())
        np.testing.assert_allclose(model.mass_matrix(q), M, rtol=0, atol=1e-12 * np.abs(M).max())
        np.testing.assert_allclose(model.forward_dynamics(q, qd), qdd, rtol=0, atol=1e-10 * np.abs(qdd).max())
