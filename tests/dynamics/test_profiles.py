"""Motion profiles of prescribed coordinates (gibbsimpact.dynamics.profiles): derivatives and closed forms."""

import math

import numpy as np
import pytest

import gibbsimpact as gi
from gibbsimpact.dynamics.profiles import PROFILE_KINDS, profile

PROFILES = {
    "spin_up": gi.profiles.spin_up(6.0, 15.0, 0.2),
    "constant_speed": gi.profiles.constant_speed(0.3, -1.5),
    "point_to_point": gi.profiles.point_to_point(0.1, 0.9, 0.5, 2.5),
    "samples": gi.profiles.samples(np.linspace(0.0, 20.0, 41), np.sin(np.linspace(0.0, 20.0, 41) / 3.0)),
}


@pytest.mark.parametrize("kind", PROFILE_KINDS)
def test_derivatives_are_consistent(kind):
    """qdot and qddot are the derivatives of q: a central difference of g with step h is off by
    h^2/6 |g'''| (truncation) plus about eps |g| / h (round-off). g''' is estimated from the profile's own
    qddot (q''' by its central difference, q'''' by its second difference), with a factor 2 of safety;
    the sample points keep h away from the kinks of qddot (t = T_s, the quintic's ends, the spline knots)."""
    f = PROFILES[kind]
    h, eps = 1e-4, np.finfo(float).eps
    for t in np.linspace(0.05, 19.95, 97):
        (q_m, qd_m, qdd_m), (q0, qd0, qdd0), (q_p, qd_p, qdd_p) = f(t - h), f(t), f(t + h)
        q3 = abs(qdd_p - qdd_m) / (2 * h)
        q4 = abs(qdd_p - 2 * qdd0 + qdd_m) / h ** 2
        tol_v = 2 * (h * h / 6 * q3 + 10 * eps * (1 + abs(q0)) / h)
        tol_a = 2 * (h * h / 6 * q4 + 10 * eps * (1 + abs(qd0)) / h)
        assert abs((q_p - q_m) / (2 * h) - qd0) <= tol_v, (kind, t)
        assert abs((qd_p - qd_m) / (2 * h) - qdd0) <= tol_a, (kind, t)


def test_spin_up_closed_form():
    """Kane, Ryan & Banerjee's spin-up, at the points where its closed form is a simple number:
    t = T/2: theta = Omega (T/8 - T/(2 pi^2)), rate Omega/2, acceleration 2 Omega/T; t = T: Omega T/2,
    Omega, 0; after T: Omega (t - T/2); before 0: at rest."""
    Om, T = 6.0, 15.0
    f = gi.profiles.spin_up(Om, T)
    eps = 4 * np.finfo(float).eps
    q, qd, qdd = f(T / 2)
    assert q == pytest.approx(Om * (T / 8 - T / (2 * math.pi ** 2)), rel=eps, abs=eps * Om * T)
    assert qd == pytest.approx(Om / 2, rel=eps) and qdd == pytest.approx(2 * Om / T, rel=eps)
    assert f(T - 1e-12) == pytest.approx((Om * T / 2, Om, 0.0), rel=1e-11, abs=1e-11)
    assert f(T) == (Om * T / 2, Om, 0.0) and f(30.0) == (Om * 22.5, Om, 0.0)
    assert f(-1.0) == (0.0, 0.0, 0.0)


def test_point_to_point_and_samples_closed_forms():
    """The quintic rests at both ends and passes the midpoint at (q_a + q_b)/2 with speed 15/8 (q_b - q_a)/T; a
    spline through samples of a cubic reproduces it (not-a-knot ends are exact for cubics)."""
    f = gi.profiles.point_to_point(0.1, 0.9, 0.5, 2.5)
    assert f(0.0) == (0.1, 0.0, 0.0) and f(3.0) == (0.9, 0.0, 0.0)
    q, qd, qdd = f(1.5)
    assert (q, qd, qdd) == pytest.approx((0.5, 15 / 8 * 0.8 / 2.0, 0.0), abs=1e-15)
    t = np.linspace(0.0, 2.0, 9)
    g = gi.profiles.samples(t, 1.0 - 2.0 * t + 0.5 * t ** 3)
    for s in (0.1, 0.77, 1.9):
        assert g(s) == pytest.approx((1 - 2 * s + 0.5 * s ** 3, -2 + 1.5 * s * s, 3 * s), abs=1e-13)
    assert g.domain == (0.0, 2.0)


def test_profile_by_kind_and_bad_parameters():
    assert profile("constant_speed", q0=1.0, v=2.0)(0.5) == (2.0, 2.0, 0.0)
    with pytest.raises(ValueError, match="kind='ramp' must be one of spin_up"):
        profile("ramp")
    with pytest.raises(ValueError, match="T_s=0.0 must be a finite positive number"):
        gi.profiles.spin_up(1.0, 0.0)
    with pytest.raises(ValueError, match="t_b=1.0 must be later than t_a=2.0"):
        gi.profiles.point_to_point(0.0, 1.0, 2.0, 1.0)
    with pytest.raises(ValueError, match="strictly increasing"):
        gi.profiles.samples([0.0, 2.0, 1.0, 3.0], [0.0, 0.0, 0.0, 0.0])


@pytest.mark.parametrize("kind", PROFILE_KINDS)
def test_profiles_pickle(kind):
    """A sweep over processes pickles the run's arguments: a profile comes back as the same function."""
    import pickle

    f = PROFILES[kind]
    g = pickle.loads(pickle.dumps(f))
    assert g.kind == f.kind and all(g(t) == f(t) for t in (0.3, 7.7, 16.0))
