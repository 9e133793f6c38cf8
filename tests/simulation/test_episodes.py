"""Collision episodes (simulation/episodes.py, docs/theory.md §14.7): closed forms of a rigid rod on a pivot
and of a rod resting on a floor, the energy identity with the impacts' losses, the effective restitution
against the angular momentum about the pivot (a second route), and the grouping of micro-impacts."""

import dataclasses

import numpy as np
import pytest

import gibbsimpact as gi
from conftest import ISSUE26_FLOOR, issue26_arm
from gibbsimpact.simulation.contact_points import rebound_period
from gibbsimpact.simulation.episodes import episodes

G, E_WALL, L, MU = 9.81, 0.5, 1.0, 1.0


@pytest.fixture(scope="module")
def rigid_arm():
    """The rigid rod of issue 26: it lands at -30 deg (tip 0.5 m below the pivot), rebounds, lands again."""
    return issue26_arm(elements=0, t_end=0.7)


def test_rigid_rod_one_episode_per_bounce_closed_form(rigid_arm):
    res = rigid_arm
    assert len(res.impacts) == 2 and len(res.episodes) == 2
    # omega^2 = 3 g sin(30 deg) / l from m g (l/2) sin 30 = I omega^2 / 2, I = mu l^3 / 3; the tip's normal
    # velocity v_n = l cos 30 omega; Lambda = (1 + e) I omega / (l cos 30); lost: (1 - e^2) I omega^2 / 2.
    I = MU * L**3 / 3.0
    omega = np.sqrt(3.0 * G * 0.5 / L)
    v_n = L * np.cos(np.pi / 6) * omega
    first, second = res.episodes
    # rtol = 1e-10 on the fall: omega, and what follows from it, to ~1e-10.
    assert first.impulse == pytest.approx((1 + E_WALL) * I * omega / (L * np.cos(np.pi / 6)), rel=1e-9)
    assert first.energy_lost == pytest.approx(0.5 * (1 - E_WALL**2) * I * omega**2, rel=1e-9)
    # The rod flies back to -30 deg with e omega (no loss in flight): the second impulse is e times the first.
    assert second.impulse == pytest.approx(E_WALL * first.impulse, rel=1e-9)
    for ep, rec in zip(res.episodes, res.impacts):
        # One impact of a rigid chain: e_eff = -v_n+ / v_n- = e, to round-off.
        assert ep.restitution == pytest.approx(E_WALL, abs=1e-12)
        # Gravity acts for the 2-4 ns to the leave event: tau_g dt / H- ~ 1e-8, an impulsive collision.
        assert ep.non_contact_share < 1e-7
        assert (ep.n_impacts, ep.points, ep.first_point, ep.walls, ep.ended) == (1, (2,), 2, (0,), True)
        assert ep.start == rec.time and ep.max_force == 0.0 and ep.resting_time == 0.0
        # energy_lost is the impact's own loss, up to the flight's energy error between it and the leave event.
        loss = rec.energy_before.total - rec.energy_after.total
        assert ep.energy_lost == pytest.approx(loss, abs=res.energy_error * res.energy_scale)
        assert ep.max_penetration <= res.settings["contact_tol"]
    # It ends at the leave event: 1.5 b above the floor, b = 2 contact_tol, reached at e v_n (gravity changes
    # that speed by g 2e-9 s, 1e-8 of it).
    b = 2.0 * res.settings["contact_tol"]
    assert first.duration == pytest.approx(1.5 * b / (E_WALL * v_n), rel=1e-6)
    k1 = first.samples[1]
    assert ISSUE26_FLOOR.gap(res.joint_positions()[k1, 1][None])[0] > b


def test_resting_rod_episode_closed_form():
    # A rigid rod (planar base) lying on the floor from t0: one episode of resting contact, no impact.
    mu, l, T = 2.0, 1.0, 0.1
    rod = gi.Model(gi.Chain([gi.Link(l, mu, 1.0)], base="planar"), gravity=(0.0, -G, 0.0))
    res = gi.simulate(rod, np.zeros(3), np.zeros(3), (0.0, T), walls=[ISSUE26_FLOOR])
    (ep,) = res.episodes
    m = mu * l
    assert (ep.start, ep.end, ep.ended, ep.impacts, ep.points) == (0.0, T, False, (), (1, 2))
    # Both ends carry m g / 2 throughout: the impulse of the floor is m g T, its largest force m g / 2.
    assert ep.impulse == pytest.approx(m * G * T, rel=1e-12)
    assert ep.max_force == pytest.approx(m * G / 2.0, rel=1e-12)
    assert ep.resting_time == pytest.approx(T, rel=1e-12) and np.isnan(ep.restitution)


@pytest.fixture(scope="module")
def stopped_arm():
    """The flexible arm (one element, EI = 1e4) with accumulation='stop': 19 impacts, no resting, then 'zeno'."""
    return issue26_arm(accumulation="stop")


def test_episode_energy_is_the_sum_of_its_impacts_losses(stopped_arm):
    res = stopped_arm
    assert res.status == "zeno"
    (ep,) = res.episodes
    assert not ep.ended and ep.n_impacts == len(res.impacts) > 10 and ep.resting_time == 0.0
    # E(before the first impact) - E(end) = sum of the impacts' losses: the flights in between conserve E
    # up to the energy error of each phase (one phase per impact).
    losses = sum(r.energy_before.total - r.energy_after.total for r in res.impacts)
    tol = (ep.n_impacts + 1) * res.energy_error * res.energy_scale
    assert ep.energy_lost == pytest.approx(losses, abs=tol)
    assert ep.energy_before == res.impacts[0].energy_before.total
    # Newton's law keeps every gap within the contact band's restart rule: no penetration beyond contact_tol.
    assert ep.max_penetration <= res.settings["contact_tol"]


def test_effective_restitution_is_the_angular_momentum_ratio_about_the_pivot(stopped_arm):
    # The issue's measure, from model.angular_momentum and the centre of mass (no code shared with the
    # generalised momenta of episodes.py): e = -(H(end) - int tau_g dt) / H(start), H about the pivot.
    res = stopped_arm
    model = res.model
    (ep,) = res.episodes
    k0, k1 = ep.samples
    pivot = np.array([0.0, 0.5, 0.0])
    H = [model.angular_momentum(res.q[k], res.qdot[k], about=pivot)[2] for k in (k0, k1)]
    weight = model.total_mass * np.asarray(model.gravity)
    tau = np.array([np.cross(model.center_of_mass(res.q[k]) - pivot, weight)[2] for k in range(k0, k1 + 1)])
    t = res.t[k0:k1 + 1]
    impulse = np.trapezoid(tau, t)
    coarse = np.trapezoid(tau[::2], t[::2]) if len(t) % 2 else np.trapezoid(tau[:-1:2], t[:-1:2]) + np.trapezoid(
        tau[-2:], t[-2:])
    e_H = -(H[1] - impulse) / H[0]
    # Tolerance: the trapezoid's error on the gravity term (Richardson: the change on halving the samples).
    tol = 4.0 * abs(impulse - coarse) / abs(H[0]) + 1e-12
    assert ep.restitution == pytest.approx(e_H, abs=tol)
    # What the other forces did: gravity's angular impulse about the pivot, over H before (0.5 %).
    assert ep.non_contact_share == pytest.approx(abs(impulse / H[0]), abs=tol)


def test_micro_impacts_and_resting_phases_are_one_episode():
    res = issue26_arm()  # 23 impacts and resting phases within 3 ms
    (ep,) = res.episodes
    assert ep.impacts == tuple(range(len(res.impacts))) and ep.ended and ep.points == (2,)
    # Every resting interval lies in an episode: their resting times add up to the run's.
    assert sum(e.resting_time for e in res.episodes) == pytest.approx(res.resting_time, rel=1e-12)
    assert ep.max_force == pytest.approx(np.max(res.contact_forces), rel=0) and ep.max_force > 0
    assert ep.max_impulse == max(float(np.max(r.impulses)) for r in res.impacts)
    assert ep.max_penetration <= res.settings["contact_tol"]
    # What binds them is the dwell of the tip: one period of link 1 clamped at its frame (17.9 ms > the 3 ms
    # of the collision). Without it, each time the tip leaves the band it ends an episode.
    assert rebound_period(res.model, 0) > ep.duration
    split = episodes(res, dwell=0.0)
    assert len(split) > 1 and sum(e.n_impacts for e in split) == len(res.impacts)
    assert split[0].start == ep.start and split[-1].end == ep.end


def test_episodes_refuse_bad_input(rigid_arm):
    for bad in (-1.0, float("inf"), "1", True, [0.1]):
        with pytest.raises(ValueError, match="dwell"):
            episodes(rigid_arm, dwell=bad)
    by_hand = dataclasses.replace(rigid_arm, settings={})
    with pytest.raises(ValueError, match="result.settings has no contact_tol, rtol, atol"):
        episodes(by_hand)
    assert episodes(dataclasses.replace(rigid_arm, walls=())) == []


def test_e_eff_of_a_newton_impact_sees_neither_the_stiffness_nor_the_cutoff():
    """Case 1 with link 1 stiffened to EI = 1e9 N m^2, e = 1: auto runs Radau with the cutoff 1.27e4 rad/s, and its
    first episode's e_eff is 0.693, not 1 (docs/theory.md §14.7, "A stiff link under a cutoff"). Neither the
    cutoff nor a bug: a one-impact episode's e_eff is fixed by the impact alone, and Newton's law sets the impulse
    from M, where link 1's mode takes its share of the effective mass however stiff it is. So e_eff is the
    closed form (1 + e) rho - 1 of the published EI = 20 (rho = m_eff / m_eff,rigid at O2 along the normal, from
    M and J), and only making link 1 rigid gives its own rho' (0.922: e_eff 0.844)."""
    import copy
    from pathlib import Path

    from gibbsimpact.case import case_from_dict

    source = gi.load_case(Path(__file__).resolve().parents[2] / "cases" / "circle_two_link.toml").source

    def first(link1, **run):
        src = copy.deepcopy(source)
        src["links"][0].update(link1)
        if link1.get("modes") == []:
            del src["initial"]["coordinates"]["delta_1_1_m"]
        res = case_from_dict(src, name="c").simulate(t_end=0.46, **run)
        return res, res.impacts[0], res.episodes[0]

    def rho(model, q, n):
        rigid = gi.Model(gi.Chain([gi.Link(1.0, 1.0, 20.0)] * 2), gravity=model.gravity)
        w, wr = (m.joint_jacobians(qq)[1].T @ n for m, qq in ((model, q), (rigid, q[:7])))
        return (wr @ np.linalg.solve(rigid.mass_matrix(q[:7]), wr)) / (w @ np.linalg.solve(model.mass_matrix(q), w))

    stiff, rec, ep = first({"EI_N_m2": 1e9}, method="auto")
    assert stiff.settings["method"] == "Radau" and stiff.settings["cutoff_frequency"] == pytest.approx(1.27e4, rel=1e-2)
    q = stiff.q[ep.samples[0]]  # falling freely, undeformed: coordinates (X, theta_-1 .. theta_2, delta_1_1, delta_2_1)
    assert ep.impacts == (0,) and ep.non_contact_share < 1e-6
    r = rho(stiff.model, q, rec.normals[0])
    assert r == pytest.approx(0.8466, abs=1e-4) and ep.restitution == pytest.approx(2.0 * r - 1.0, abs=1e-8)
    rigid1, rec1, ep1 = first({"modes": []})
    assert rec1.time == pytest.approx(rec.time, abs=1e-9)
    r1 = rho(rigid1.model, np.delete(q, stiff.model.delta_index[0]), rec1.normals[0])
    assert r1 == pytest.approx(0.922, abs=1e-3) and ep1.restitution == pytest.approx(2.0 * r1 - 1.0, abs=1e-8)
