"""What each contact point is (simulation/contact_points.py): the points where Newton's law is ill-posed,
checked against their effective mass under refinement (a second route: M and the Jacobians only), the
dwell of an episode against the cantilever's closed form, and the numbers of docs/theory.md §11.4."""

import numpy as np
import pytest

import gibbsimpact as gi
from conftest import issue26_arm, issue26_model, two_link_circle_model
from gibbsimpact.dynamics.link_points import material_jacobian
from gibbsimpact.simulation.contact_points import contact_points, rebound_period

UP = np.array([0.0, 1.0, 0.0])


def effective_mass(model, q, J, n=UP) -> float:
    """1 / (n^T J M^-1 J^T n) [kg] of a point with Jacobian J (3, N) along the unit vector n."""
    w = J.T @ n
    return 1.0 / float(w @ np.linalg.solve(model.mass_matrix(q), w))


def fe_pair(elements):
    """Two finite-element links (1 m, 1 kg/m, EI = 1e4) on a pivot, bent at the elbow: O2 a joint, O3 the tip."""
    link = gi.Link(1.0, 1.0, 1e4, elements=elements)
    model = gi.Model(gi.Chain([link, link], base=gi.FixedBase((0.0, 0.5))), gravity=(0.0, -9.81, 0.0))
    return model, model.state(theta_1=-np.pi / 6, theta_2=0.4)


def test_what_each_point_is():
    ill = lambda model: [p.newton_ill_posed for p in contact_points(model)]  # noqa: E731
    fe_arm = contact_points(issue26_model(elements=2))
    assert [(p.name, p.description, p.link, p.free) for p in fe_arm] == [
        ("O1", "joint 1", None, False), ("O2", "tip of link 1", 0, True), ("link 1.1", "span of link 1", 0, True),
        ("link 1.2", "span of link 1", 0, True)]  # one span column per element (contact/span_cells.py)
    assert ill(issue26_model(elements=0)) == [False, False]  # a rigid rod: no span column either
    cf = issue26_model(elements=0, modes=[gi.Mode("clamped-free", "y")])
    assert ill(cf) == [False, True, True]
    # The published chains: clamped-clamped modes leave every joint on its link frame.
    case1 = contact_points(two_link_circle_model())
    assert [p.link for p in case1[:3]] == [None, None, None] and ill(two_link_circle_model())[:3] == [False] * 3
    # Two finite-element links: the elbow O2 is moved by link 1's elements but holds link 2; the tip is free.
    model, _ = fe_pair(2)
    assert [(p.link, p.free, p.newton_ill_posed) for p in contact_points(model, link_contacts=False)] == [
        (None, False, False), (0, False, False), (1, True, True)]


@pytest.mark.parametrize("elements", [8])
def test_ill_posed_points_are_those_whose_effective_mass_vanishes_under_refinement(elements):
    # From n_e to 2 n_e elements: the effective mass of an ill-posed point halves (like the element length),
    # that of a well-posed one changes by a few per cent (measured 0.95; 0.9 leaves room below).
    coarse, fine = fe_pair(elements), fe_pair(2 * elements)
    for j, point in enumerate(contact_points(coarse[0], link_contacts=False)):
        if j == 0:
            continue  # the pivot: J = 0
        ratio = (effective_mass(*fine, fine[0].joint_jacobians(fine[1])[j])
                 / effective_mass(*coarse, coarse[0].joint_jacobians(coarse[1])[j]))
        assert (ratio < 0.55) if point.newton_ill_posed else (ratio > 0.9), (point, ratio)
    # A span point (mid-link 2) is ill-posed too.
    mid = [effective_mass(m, q, material_jacobian(m, q, np.zeros(m.n_dof), 1, 0.5)[1]) for m, q in (coarse, fine)]
    assert mid[1] / mid[0] < 0.55


def test_rebound_period_closed_forms():
    # Finite elements: the cantilever, omega_1 = 1.875104^2 sqrt(EI / mu) / l^2 (cubic Hermite elements converge
    # as h^4: 8 of them give omega_1 to 2e-6); one clamped-clamped mode is its own eigenfunction: 4.730041^2.
    EI, mu, l = 1e3, 1.0, 1.0
    cantilever = gi.Model(gi.Chain([gi.Link(l, mu, EI, elements=8)]))
    assert rebound_period(cantilever, 0) == pytest.approx(
        2 * np.pi * l**2 / (1.8751040687119611**2 * np.sqrt(EI / mu)), rel=1e-5)
    assert rebound_period(two_link_circle_model(), 0) == pytest.approx(
        2 * np.pi / (4.730040744862704**2 * np.sqrt(20.0)), rel=1e-9)
    assert rebound_period(issue26_model(elements=0), 0) == 0.0


#: docs/theory.md §11.4: the first impulse of the issue's arm (EI = 1e4) for n_e = 1, 2, 4, 8, 16, simulated
#: (benchmarks/newton_point_refinement.py), and the rigid rod's.
DOCS_IMPULSES = {1: 0.44337, 2: 0.23826, 4: 0.12010, 8: 0.06005, 16: 0.03003}
DOCS_RIGID = 2.21472


def test_the_docs_impulses_halve_with_every_doubling_of_elements():
    # Second route: Lambda = (1 + e) v_n m_eff, the arm rigid at the impact (-30 deg, omega^2 = 3 g sin 30 / l,
    # v_n = l cos 30 omega), m_eff from M and J of each mesh.
    omega = np.sqrt(3.0 * 9.81 * 0.5)
    v_n = np.cos(np.pi / 6) * omega
    impulses = {}
    for ne in (0, *DOCS_IMPULSES):
        model = issue26_model(elements=ne)
        q = model.state(theta_1=-np.pi / 6)
        impulses[ne] = 1.5 * v_n * effective_mass(model, q, model.joint_jacobians(q)[1])
    assert impulses[0] == pytest.approx(DOCS_RIGID, abs=5e-6)
    # The simulated arm arrives vibrating a little (released from rest, EI = 1e4): 0.1 % apart.
    for ne, value in DOCS_IMPULSES.items():
        assert impulses[ne] == pytest.approx(value, rel=2e-3), ne
    for ne in (2, 4, 8):  # 0.5029, 0.5000, 0.5000: like the length of the last element
        assert impulses[2 * ne] / impulses[ne] == pytest.approx(0.5, abs=5e-3)
    # And the simulation itself (n_e = 1) gives the docs' number.
    assert issue26_arm().impacts[0].impulses[0] == pytest.approx(DOCS_IMPULSES[1], abs=5e-6)


def test_a_serial_chain_with_a_weld_strikes_a_floor_as_the_one_rod_it_makes():
    """A weld in a serial chain (formulation §17) is a contact point at its host's tip like a revolute
    joint, named 'weld 2'; before, describing it raised KeyError('W') and no run with walls could start.
    Second route: rods of 1 m and 0.5 m welded straight are one rigid rod of 1.5 m (same mass line),
    so a planar run onto a floor (e = 0.6, 15 impacts, the last ones resting) has the rod's impact
    times and final state; both integrate one ODE to rtol 1e-10, so they agree far below 1e-8."""
    rod = lambda length: gi.Link(length, 1.0, 10.0)  # noqa: E731  rigid (no modes): EI plays no part
    gravity, floor = (0.0, -9.81, 0.0), gi.Plane((0.0, 0.0, 0.0), (0.0, 1.0, 0.0))
    welded = gi.Model(gi.Chain([rod(1.0), rod(0.5)], joints=[gi.Revolute(), gi.Weld(0.0)], base="planar"), gravity=gravity)
    one = gi.Model(gi.Chain([rod(1.5)], base="planar"), gravity=gravity)
    assert [p.description for p in contact_points(welded)][:3] == ["joint 1", "weld 2", "tip of link 2"]
    runs = [gi.simulate(m, m.state(X1=0.0, X2=0.5, theta_1=-0.3), m.state(X1=0.2, X2=-1.0, theta_1=2.0),
                        (0.0, 0.8), walls=[floor], restitution=0.6) for m in (welded, one)]
    assert [r.status for r in runs] == ["finished", "finished"]
    assert len(runs[0].impacts) == len(runs[1].impacts) >= 10
    np.testing.assert_allclose([e.time for e in runs[0].impacts], [e.time for e in runs[1].impacts], atol=1e-8)
    np.testing.assert_allclose(runs[0].q[-1], runs[1].q[-1], atol=1e-8)
