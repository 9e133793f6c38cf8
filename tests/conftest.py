"""Shared model builders for the tests (the published chains and small variants)."""

import functools

import numpy as np
import scipy.linalg
import pytest

import gibbsimpact as gi
from gibbsimpact.dynamics.kinematics import transforms


def two_link_circle_model():
    """Case 1: two links, one clamped-clamped y-mode each, N = 9."""
    link = gi.Link(1.0, 1.0, 20.0, modes=[gi.Mode("clamped-clamped", "y")], geometric_stiffening=False)
    return gi.Model(gi.Chain([link, link]), gravity=(0.0, -9.81, 0.0))


def two_link_circle_state(model):
    q = model.state(X1=-np.cos(np.pi / 6), theta_1=-np.pi / 6, theta_2=np.pi / 3)
    return q, np.zeros_like(q)


def single_link_sphere_model():
    """Case 2: one link, y- and z-mode, rotary inertia of a round section r = 1 cm, N = 8."""
    r = 0.01
    link = gi.Link(
        1.0, 1.0, (20.0, 20.0),
        modes=[gi.Mode("clamped-clamped", "y"), gi.Mode("clamped-clamped", "z")],
        rotary_inertia=(r * r / 2, r * r / 4, r * r / 4), geometric_stiffening=False)
    return gi.Model(gi.Chain([link]), gravity=(0.0, -9.81, 0.0))


def single_link_sphere_state(model):
    q = model.state(theta_m1=0.3, theta_0=0.2, theta_1=0.5)
    q[:3] = -transforms(model, q)[0][:3, :3] @ np.array([0.5, 0.0, 0.0])
    qd = model.state(X1=0.4, X2=0.8, X3=0.24, theta_1=2.0, delta_1_1=0.2, delta_1_2=-0.1)
    return q, qd


#: (beta_k l) of a clamped-clamped beam, k = 1, 2, 3 (roots of cos z cosh z = 1; Blevins, Formulas for Natural
#: Frequency and Mode Shape, table 8-1).
CLAMPED_CLAMPED_ROOTS = (4.730040745, 7.853204624, 10.99560784)


def welded_beam_model(EI=50.0, mu=2.0, length=1.5):
    """One link welded to a fixed base with the first three clamped-clamped y-modes, no gravity: N = 3 and no
    rigid motion, so its frequencies are the beam's, (beta_k l)^2 sqrt(EI / (mu l^4)) (the assumed modes are its
    eigenfunctions): 54.80, 137.05, 268.67 rad/s as given."""
    link = gi.Link(length, mu, EI, modes=[gi.Mode("clamped-clamped", "y", k) for k in (1, 2, 3)],
                   geometric_stiffening=False)
    return gi.Model(gi.Chain([link], joints=[gi.Weld()], base=gi.FixedBase()), gravity=(0.0, 0.0, 0.0))


def random_state(model, rng, angle=0.8, delta=0.05, speed=1.0):
    """A random (q, qdot) away from gimbal lock (|theta_0| < 0.8 rad)."""
    N = model.n_dof
    q = rng.uniform(-angle, angle, N)
    q[:3] = rng.uniform(-1, 1, 3)
    for idx in model.delta_index:
        q[idx] = rng.uniform(-delta, delta, idx.size)
    return q, rng.normal(scale=speed, size=N)


@pytest.fixture
def rng():
    return np.random.default_rng(20261122)


# A case file of a rigid rod hanging from a guide at the base origin (Pb, joint 1): d_1'' = g,
# so from d_1 = 0.2 m at rest it reaches d_max = 0.5 m at t = sqrt(2 * 0.3 / 9.81) = 0.24731 s
# (tests/test_case.py, tests/test_cli.py).
PB_DROP_CASE = """
gravity_m_per_s2 = [0.0, -9.81, 0.0]

[base]
type = "fixed"
angle_deg = -90.0

[[links]]
length_m = 0.6
mass_per_length_kg_per_m = 1.0
EI_N_m2 = 1.0

[links.joint]
type = "Pb"
range_m = [0.1, 0.5]

[initial.coordinates]
d_1_m = 0.2

[time]
t_end_s = 0.4
"""


# A rod dropped flat with e = 0.5: its impacts accumulate (tests/cli, tests/contact).
ZENO = """
name = "zeno_drop"
gravity_m_per_s2 = [0.0, -9.81, 0.0]
restitution = 0.5

[[links]]
length_m = 1.0
mass_per_length_kg_per_m = 1.0
EI_N_m2 = 20.0
cross_section_radius_m = 0.01

[[walls]]
type = "plane"
point_m = [0.0, 0.0, 0.0]
normal = [0.0, 1.0, 0.0]

[initial.coordinates]
X1_m = -0.5
X2_m = 0.01

[time]
t_end_s = 1.0

[solver]
rtol = 1e-8
atol = 1e-10
zeno_interval_s = 0.05
zeno_count = 3
accumulation = "stop"
"""


def deepest_point(model, q, i, wall):
    """(x [m], depth [m]) of link i's material point farthest beyond ``wall``, from material_points and
    the wall's gap alone: the lowest of 2001 samples, refined by Brent's method between its neighbours."""
    from scipy.optimize import minimize_scalar

    from gibbsimpact.dynamics.link_points import material_points

    xs = np.linspace(0.0, model.chain.links[i].length, 2001)
    k = int(np.argmin(wall.gap(material_points(model, q, i, xs))))
    res = minimize_scalar(lambda x: wall.gap(material_points(model, q, i, [x]))[0], method="bounded",
                          bounds=(xs[max(k - 1, 0)], xs[min(k + 1, xs.size - 1)]), options={"xatol": 1e-12})
    return float(res.x), float(-res.fun)


#: Starts and sizes of the 7 accumulations of fixed_base_fe_arm run to 1 s (`gibbsimpact run
#: cases/fixed_base_fe_arm.toml --t-end 1`): 101 impacts of the tip O3 on the floor.
FE_ARM_BURSTS = ((0.525317, 15), (0.537676, 16), (0.631847, 14), (0.641583, 11), (0.683349, 14),
                 (0.745233, 17), (0.757550, 14))


def burst_result(bursts=FE_ARM_BURSTS, t_end=1.0, dt=1e-3, modes=1):
    """A Result (no dynamics: smooth made-up states) of a two-link arm on a fixed base whose tip O3
    strikes a floor in bursts [(start [s], impacts)], each an accumulation of rebounds whose
    intervals shrink by e = 0.6 from 0.34 ms (0.85 ms in all at most), samples every ``dt`` plus
    both sides of each impact; ``modes`` clamped-free y-modes per link."""
    from gibbsimpact.simulation.results import ImpactRecord, Result

    link = gi.Link(1.0, 1.0, 25.0, modes=[gi.Mode("clamped-free", "y", k + 1) for k in range(modes)], geometric_stiffening=False)
    model = gi.Model(gi.Chain([link, link], base=gi.FixedBase((0.0, 0.6), 0.0)), gravity=(0.0, -9.81, 0.0))
    times = np.concatenate([np.zeros(0)] + [start + np.r_[0.0, np.cumsum(3.4e-4 * 0.6 ** np.arange(n - 1))]
                                            for start, n in bursts])
    t = np.sort(np.concatenate([np.arange(0.0, t_end + 0.5 * dt, dt), times, times]))
    N = model.n_dof
    w = 2 * np.pi * np.arange(1, N + 1) / N  # rad/s, one per coordinate
    q = 0.3 * np.sin(np.outer(t, w))
    qdot = 0.3 * w * np.cos(np.outer(t, w))
    phase = np.searchsorted(times, t, side="left")
    E = gi.Energy(0.0, 0.0, 0.0, 0.0)
    impacts = [ImpactRecord(float(ti), (3,), (0,), np.array([[0.0, 1.0, 0.0]]), np.ones(1), -np.ones(1),
                            0.6 * np.ones(1), 0.6 * np.ones(1), np.zeros(N), np.zeros(N), E, E) for ti in times]
    return Result(model=model, walls=(gi.Plane((0.0, 0.0, 0.0), (0.0, 1.0, 0.0)),), t=t, q=q, qdot=qdot,
                  phase=phase, impacts=impacts, status="finished", message="")


def issue26_model(elements=1, EI=1e4, modes=()):
    """The arm of issue 26: one link, l = 1 m, mu = 1 kg/m, on a pivot at (0, 0.5) m, with ``elements`` Hermite
    elements (0 and no modes: the rigid rod) or assumed ``modes``."""
    link = gi.Link(1.0, 1.0, EI, elements=elements, modes=modes, geometric_stiffening=False)
    return gi.Model(gi.Chain([link], base=gi.FixedBase((0.0, 0.5))), gravity=(0.0, -9.81, 0.0))


#: The floor Y = 0 of issue 26, e = 0.5.
ISSUE26_FLOOR = gi.Plane((0.0, 0.0, 0.0), (0.0, 1.0, 0.0), restitution=0.5)


@functools.cache
def issue26_arm(elements=1, EI=1e4, t_end=0.275, accumulation="rest"):
    """The arm of issue 26 released horizontal at rest onto the floor (its tip lands at 0.268 s; with one
    element, EI = 1e4: 23 impacts and 0.58 ms of resting contact to 0.275 s, 2.4 s of CPU); warnings are
    silenced here (tests/simulation/test_validity.py checks the one it gives). Shared by the test modules."""
    import warnings

    model = issue26_model(elements, EI)
    q0 = np.zeros(model.n_dof)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", gi.ValidityWarning)
        return gi.simulate(model, q0, np.zeros_like(q0), (0.0, t_end), walls=[ISSUE26_FLOOR],
                           accumulation=accumulation)


def warning_run():
    """The issue 26 arm (1 element) made soft (EI = 20 N m^2, omega_1 = 15.8 rad/s), bent 0.15 m at its tip and
    thrown at the floor at 6 rad/s: each kind of run warning once (initial deflection, Newton at the element's
    tip, the spin across the link); (the Result, the messages simulate issued, in order). 0.4 s of CPU."""
    import warnings

    model = issue26_model(elements=1, EI=20.0)
    q0, qd0 = model.state(delta_1_1=-0.15), model.state(theta_1=-6.0)
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always", gi.ValidityWarning)
        res = gi.simulate(model, q0, qd0, (0.0, 0.15), walls=[ISSUE26_FLOOR])
    return res, [str(w.message) for w in record if issubclass(w.category, gi.ValidityWarning)]


#: Issue 25 item 5 (the random tester's reproducer): four links, link 2 with a pinned-pinned and a
#: clamped-clamped mode; gi.Link arguments (length, mass per length, EI, modes).
ISSUE25_ITEM5_LINKS = (
    (1.0332584103028422, 4.456424255023867, (1.2138397573378872, 1.2138397573378872), ()),
    (1.2065600293078453, 0.8127029300460183, (2.2906621986988864, 1.6099354542861524),
     (("pinned-pinned", "y", 1), ("clamped-clamped", "y", 1))),
    (1.3426463772531614, 0.8734618454289267, (24.431683210930398, 101.0284457378389), ()),
    (1.4506055004697493, 4.917844549613507, (21.67920335417858, 2.783118327624412), (("clamped-free", "y", 1),)),
)
ISSUE25_ITEM5_FLOOR = gi.Plane((0.0, -0.13589120957267337, 0.0), (0.0, 1.0, 0.0))


def issue25_item5_model():
    # Linear beams, as the random tester's runs were (they predate geometric_stiffening).
    links = [gi.Link(length, mu, EI, modes=[gi.Mode(*m) for m in modes], geometric_stiffening=False)
             for length, mu, EI, modes in ISSUE25_ITEM5_LINKS]
    return gi.Model(gi.Chain(links), gravity=(0.0, -9.81, 0.0))


#: Its initial state (q0, qdot0) and time span [s].
ISSUE25_ITEM5_Q0 = (0.0, 0.0, 0.0, 0.0, 0.0, 0.08736782551397138, 0.8290679050628729, 0.38942952098144035,
                    1.6585929369678118, 0.016768174926124046, -0.01290106204367606, -0.009427651300191893)
ISSUE25_ITEM5_QDOT0 = (0.8583076559391034, -1.4290051150753251, 0.0, 0.0, 0.0, -0.034431149144380946,
                       -0.48459053070925506, 0.7192051244024915, 2.9756709258501006, -0.17100324569045428, 0.0, 0.0)
ISSUE25_ITEM5_T_SPAN = (0.0, 0.2758842968532299)


#: The run of cases/fixed_base_R_Pb_arm.toml and fixed_base_R_Pa_arm.toml before they took method auto at rtol
#: 1e-2 (docs/benchmarks.md, "Stiff chains"): the tests that pin its numbers (DOP853's cost estimate, its
#: right-hand sides, its energy balance) run it explicitly, as keywords and as command-line options.
TIGHT_DOP853 = {"method": "DOP853", "rtol": 1e-8, "atol": 1e-10}
TIGHT_DOP853_ARGS = ("--method", "DOP853", "--rtol", "1e-8", "--atol", "1e-10")


def tight_dop853_text(text: str) -> str:
    """A prismatic arm's case-file text with its [solver] method, rtol, atol set to TIGHT_DOP853's."""
    old = 'method = "auto"\nrtol = 1e-2\natol = 1e-4\n'
    assert text.count(old) == 1
    return text.replace(old, 'method = "DOP853"\nrtol = 1e-8\natol = 1e-10\n')


def fast_mode_energy(model, q, qdot):
    """0.5 (phi^T M qdot)^2 [J]: the kinetic energy of the highest mode phi (K phi = omega^2 M phi, phi^T M phi = 1)
    of the chain linearised at q (N,), qdot (N,), K by central differences of dV/dq (as no stepper computes it).
    Shared by tests/simulation/test_compiled_radau.py and test_cutoff_radau.py."""
    from gibbsimpact.simulation.stability import mass_matrix, potential_forces
    N = model.n_dof
    K = np.empty((N, N))
    for j in range(N):
        dq = np.zeros(N)
        dq[j] = 1e-6 * max(1.0, abs(q[j]))
        K[:, j] = (potential_forces(model, q + dq) - potential_forces(model, q - dq)) / (2.0 * dq[j])
    M = mass_matrix(model, q)
    _, phi = scipy.linalg.eigh(0.5 * (K + K.T), M)
    return 0.5 * float(phi[:, -1] @ M @ qdot) ** 2


def started_run(model, q0, qdot0, walls, restitution=0.0, inputs=None, contact_tol=1e-6, method="DOP853"):
    """The event loop's Run (simulation.stages.start) of a simulate call from (q0, qdot0) (N,) over 1 s with
    simulate's defaults otherwise: for tests that drive single stages (a mode decision, a phase's right-hand side)."""
    import warnings

    from gibbsimpact.simulation.progress import Clock
    from gibbsimpact.simulation.settings import Settings
    from gibbsimpact.simulation.stages import start

    settings = Settings.from_arguments((0.0, 1.0), walls, restitution, method, None, None, inputs, 10, 10000, "stop",
                                       0.5, "rest", True, rtol=1e-10, atol=1e-12, contact_tol=contact_tol,
                                       max_step=np.inf, grazing_velocity=1e-6, penetration_tol=1e-6,
                                       zeno_interval=1e-6, state=(model, q0, qdot0))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", gi.ValidityWarning)
        return start(model, q0, qdot0, settings, Clock(None))


def pressed_arm_moment(model, res, g=9.81):
    """The moment about the base joint [N m] at the last sample of a one-link fixed-base finite-element arm resting on
    a floor (issue 25), from the public kinematics and the recorded forces only (independent of the dynamics): the
    moment of gravity on the material points (Gauss-Legendre, 8 points per element: exact for the cubic centreline)
    plus each recorded contact force (0, F_c, 0) at its recorded point (a joint, or the material point at
    Result.contact_abscissae). Returns (moment, F (C,) [N] the last sample's forces on wall 1)."""
    from gibbsimpact.dynamics.link_points import material_points

    link = model.chain.links[0]
    n_e = link.elements
    P, F, X = model.n_joints, res.contact_forces[-1, 0], res.contact_abscissae[-1, 0]
    xg, wg = np.polynomial.legendre.leggauss(8)
    h = link.length / n_e
    x = np.concatenate([(e + 0.5) * h + 0.5 * h * xg for e in range(n_e)])
    base = res.joint_positions()[-1, 0, 0]
    moment = -g * link.mass_per_length * float(
        np.sum(0.5 * h * np.tile(wg, n_e) * (material_points(model, res.q[-1], 0, x)[:, 0] - base)))
    joints = res.joint_positions()[-1, :, 0]
    for c in np.flatnonzero(F):
        at = joints[c] if c < P else material_points(model, res.q[-1], 0, X[c:c + 1])[0, 0]
        moment += float(F[c] * (at - base))
    return moment, F
