"""Walking machines (issue 28 item 4, docs/walking.md): the compass gait's contact filter and limit cycle,
the rimless wheel's steady rolling speed.

The rigid compass gait is checked against an independent textbook model written here (no package
code): stance foot pinned, absolute leg angles th1 (stance, foot -> hip = l (-sin th1, cos th1)) and
th2 (swing, hip -> foot = l (sin th2, -cos th2)), uniform legs of mass m, length l, centre of mass at
l/2, inertia I = m l^2 / 12 about it, hip mass m_H; Lagrange's equations

    M(th) thdd + h(th, thd) = 0,   M = [[m_H l^2 + m a^2 + I + m l^2, -c cos(th1 - th2)],
                                        [-c cos(th1 - th2),          m b^2 + I]],   c = m l b,
    h = (-c sin(th1 - th2) thd2^2 - (m_H l + m a + m l) g sin th1,  c sin(th1 - th2) thd1^2 + m g b sin th2),

a = b = l/2; heel strike: the plastic, sticking impact of the swing foot on the 4-DOF floating
chain (foot position and the two angles), M4 (qd+ - qd-) = J^T Lambda, J qd+ = 0, then the legs swap.
"""

from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import fsolve

import gibbsimpact as gi
from gibbsimpact.contact import span_resting
from gibbsimpact.simulation.contact_filter import LeadFilter

CASES = Path(__file__).resolve().parents[2] / "cases"
G, L, M_LEG, M_HIP, SLOPE, CLEARANCE = 9.81, 1.0, 5.0, 10.0, np.radians(1.5), 0.05
A = B = L / 2
I_LEG = M_LEG * L * L / 12
NORMAL = np.array([np.sin(SLOPE), np.cos(SLOPE), 0.0])   # the slope's normal, into the free side
DOWNHILL = np.array([np.cos(SLOPE), -np.sin(SLOPE), 0.0])


# -- the textbook compass gait (independent of the package) ---------------------------------------

def _textbook_rhs(t, y):
    th1, th2, w1, w2 = y
    c = M_LEG * L * B
    M = np.array([[M_HIP * L * L + M_LEG * A * A + I_LEG + M_LEG * L * L, -c * np.cos(th1 - th2)],
                  [-c * np.cos(th1 - th2), M_LEG * B * B + I_LEG]])
    s = c * np.sin(th1 - th2)
    h = np.array([-s * w2 ** 2 - (M_HIP * L + M_LEG * A + M_LEG * L) * G * np.sin(th1),
                  s * w1 ** 2 + M_LEG * G * B * np.sin(th2)])
    return np.concatenate(((w1, w2), np.linalg.solve(M, -h)))


def _swing_foot(th):
    """(gap above the slope, distance ahead of the stance foot down the slope) [m] of the swing foot."""
    p = L * np.array([np.sin(th[1]) - np.sin(th[0]), np.cos(th[0]) - np.cos(th[1])])
    return p @ NORMAL[:2], p @ DOWNHILL[:2]


def _textbook_strike(th, w):
    """(th, w) of the new stance and swing legs after the plastic, sticking heel strike."""
    d1, d2 = np.array([-np.cos(th[0]), -np.sin(th[0])]), np.array([np.cos(th[1]), np.sin(th[1])])
    M4 = np.diag([0.0, 0.0, I_LEG, I_LEG])
    for mk, r1, r2 in ((M_HIP, L * d1, 0 * d2), (M_LEG, A * d1, 0 * d2), (M_LEG, L * d1, B * d2)):
        Jk = np.column_stack((np.eye(2), r1, r2))
        M4 += mk * Jk.T @ Jk
    J = np.column_stack((np.eye(2), L * d1, L * d2))  # the swing foot's velocity
    qd = np.concatenate(([0.0, 0.0], w))
    sol = np.linalg.solve(np.block([[M4, -J.T], [J, np.zeros((2, 2))]]), np.concatenate((M4 @ qd, [0.0, 0.0])))
    return th[::-1], sol[[3, 2]]


def _textbook_step(z):
    """(z after one step, step period [s], step length [m]) from z = (half inter-leg angle, w1, w2) just
    after a strike (legs symmetric about the slope normal)."""
    th = np.array([z[0] - SLOPE, -z[0] - SLOPE])

    def strike(t, y):
        gap, ahead = _swing_foot(y[:2])
        return gap if ahead > CLEARANCE else 1.0
    strike.terminal, strike.direction = True, -1
    sol = solve_ivp(_textbook_rhs, (0.0, 5.0), np.concatenate((th, z[1:])), events=strike, rtol=1e-12, atol=1e-12)
    y = sol.y_events[0][0]
    th2, w2 = _textbook_strike(y[:2], y[2:])
    return np.array([(th2[0] - th2[1]) / 2, *w2]), sol.t_events[0][0], _swing_foot(y[:2])[1]


@pytest.fixture(scope="module")
def textbook_cycle():
    """The textbook period-one gait: z* = (0.23375 rad, -0.92175 rad/s, -0.68170 rad/s), its period, step."""
    z = fsolve(lambda z: _textbook_step(z)[0] - z, [0.2337, -0.9218, -0.6817], xtol=1e-13)
    return z, *_textbook_step(z)[1:]


# -- the package's compass gait ----------------------------------------------------------------------

def biped(elements=0, EI=2.0e3):
    """Two legs (uniform, 5 kg, 1 m), a 10 kg hip mass at leg 1's tip, planar floating base at foot O1."""
    def leg(bodies=()):
        return gi.Link(L, M_LEG / L, EI, elements=elements, bodies=bodies)
    return gi.Model(gi.Chain([leg((gi.RigidBody(M_HIP),)), leg()], base="planar"), gravity=(0.0, -G, 0.0))


@pytest.fixture(scope="module")
def rigid_biped():
    return biped()


def start_state(model, z):
    """(q0, qdot0) of the package from the textbook's z: theta_1 = th1 + pi/2, theta_2 = th2 - th1 - pi."""
    th1, th2 = z[0] - SLOPE, -z[0] - SLOPE
    q0 = model.state(theta_1=th1 + np.pi / 2, theta_2=th2 - th1 - np.pi)
    return q0, model.state(theta_1=z[1], theta_2=z[2] - z[1])


def walk(model, z, t_end, **kw):
    ground = gi.Plane(point=(0.0, 0.0, 0.0), normal=tuple(NORMAL), friction=1.0)
    return gi.simulate(model, *start_state(model, z), (0.0, t_end), walls=[ground], restitution=0.0,
                       link_contacts=False, **kw)


def test_rigid_compass_gait_repeats_the_textbook_limit_cycle(rigid_biped, textbook_cycle):
    """From the textbook fixed point the package walks steps of the textbook period and length, each strike
    on O3 / O1 in turn with the old stance foot leaving (zero impulse), and the state after the first
    strike is the start state, legs swapped: an independent route to the same Poincare map. Both
    integrate at rtol 1e-10..1e-12 over 0.9 s: agreement to 1e-8 relative leaves a margin of 100."""
    z, period, step = textbook_cycle
    model = rigid_biped
    rule = LeadFilter(model, [0, 2], DOWNHILL, CLEARANCE)
    res = walk(model, z, 2 * period + 0.05, contact_filter=rule)
    assert res.status == "finished"
    strikes = [r for r in res.impacts if np.any(r.impulses > 0)]
    assert [r.time for r in strikes] == pytest.approx([period, 2 * period], rel=1e-8)
    feet = [r.points[np.argmax(r.impulses)] for r in strikes]
    assert (feet[0] @ DOWNHILL, feet[1] @ DOWNHILL) == pytest.approx((step, 2 * step), rel=1e-8)
    assert [r.joints[int(np.argmax(r.impulses))] for r in strikes] == [3, 1]
    # After strike 1 leg 2 stands: its absolute angular velocity is the textbook's new stance w1.
    qd = strikes[0].qdot_after
    assert (qd[2] + qd[3], -qd[3]) == pytest.approx((z[1], z[2] - z[1]), rel=1e-7)
    assert np.linalg.norm(strikes[0].friction_impulses) <= strikes[0].impulses.max()  # mu = 1: it sticks


def test_without_the_filter_the_straight_swing_foot_scuffs(rigid_biped, textbook_cycle):
    """The scuff the filter exists for: without it the swing foot O3 meets the slope behind the stance foot,
    before mid-step (textbook: 0.62 mm deep, from 8.6 cm behind it to level with it, 0.366-0.417 s), long
    before the heel strike."""
    z, period, _ = textbook_cycle
    res = walk(rigid_biped, z, period / 2, max_impacts=3)
    first = res.impacts[0]
    assert first.time == pytest.approx(0.36600, abs=1e-4)  # the textbook's scuff starts at 0.36600 s (+-5e-5 s)
    assert first.points[first.joints.index(3)] @ DOWNHILL < 0.0


def test_lead_filter_watches_a_foot_only_ahead_of_the_other(rigid_biped, textbook_cycle):
    """LeadFilter at the start state (stance foot O1 at 0, swing foot 0.463 m uphill): O3 not watched,
    O1 watched (it leads by 0.463 m > 5 cm), O2 (the hip, not listed) always; swapped ahead when the
    clearance exceeds the lead."""
    q0, _ = start_state(rigid_biped, textbook_cycle[0])
    assert LeadFilter(rigid_biped, [0, 2], DOWNHILL, CLEARANCE)(q0).tolist() == [True, True, False]
    assert LeadFilter(rigid_biped, [0, 2], DOWNHILL, 0.5)(q0).tolist() == [False, True, False]
    with pytest.raises(ValueError, match="contact_filter"):
        walk(rigid_biped, textbook_cycle[0], 0.1, contact_filter="feet")
    with pytest.raises(ValueError, match="one bool per contact candidate"):
        walk(rigid_biped, textbook_cycle[0], 0.1, contact_filter=lambda q: [True])


def test_compass_gait_case_file_walks_with_its_filter(textbook_cycle):
    """cases/compass_gait.toml holds the limit cycle and the [contact_filter] (which `show` states): its first
    strike at the textbook period."""
    from gibbsimpact.cli.commands import describe_case

    case = gi.load_case(CASES / "compass_gait.toml")
    assert isinstance(case.contact_filter, LeadFilter) and case.contact_filter.clearance == CLEARANCE
    assert "contact filter: lead: O1, O3 may begin a contact only 0.05 m ahead" in describe_case(case)
    res = case.simulate(t_end=1.0)
    strikes = [r.time for r in res.impacts if np.any(r.impulses > 0)]
    assert strikes == pytest.approx([textbook_cycle[1]], rel=1e-8)


@pytest.mark.slow
def test_bending_legs_tend_to_the_rigid_gait_like_one_over_EI(textbook_cycle):
    """Legs with one clamped-clamped mode (5 % damping) from the rigid limit-cycle state: the first strike's
    time differs from the rigid period by an amount that falls tenfold when EI grows tenfold (the legs'
    static bending under their loads ~ 1/EI; measured 7.6e-6 s at 1e3, 7.6e-7 s at 1e4 N m^2), and the
    energy balance (damping and the strike counted) closes to 1e-12 of the energy scale."""
    z, period, _ = textbook_cycle
    shift = {}
    for EI in (1e3, 1e4):
        legs = [gi.Link(L, M_LEG / L, EI, modes=[gi.Mode("clamped-clamped", "y")], damping=0.05, bodies=b)
                for b in ((gi.RigidBody(M_HIP),), ())]
        model = gi.Model(gi.Chain(legs, base="planar"), gravity=(0.0, -G, 0.0))
        res = walk(model, z, 0.95, contact_filter=LeadFilter(model, [0, 2], DOWNHILL, CLEARANCE))
        hits = [r.time for r in res.impacts if np.any(r.impulses > 0)]
        assert res.status == "finished" and len(hits) == 1
        assert res.energy_error_whole_run < 1e-12
        shift[EI] = hits[0] - period
    assert 0.0 < shift[1e4] < 1e-6 * period
    assert shift[1e3] / shift[1e4] == pytest.approx(10.0, rel=0.1)


# -- the rimless wheel (needs trees and welds: formulation.md §17) ------------------------------------

N_SPOKES, SPOKE, MU_SPOKE, M_HUB, I_HUB, WHEEL_SLOPE = 6, 1.0, 0.1, 10.0, 0.5, np.radians(12.0)


def rimless_wheel_speed(m, I_c, l, alpha, slope, g=G):
    """McGeer's (1990) steady rolling speed |omega_end| [rad/s] just before each impact.

    m [kg]: the wheel's whole mass (hub and spokes); I_c [kg m^2]: its inertia about its centre of
    mass, which is the hub (the spokes are symmetric); l [m]: hub-to-foot length of a spoke;
    alpha [rad]: half the angle between neighbouring spokes (pi / N); slope [rad].
    A stance phase turns the wheel about its sticking foot by 2 alpha, from the spoke at slope - alpha
    to slope + alpha from the vertical: the hub drops 2 l sin(alpha) sin(slope), so
    (I_c + m l^2)(omega_end^2 - omega_start^2) / 2 = 2 m g l sin(alpha) sin(slope).
    The plastic impact on the new foot keeps the angular momentum about it (the old foot leaves
    with no impulse): the hub's velocity l omega is normal to the old spoke, at 2 alpha from the new
    one, so I_c omega_end + m l^2 cos(2 alpha) omega_end = (I_c + m l^2) omega_start, i.e.
    omega_start = r omega_end, r = (I_c + m l^2 cos 2 alpha) / (I_c + m l^2). A steady gait repeats
    omega_end: omega_end^2 (1 - r^2) = 4 m g l sin(alpha) sin(slope) / (I_c + m l^2).
    """
    r = (I_c + m * l * l * np.cos(2 * alpha)) / (I_c + m * l * l)
    return np.sqrt(4 * m * g * l * np.sin(alpha) * np.sin(slope) / ((I_c + m * l * l) * (1 - r * r)))


def rimless_wheel():
    """Spoke 1 is the root, its O1 at the hub (with the hub's RigidBody); spokes 2..N welded to it at the hub."""
    hub = gi.RigidBody(M_HUB, inertia=(I_HUB / 2, I_HUB / 2, I_HUB), at=0.0)  # a disc
    spokes = [gi.Link(SPOKE, MU_SPOKE, 1.0, bodies=(hub,))]
    spokes += [gi.Link(SPOKE, MU_SPOKE, 1.0) for _ in range(N_SPOKES - 1)]
    joints = [gi.Revolute()] + [gi.Weld(angle=2 * np.pi * k / N_SPOKES) for k in range(1, N_SPOKES)]
    chain = gi.Chain(spokes, joints=joints, parents=[-1] + [0] * (N_SPOKES - 1), attach=[None] + [0.0] * (N_SPOKES - 1),
                     base="planar")
    return gi.Model(chain, gravity=(0.0, -G, 0.0))


@pytest.mark.slow
@pytest.mark.skipif(not (hasattr(gi, "Weld") and hasattr(span_resting, "tip_point_terms")),
                    reason="rimless wheel: needs trees, gi.Weld and resting at a tree's free tips (issue 28 items 1-2)")
@pytest.mark.parametrize("omega0", [1.2, 1.5, 1.8])
def test_rigid_rimless_wheel_reaches_mcgeers_steady_speed(omega0):
    """From several initial speeds [rad/s] (about the stance foot, right after a strike) the wheel's speed
    just before a strike tends to rimless_wheel_speed: omega_end^2 converges like r^(2k), r = 0.531 here,
    so 13 strikes leave 1e-7 of the initial difference: <= 1e-6 relative, the integration error (rtol
    1e-10) far below it. The speeds keep the wheel vaulting (omega0 > 0.95 rad/s: 1/2 (I_c + m l^2)
    omega0^2 > m g l (1 - cos(alpha - slope))) and its foot down (omega^2 l < g cos(alpha + slope) up to
    the first strike)."""
    model, alpha = rimless_wheel(), np.pi / N_SPOKES
    m = M_HUB + N_SPOKES * MU_SPOKE * SPOKE
    I_c = I_HUB + N_SPOKES * MU_SPOKE * SPOKE ** 3 / 3
    expected = rimless_wheel_speed(m, I_c, SPOKE, alpha, WHEEL_SLOPE)
    normal = np.array([np.sin(WHEEL_SLOPE), np.cos(WHEEL_SLOPE), 0.0])
    # Spoke 1 stands on its foot at the origin, alpha downhill of the slope normal seen from the hub (spoke N touches
    # too: right after a strike), turning clockwise (downhill) at omega0 about the foot.
    down = alpha - WHEEL_SLOPE - np.pi / 2  # spoke 1 (the front foot): hub -> foot
    hub = -SPOKE * np.array([np.cos(down), np.sin(down)])
    q0 = model.state(X1=hub[0], X2=hub[1], theta_1=down)
    v_hub = -omega0 * np.array([-hub[1], hub[0]])  # omega = -omega0 about the foot: v = omega x (hub - foot)
    qd0 = model.state(X1=v_hub[0], X2=v_hub[1], theta_1=-omega0)
    ground = gi.Plane(point=(0.0, 0.0, 0.0), normal=tuple(normal), friction=2.0)
    res = gi.simulate(model, q0, qd0, (0.0, 14.0), walls=[ground], restitution=0.0, link_contacts=False)
    strikes = [r for r in res.impacts if np.any(r.impulses > 0)]
    assert res.status == "finished" and len(strikes) >= 13, (res.status, len(strikes))
    omega_end = [-r.qdot_before[model.coordinate_names.index("theta_1")] for r in strikes]
    assert omega_end[12] == pytest.approx(expected, rel=1e-6)
    assert abs(omega_end[0] / expected - 1) > 1e-3  # it started away from the steady speed


@pytest.mark.slow
def test_rimless_wheel_case_file_contracts_to_mcgeers_speed_by_r_squared():
    """cases/rimless_wheel.toml (the wheel above from 1.5 rad/s over 4 s): a rigid wheel's speed before
    strike k+1 follows exactly from the one before strike k (rimless_wheel_speed's docstring: the impact
    scales omega by r, the stance phase adds 4 m g l sin(alpha) sin(slope) / (I_c + m l^2) to omega^2), so
    (omega_{k+1}^2 - omega_end^2) = r^2 (omega_k^2 - omega_end^2) strike by strike; the ratio holds to the
    integration error (rtol 1e-10) amplified by the difference's smallness (>= 1e-3 of omega_end^2 here)."""
    case = gi.load_case(CASES / "rimless_wheel.toml")
    model, alpha = case.model, np.pi / N_SPOKES
    assert model.n_dof == 3 and sum(j.kind == "W" for j in model.chain.joints) == N_SPOKES - 1
    m = M_HUB + N_SPOKES * MU_SPOKE * SPOKE
    I_c = I_HUB + N_SPOKES * MU_SPOKE * SPOKE ** 3 / 3
    w_star = rimless_wheel_speed(m, I_c, SPOKE, alpha, WHEEL_SLOPE)
    r = (I_c + m * SPOKE ** 2 * np.cos(2 * alpha)) / (I_c + m * SPOKE ** 2)
    res = case.simulate()
    strikes = [s for s in res.impacts if np.any(s.impulses > 0)]
    w = np.array([-s.qdot_before[model.coordinate_names.index("theta_1")] for s in strikes])
    assert res.status == "finished" and len(w) >= 4, (res.status, len(w))
    d = w ** 2 - w_star ** 2
    np.testing.assert_allclose(d[1:] / d[:-1], r * r, rtol=1e-6)
