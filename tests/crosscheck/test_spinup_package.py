"""The spin-up benchmark run by the package against the independent Ritz reference (issue 24).

A 10 m cantilever (mu = 1.2 kg/m, EI = 14 000 N m^2; Simo & Vu-Quoc 1986, Kane, Ryan & Banerjee
1987) clamped to a hub whose angle is prescribed by the spin-up profile (Omega_s = 6 rad/s,
T_s = 15 s, 30 s in all). The package: one Hermite-element link with geometric_stiffening=True,
theta_1 prescribed through ``gi.profiles.spin_up`` (simulate(prescribed=...)). The reference:
tests/crosscheck/spinup_reference.py, a Ritz model with foreshortening that imports nothing of the
package (polynomial basis, its own Lagrange equations), converged to 1.6e-4 of the peak at n = 4
and 3e-6 at n = 5 (test_spinup_reference).

Asserted: the run is bounded (finished, |v(L)| < 1 m) and the tip deflection in the hub frame
(the link frame of a root R joint is the hub frame) agrees with the reference to 1 % of its peak
over the whole 30 s, as the issue asks; measured 2.4e-4 of the peak with 4 elements. The
element discretisation error (O(h^4), ~1e-4 at 4 elements) and the reference's (~3e-6 at n = 5)
are both far below the 1 % bound, which is what the issue sets for the model's agreement.
"""

from __future__ import annotations

import numpy as np
import pytest
from spinup_reference import spinup_reference, spinup_summary

import gibbsimpact as gi
from gibbsimpact.model.shapes import link_deflection

L, MU, EI, OMEGA_S, T_S, T_END = 10.0, 1.2, 14000.0, 6.0, 15.0, 30.0


def package_tip(stiffened: bool, t_end: float, elements: int = 4):
    """(t (k,) [s], v(L, t) (k,) [m], Result) of the package's spin-up run."""
    link = gi.Link(L, MU, EI, elements=elements, geometric_stiffening=stiffened)
    model = gi.Model(gi.Chain([link], base=gi.FixedBase(position=(0.0, 0.0), angle=0.0)), gravity=(0.0, 0.0, 0.0))
    zero = np.zeros(model.n_dof)
    res = gi.simulate(model, zero, zero, (0.0, t_end), prescribed={"theta_1": gi.profiles.spin_up(OMEGA_S, T_S)},
                      rtol=1e-10, atol=1e-12, output_dt=0.05)
    v = np.array([link_deflection(model, q, 0, [L])[0][0] for q in res.q])
    return res.t, v, res


@pytest.mark.slow
def test_spin_up_of_a_stiffened_fe_link_matches_the_independent_reference():
    t, v, res = package_tip(True, T_END)
    assert res.status == "finished" and t[-1] == pytest.approx(T_END)
    assert np.max(np.abs(v)) < 1.0
    ref = spinup_reference(Omega_s=OMEGA_S, T_s=T_S, t_end=T_END, n=5, t_eval=t, L=L, mu=MU, EI=EI)
    peak = spinup_summary(ref, T_S)["peak"]
    assert np.max(np.abs(v - ref["tip_deflection"])) < 0.01 * peak


def test_spin_up_of_a_linear_link_runs_away_where_the_reference_does():
    """The linear beam (geometric_stiffening=False) follows the linear reference while it is small and
    then grows past the link's length once the hub outruns omega_1 = 3.80 rad/s (t ~ 8.5 s); the
    validity warning of issue 24 item 4 says so."""
    with pytest.warns(gi.ValidityWarning, match="geometric"):
        t, v, res = package_tip(False, 12.0, elements=2)
    assert np.max(np.abs(v)) > L
    ref = spinup_reference(Omega_s=OMEGA_S, T_s=T_S, t_end=7.0, n=5, t_eval=t[t <= 7.0], L=L, mu=MU, EI=EI,
                           foreshortening=False)
    small = t <= 7.0
    assert np.max(np.abs(v[small] - ref["tip_deflection"])) < 0.01 * np.max(np.abs(ref["tip_deflection"]))
