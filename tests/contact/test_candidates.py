"""Material points of the links (gibbsimpact.linkpoints) against independent routes.

1. positions: p(x) at the ends of every link's search interval equals the contact points of
   the kernel (kinematics.joint_positions, another code path: the frame recursion's
   origins), for rigid, modal, finite-element, spatial and prismatic (R-Pa, R-Pb, Pb-R)
   chains, <= 1e-13 m (measured: 0 to 3e-17 m);
2. J(x) against central differences of material_points (<= 1e-7 relative; measured 2e-10),
   a0 = Jdot qdot against central differences of J(q + s qdot) qdot (<= 1e-6; measured
   3e-10), and J qddot + a0 against the fourth-order second difference of p(t) along a
   gi.simulate trajectory without walls (<= 1e-5; measured 2e-6 at dt = 0.05 / omega_max);
3. closest_points against brute force (10^5 samples of the gap along each link through
   material_points / model.link_deflection, then a bounded scalar minimisation around the
   best sample) on random deflected states with plane, circle and sphere walls near the
   chain and hugging a bulge (<= 1e-10 m; measured 3e-14 m), including element nodes off the
   sample grid; a clamped-clamped link bowed towards a plane touches at x* = l / 2; K states
   in one call equal K calls; refine_below keeps the sign and bounds the error.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.linalg import eigh

import gibbsimpact as gi
from gibbsimpact.contact import candidates as lp
from gibbsimpact.dynamics.kinematics import joint_positions

from conftest import ISSUE25_ITEM5_FLOOR, issue25_item5_model
from link_models import (MODELS, _case1, _check_against_brute_force, _obstacles_near, _prismatic, _spatial_fe,
                         _state, _walls_hugging, _walls_near)

# -- 1. positions ------------------------------------------------------------------------------

@pytest.mark.parametrize("name", list(MODELS))
def test_end_positions_are_the_joint_points(name, rng):
    model = MODELS[name]()
    ends = lp.end_joints(model)
    for _ in range(3):
        q, _ = _state(model, rng)
        P = joint_positions(model, q)
        a, b = lp.search_interval(model, q)
        for i in range(model.n_links):
            l = model.chain.links[i].length
            p = lp.material_points(model, q, i, [0.0, a[i], b[i]])
            # x = 0 is link i's frame origin O_(i+1) (a Pb link's rear end).
            assert np.max(np.abs(p[0] - P[i])) <= 1e-13
            assert b[i] == l
            for k, j in enumerate(ends[i]):
                if j >= 0:
                    assert np.max(np.abs(p[1 + k] - P[j])) <= 1e-13, (name, i, k)


def test_end_joints_of_prismatic_chains():
    # Joint points: O1 O2 O3, then the tip of link 1 (host of the prismatic joint 2).
    assert lp.end_joints(_prismatic("R-Pb")).tolist() == [[0, 3], [3, 2]]
    assert lp.end_joints(_prismatic("R-Pa")).tolist() == [[0, 3], [1, 2]]
    assert lp.end_joints(_prismatic("Pb-R")).tolist() == [[-1, 1], [1, 2]]
    assert lp.end_joints(_case1()).tolist() == [[0, 1], [1, 2]]


def test_end_joints_of_a_serial_chain_with_a_weld(rng):
    """A weld sits at its host's tip like a revolute (model.joints.JOINT_KINDS: not prismatic), so the
    tip of its host is the weld's frame origin, not an extra point: the end of each link's search
    interval is the contact point Model.tip_points names (before, the weld took an extra point
    index P that joint_positions has not). The positions are checked against the kernel's."""
    link = gi.Link(1.0, 1.0, 20.0, modes=[gi.Mode("clamped-clamped", "y")])
    model = gi.Model(gi.Chain([link] * 3, joints=[gi.Revolute(), gi.Weld(0.3), gi.Revolute()],
                              base=gi.FixedBase((0.0, 0.0))))
    ends = lp.end_joints(model)
    assert ends.tolist() == [[0, 1], [1, 2], [2, 3]]
    assert ends[:, 1].tolist() == list(model.tip_points)
    q = rng.normal(scale=0.1, size=model.n_dof)  # theta_1, theta_3 [rad], one delta per link [m]
    P = joint_positions(model, q)
    for i in range(model.n_links):
        tip = lp.material_points(model, q, i, [model.chain.links[i].length])[0]
        assert np.max(np.abs(tip - P[ends[i, 1]])) <= 1e-13


# -- 2. Jacobian and velocity-product acceleration ----------------------------------------------

def _fd_jacobian(model, q, i, x, eps=1e-6):
    J = np.empty((3, model.n_dof))
    for c in range(model.n_dof):
        dq = np.zeros(model.n_dof)
        dq[c] = eps
        plus, minus = lp.material_points(model, q + dq, i, [x])[0], lp.material_points(model, q - dq, i, [x])[0]
        J[:, c] = (plus - minus) / (2 * eps)
    return J


@pytest.mark.parametrize("name", list(MODELS))
def test_jacobian_and_a0_against_finite_differences(name, rng):
    model = MODELS[name]()
    for _ in range(2):
        q, qd = _state(model, rng)
        a, b = lp.search_interval(model, q)
        for i in range(model.n_links):
            l = model.chain.links[i].length
            # Random abscissae, on the protruding part of a Pb link and behind its guide.
            for x in (rng.uniform(a[i], b[i]), rng.uniform(0.0, l)):
                p, J, a0 = lp.material_jacobian(model, q, qd, i, x)
                assert np.allclose(p, lp.material_points(model, q, i, [x])[0], rtol=0, atol=1e-15)
                J_fd = _fd_jacobian(model, q, i, x)
                assert np.max(np.abs(J - J_fd)) <= 1e-7 * max(np.max(np.abs(J)), 1e-12), (name, i, x)
                eps = 1e-6
                Jp = lp.material_jacobian(model, q + eps * qd, qd, i, x)[1]
                Jm = lp.material_jacobian(model, q - eps * qd, qd, i, x)[1]
                a0_fd = (Jp - Jm) @ qd / (2 * eps)
                assert np.max(np.abs(a0 - a0_fd)) <= 1e-6 * max(np.max(np.abs(a0)), 1e-12), (name, i, x, a0, a0_fd)


def _smooth_elastic(model, q, qd, rng, amplitude=0.02):
    """Nodal values of smooth deflections v = A xi^2 (and velocities B xi^2) on the Hermite links,
    xi = x / l (or sigma / d behind a Pb guide), so that the motion has no element-scale modes."""
    for i, lk in enumerate(model.chain.links):
        if not lk.elements:
            continue
        ne, idx = lk.elements, model.delta_index[i]
        span = q[model.theta_index[i]] if model.joint_kinds[i] == "Pb" else lk.length
        xi = np.arange(1, ne + 1) / ne
        for k in range(len(lk.element_directions)):
            A, B = rng.uniform(-amplitude, amplitude, 2)
            block = idx[2 * ne * k:2 * ne * (k + 1)]
            q[block[0::2]], q[block[1::2]] = A * xi**2, 2 * A * xi / span
            qd[block[0::2]], qd[block[1::2]] = B * xi**2, 2 * B * xi / span
    return q, qd


@pytest.mark.parametrize("name", ["case1", "spatial-modal", "spatial-fe", "R-Pb"])
def test_acceleration_along_a_trajectory(name, rng):
    """pddot = J qddot + a0 against the fourth-order central second difference of p(t)."""
    model = MODELS[name]()
    q0, qd0 = _smooth_elastic(model, *_state(model, rng, delta=0.02), rng)
    if not model.free_base:
        qd0 *= 0.3   # keep the Pb link inside its range over the run
    # dt = 0.05 / omega_max (omega_max^2 the largest eigenvalue of (K, M)): the difference's
    # truncation error (omega dt)^4 / 90 is then ~7e-8 of the fastest mode's share of pddot.
    omega_max = np.sqrt(eigh(model.stiffness_matrix, model.mass_matrix(q0), eigvals_only=True)[-1])
    dt = 0.05 / omega_max
    res = gi.simulate(model, q0, qd0, (0.0, 40 * dt), rtol=1e-12, atol=1e-14, output_dt=dt)
    assert res.success
    k = len(res.t) // 2
    assert np.allclose(np.diff(res.t[k - 2:k + 3]), dt, rtol=1e-9)
    q, qd = res.q[k], res.qdot[k]
    qdd = model.forward_dynamics(q, qd)
    a, b = lp.search_interval(model, q)
    for i in range(model.n_links):
        # Abscissae at element midpoints on a Pb link: there d2v/dd2 jumps when a moving node passes x.
        u = np.linspace(0.0, 1.0, 4) if model.joint_kinds[i] != "Pb" else (np.arange(2) + 0.5) / 2
        for x in a[i] + u * (b[i] - a[i]):
            p = np.array([lp.material_points(model, res.q[j], i, [x])[0] for j in range(k - 2, k + 3)])
            pdd_fd = (-p[0] + 16 * p[1] - 30 * p[2] + 16 * p[3] - p[4]) / (12 * dt * dt)
            _, J, a0 = lp.material_jacobian(model, q, qd, i, x)
            pdd = J @ qdd + a0
            err = np.max(np.abs(pdd - pdd_fd)) / max(1.0, np.max(np.abs(pdd)))
            assert err <= 1e-5, (name, i, x, pdd, pdd_fd)


# -- 3. closest points --------------------------------------------------------------------------

@pytest.mark.parametrize("name", list(MODELS))
def test_closest_points_against_brute_force(name, rng):
    model = MODELS[name]()
    flexible = [i for i, lk in enumerate(model.chain.links) if lk.modes or lk.elements]
    n_interior = 0
    for trial in range(4):
        q, _ = _state(model, rng, delta=0.08)
        walls = _walls_near(model, q, rng)
        if flexible:
            walls += _walls_hugging(model, q, flexible[trial % len(flexible)], rng)
        res = lp.closest_points(model, q, walls)
        W = len(walls)
        assert res.x.shape == res.gap.shape == (W, model.n_links) and res.normal.shape == (W, model.n_links, 3)
        n_interior += int(lp.interior(model, q, res.x).sum())
        _check_against_brute_force(model, q, walls, res, (name, trial))
    # Rigid links: always an end (closed form); the hugging walls give interior minima.
    assert (n_interior == 0) if not flexible else (n_interior >= 4)


@pytest.mark.parametrize("name", list(MODELS))
def test_closest_points_to_obstacles_against_brute_force(name, rng):
    """Obstacles (inside=False, g = |P (p - c)| - R, convex along a line): the closest point of a
    rigid link is the projection of the centre onto it (closed form), of a flexible link a
    refined interior minimum; both against 10^5 samples and a bounded minimisation (<= 1e-10 m),
    with the obstacles beside the links at interior points (every pair of the obstacles beside
    link i has an interior minimum on link i)."""
    model = MODELS[name]()
    for trial in range(3):
        q, _ = _state(model, rng, delta=0.08)
        i = trial % model.n_links
        walls = _obstacles_near(model, q, i, rng) + _walls_near(model, q, rng)
        res = lp.closest_points(model, q, walls)
        assert lp.interior(model, q, res.x)[:2, i].all(), (name, trial, res.x[:2, i])
        _check_against_brute_force(model, q, walls, res, (name, trial))


def test_bowed_link_touches_at_mid_span():
    """A clamped-clamped link along X1 bowed by delta towards the plane X2 = -c: x* = l / 2, gap = c - delta."""
    model = _case1()
    q = model.state(X1=-1.0, delta_1_1=-0.05, delta_2_1=0.02)
    plane = gi.Plane((0.0, -0.1, 0.0), (0.0, 1.0, 0.0))
    res = lp.closest_points(model, q, [plane])
    assert abs(res.x[0, 0] - 0.5) <= 1e-9
    assert abs(res.gap[0, 0] - 0.05) <= 1e-14
    assert np.allclose(res.normal[0, 0], (0.0, 1.0, 0.0), rtol=0, atol=1e-15)
    # Link 2 bows away from the plane: its ends are closest (both at gap 0.1; the proximal one).
    assert res.x[0, 1] == 0.0 and abs(res.gap[0, 1] - 0.1) <= 1e-15
    assert lp.interior(model, q, res.x).tolist() == [[True, False]]


def test_batch_of_states_equals_one_by_one(rng):
    model = _spatial_fe()
    qs = np.array([_state(model, rng, delta=0.08)[0] for _ in range(5)])
    walls = _walls_near(model, qs[0], rng)
    batch = lp.closest_points(model, qs, walls)
    for k in range(5):
        one = lp.closest_points(model, qs[k], walls)
        for a, b in zip(batch, one):
            assert np.allclose(a[k], b, rtol=0, atol=1e-14)


def test_refine_below_keeps_the_sign_of_the_gap(rng):
    """Pairs whose lowest sample exceeds refine_below keep that sample: an upper bound of the exact
    minimum, above it by at most h^2/8 max|g''| (h = l / (S - 1)); the others are exact."""
    model = _case1()
    S = lp._tables(model).S
    for trial in range(5):
        q, _ = _state(model, rng, delta=0.08)
        walls = _walls_near(model, q, rng) + _walls_hugging(model, q, trial % 2, rng)
        exact = lp.closest_points(model, q, walls)
        rough = lp.closest_points(model, q, walls, refine_below=0.02)
        coarse = rough.gap > 0.02
        assert np.all(rough.gap >= exact.gap - 1e-15)
        # |g''| <= |v''| + |p'|^2 / R: here below 3 /m for the deflections and walls used.
        assert np.all(rough.gap - exact.gap <= (1.0 / (S - 1)) ** 2 / 8 * 3.0)
        assert np.allclose(rough.gap[~coarse], exact.gap[~coarse], rtol=0, atol=1e-15)


def test_interior_of_a_batch(rng):
    model = _prismatic("R-Pb")
    qs = np.array([_state(model, rng, delta=0.08)[0] for _ in range(3)])
    walls = _walls_hugging(model, qs[0], 1, rng)
    batch = lp.closest_points(model, qs, walls)
    inner = lp.interior(model, qs, batch.x)
    assert inner.shape == (3, 3, 2)
    for k in range(3):
        assert np.array_equal(inner[k], lp.interior(model, qs[k], lp.closest_points(model, qs[k], walls).x))



def test_dip_growing_out_of_a_resting_end_is_found():
    """Issue 25 item 5: link 2 lies with its end O2 on the floor (g = 0) and turns about it; g'(0) > 0
    still, but the curvature near the end already pulls the span below the end, so the sampled g'
    (17 samples on 1.2 m) is > 0 at both samples of the first interval and the old search
    returned the end, missing a dip of -1.6e-5 m at x = 0.04 m. The cubic Hermite interpolant of
    (g, g') on that interval has an interior minimum (_hidden_brackets): the dip is found, against
    10^5 samples and a bounded minimisation (<= 1e-10 m)."""
    model = issue25_item5_model()
    q = np.array([0.19272770594277291, -0.13589120957267337, 0.0, 0.0, 0.0, 6.523487512558426e-18,
                  0.36984665286241086, 1.0891726192508533, 2.3862880904649697, -0.14888650507160264,
                  -0.003130873598633499, -0.5352846211162231])
    res = lp.closest_points(model, q, [ISSUE25_ITEM5_FLOOR])
    _check_against_brute_force(model, q, [ISSUE25_ITEM5_FLOOR], res, "issue 25 item 5")
    assert res.gap[0, 1] < -1e-5 and 0.03 < res.x[0, 1] < 0.05
    # The end O2 is on the floor: the dip is below the end, an interior point.
    assert abs(ISSUE25_ITEM5_FLOOR.gap(joint_positions(model, q)[1:2])[0]) <= 1e-15
    assert lp.interior(model, q, res.x)[0, 1]
