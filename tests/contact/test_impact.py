"""The impulse solver on its own: energy never rises, Newton's law on every contact that carries an impulse.

Independent checks: the kinetic energy 1/2 qdot^T M qdot and the normal
velocities n.J qdot are recomputed from the model, and every round of the
impact is replayed with its own M^-1 W solve.
"""

import numpy as np
import pytest

import gibbsimpact as gi
from gibbsimpact.contact.impact import solve_impulses

from conftest import random_state


def _chains():
    cc = gi.Mode("clamped-clamped", "y")
    cf_y, cf_z = gi.Mode("clamped-free", "y"), gi.Mode("clamped-free", "z")
    rigid = gi.Link(1.0, 2.0, 1.0, rotary_inertia=(1e-4, 0.0, 0.0))
    return {
        "rigid rod": gi.Model(gi.Chain([rigid])),
        "two links, cc modes": gi.Model(gi.Chain([gi.Link(1.0, 1.0, 20.0, modes=[cc])] * 2)),
        "three links, spatial cf modes": gi.Model(gi.Chain([
            gi.Link(0.7, 1.0, (15.0, 25.0), modes=[cf_y, cf_z], rotary_inertia=(1e-4, 5e-5, 5e-5)),
            gi.Link(0.5, 0.5, 10.0, modes=[cc]),
            gi.Link(0.4, 2.0, (8.0, 8.0), modes=[cf_y, cf_z]),
        ])),
    }


def _unit(rng, n=3):
    v = rng.normal(size=n)
    return v / np.linalg.norm(v)


def test_reproducer_separating_contact_gains_no_energy():
    # Issue 12.2: a rod lying on a floor, O2 approaching (-0.5 m/s), O1 moving away
    # (+0.2 m/s), e = 1. Stopping O1 at v+ = 0 would raise the energy by 31.6 %.
    model = gi.Model(gi.Chain([gi.Link(1.0, 1.0, (20.0, 20.0), rotary_inertia=(5e-5, 2.5e-5, 2.5e-5))]),
                     gravity=(0.0, 0.0, 0.0))
    q, qd = np.array([0, 1e-10, 0, 0, 0, 0.0]), np.array([0, 0.2, 0, 0, 0, -0.7])
    res = gi.simulate(model, q, qd, (0.0, 0.05), walls=[gi.Plane((0, 0, 0), (0, 1, 0))], restitution=1.0)
    assert res.status == "finished", res.message
    E = res.energy().total
    assert np.max(E) <= E[0] * (1 + 1e-12)
    assert abs(E[-1] - E[0]) <= 1e-12 * E[0]  # e = 1: each round conserves it
    (rec,) = res.impacts
    assert rec.joints == (1, 2) and rec.rounds == 2
    assert np.all(rec.v_after >= 0)
    # Round 1: O2 alone reverses; O1 is pushed to a negative velocity; round 2 reverses that.
    M = model.mass_matrix(q)
    J = model.joint_jacobians(q)
    n = np.array([0.0, 1.0, 0.0])
    W = np.stack([J[0].T @ n, J[1].T @ n], axis=1)
    v1 = W.T @ qd
    G = W.T @ np.linalg.solve(M, W)
    lam2 = -2 * v1[1] / G[1, 1]
    v_mid = v1 + G[:, 1] * lam2
    assert v_mid[0] < 0
    lam1 = -2 * v_mid[0] / G[0, 0]
    v_end = v_mid + G[:, 0] * lam1
    np.testing.assert_allclose(rec.impulses, [lam1, lam2], rtol=1e-12)
    np.testing.assert_allclose(rec.v_after, v_end, rtol=1e-12)


def test_random_impulse_problems_never_raise_energy():
    # >= 10,000 random multi-contact problems: random chains, configurations, contact
    # points (joints, sometimes one joint against two walls), normals, velocities with
    # approaching and separating contacts, e in [0, 1] per contact.
    rng = np.random.default_rng(12)
    n_problems = n_multi_round = n_separating_pushed = 0
    worst_gain = worst_newton = 0.0
    for model in _chains().values():
        n_joints = model.n_joints
        for _ in range(170):
            q, _ = random_state(model, rng)
            M = model.mass_matrix(q)
            J = model.joint_jacobians(q)
            for _ in range(20):
                k = int(rng.integers(1, n_joints + 2))
                joints = rng.choice(n_joints, size=min(k, n_joints), replace=False).tolist()
                if k > n_joints:
                    joints.append(int(rng.integers(n_joints)))  # one joint at a corner of two walls
                W = np.stack([J[j].T @ _unit(rng) for j in joints], axis=1)
                qd = rng.normal(size=model.n_dof)
                v = W.T @ qd
                if not np.any(v < 0):
                    qd -= W[:, int(np.argmax(v))] * (v.max() + 0.5) / (W[:, int(np.argmax(v))] @ W[:, int(np.argmax(v))])
                    v = W.T @ qd
                e = rng.uniform(0, 1, len(joints)) if rng.uniform() < 0.7 else np.full(len(joints), rng.choice([0.0, 1.0]))
                sol = solve_impulses(M, W, qd, e)
                n_problems += 1
                T0 = 0.5 * qd @ M @ qd
                T1 = 0.5 * sol.qdot_after @ M @ sol.qdot_after
                worst_gain = max(worst_gain, (T1 - T0) / T0)
                assert T1 <= T0 * (1 + 1e-11) + 1e-14, (T0, T1)
                assert np.all(sol.impulses >= 0)
                scale = np.max(np.abs(v))
                # Recomputed normal velocities; no contact leaves into the wall.
                np.testing.assert_allclose(W.T @ sol.qdot_after, sol.v_after, atol=1e-12 * scale)
                assert np.all(sol.v_after >= -1e-10 * scale)
                # Replay every round: Newton's law on each contact that carries an impulse in it.
                qdr = qd.copy()
                for r_i, rnd in enumerate(sol.rounds):
                    S = rnd.contacts
                    vr = W[:, S].T @ qdr
                    np.testing.assert_allclose(vr, rnd.v_before, atol=1e-11 * scale)
                    assert np.all(rnd.impulses >= 0)
                    qdr = qdr + np.linalg.solve(M, W[:, S] @ rnd.impulses)
                    vr_after = W[:, S].T @ qdr
                    act = rnd.impulses > 1e-12 * np.max(rnd.impulses, initial=0.0)
                    plastic = r_i == 10 * len(joints) + 10  # the closing round, never reached here
                    target = np.zeros(act.sum()) if plastic else -e[S][act] * vr[act]
                    err = np.abs(vr_after[act] - target)
                    worst_newton = max(worst_newton, float(err.max(initial=0.0)) / scale)
                    assert np.all(err <= 1e-9 * scale)
                    # Only contacts that approach or rest carry an impulse in a Newton round.
                    assert plastic or np.all(vr[act] <= 1e-9 * scale)
                np.testing.assert_allclose(qdr, sol.qdot_after, atol=1e-10 * max(1.0, np.abs(qd).max()))
                n_multi_round += len(sol.rounds) > 1
                n_separating_pushed += np.any((v > 0) & (sol.impulses > 0))
    assert n_problems >= 10_000
    # The sample exercises what it is meant to: impacts that need more than one round.
    assert n_multi_round > 100, n_multi_round
    assert n_separating_pushed > 50, n_separating_pushed
    print(f"{n_problems} problems, {n_multi_round} with several rounds; max relative energy change "
          f"{worst_gain:.2e}, max Newton residual {worst_newton:.2e}")


def test_jammed_rod_ends_in_a_plastic_round():
    # A rigid rod spanning the gap between a floor and a ceiling that fit it
    # exactly, e = 1, moving up: each end's rebound drives the other into its wall.
    # The rounds cannot end by themselves; the last, plastic round stops it.
    model = gi.Model(gi.Chain([gi.Link(1.0, 1.0, 1.0, rotary_inertia=(1e-4, 0, 0))]))
    q = model.state(theta_1=np.pi / 2)  # O1 at y = 0, O2 at y = 1
    J = model.joint_jacobians(q)
    W = np.stack([J[0].T @ [0, 1.0, 0], J[1].T @ [0, -1.0, 0]], axis=1)
    qd = model.state(X2=1.0)
    M = model.mass_matrix(q)
    sol = solve_impulses(M, W, qd, 1.0, max_rounds=7)
    assert len(sol.rounds) == 8
    np.testing.assert_allclose(sol.v_after, [0.0, 0.0], atol=1e-12)
    assert 0.5 * sol.qdot_after @ M @ sol.qdot_after <= 0.5 * qd @ M @ qd


@pytest.mark.parametrize("e", [0.0, 0.4, 1.0])
def test_single_contact_is_one_round(e):
    model = gi.Model(gi.Chain([gi.Link(1.0, 1.0, 20.0, modes=[gi.Mode("clamped-clamped", "y")])] * 2))
    rng = np.random.default_rng(3)
    q, qd = random_state(model, rng)
    J = model.joint_jacobians(q)
    w = J[2].T @ _unit(rng)
    qd -= w * ((w @ qd) + 1.0) / (w @ w)  # v_n = -1 m/s
    M = model.mass_matrix(q)
    sol = solve_impulses(M, w[:, None], qd, e)
    G = w @ np.linalg.solve(M, w)
    assert len(sol.rounds) == 1
    # Both sides solve M x = w with a backward-stable factorisation (LAPACK's LU here, the
    # impact solver's own), each with a relative forward error up to ~kappa(M) eps to first
    # order; kappa(M) = 1.8e5 at this state, so kappa eps = 3.9e-11 (the two routes differ by
    # 1.5e-12 with AVX-512 BLAS kernels, by less with Haswell's).
    kappa_eps = np.linalg.cond(M) * np.finfo(float).eps
    np.testing.assert_allclose(sol.impulses, [(1 + e) / G], rtol=kappa_eps)
    # v_after = w.qdot_after cancels O(1) terms: its round-off over 200 random states is
    # 2.2e-16 (median) to 6.3e-15 (worst) with the numpy kernel of 54f2dfd, 4.2e-15 with
    # the compiled kernel; 1e-14 m/s is that floor, not a physics tolerance.
    np.testing.assert_allclose(sol.v_after, [e], rtol=1e-12, atol=1e-14)
