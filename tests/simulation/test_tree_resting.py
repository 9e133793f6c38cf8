"""A tree comes to rest on its free tips (formulation §17: every link end that carries no child is a
contact point; a tree's free tips rest through span_resting.tip_point_terms)."""

import numpy as np
import pytest

import gibbsimpact as gi


@pytest.mark.slow
def test_welded_v_stands_on_both_feet():
    """A rigid hub with two legs welded at +-0.5 rad, dropped onto a floor (e = 0, mu = 0.8): it lands
    on one foot (the last link's tip, a frame origin), tips over onto the other (a free tip, no frame
    origin) and stands. At rest both feet are on the floor and the normal forces carry the weight
    m g = 1.2 kg x 9.81 m/s^2 (statics, an independent balance) to the solver's tolerance."""
    hub, leg = gi.Link(0.2, 1.0), gi.Link(0.5, 1.0)
    chain = gi.Chain([hub, leg, leg], joints=[gi.Revolute(), gi.Weld(angle=0.5), gi.Weld(angle=-0.5)],
                     parents=[-1, 0, 0], base="planar")
    m = gi.Model(chain, gravity=(0.0, -9.81, 0.0))
    assert m.contact_point_names[-1] == "tip of link 2"
    r = gi.simulate(m, m.state(X2=0.8, theta_1=-1.5), np.zeros(m.n_dof), (0, 0.6),
                    walls=[gi.Plane((0, 0, 0), (0, 1, 0), friction=0.8)], restitution=0.0)
    assert r.status == "finished" and r.resting_time > 0.2
    feet = m.joint_positions(r.q[-1])[[3, 4], 1]
    np.testing.assert_allclose(feet, 0.0, atol=1e-9)
    assert np.max(np.abs(r.qdot[-1])) <= 1e-9
    F = r.contact_forces[-1, 0]
    assert F[3] > 0 and F[4] > 0
    assert F.sum() == pytest.approx(1.2 * 9.81, rel=1e-6)
