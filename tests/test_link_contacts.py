"""Contact along links (issue 9 item 2): a flexible link that bulges into a wall between its joints.

Positions here come from the public kinematics (transforms, model.link_deflection), not from
gibbsimpact.linkpoints, which the event loop uses.
"""

import numpy as np
import pytest

import gibbsimpact as gi
from gibbsimpact.kinematics import transforms

G = 9.81


def points_along(model, q, n=64):
    """(n_links, n, 3) world points p(x) = T_i (x, v, w) at n abscissae per link [m]."""
    T = transforms(model, q)
    out = []
    for i, lk in enumerate(model.chain.links):
        x = np.linspace(0.0, lk.length, n)
        v, w = gi.model.link_deflection(model, q, i, x)
        r = np.stack((x, v, w, np.ones_like(x)), axis=1)
        out.append((r @ T[i].T)[:, :3])
    return np.array(out)


def flat_link():
    link = gi.Link(1.0, 1.0, 50.0, modes=[gi.Mode("clamped-clamped", "y")], rotary_inertia=(1e-4, 0, 0))
    return gi.Model(gi.Chain([link]), gravity=(0.0, -G, 0.0))


@pytest.mark.parametrize("e", [1.0, 0.5])
def test_flexible_link_falling_flat_hits_at_mid_span_first(e):
    # A clamped-clamped link lying flat 1 mm above a floor, its first mode moving towards it
    # (delta_dot < 0: the middle goes down, the ends stay): the middle reaches the floor first.
    model = flat_link()
    q0 = model.state(X1=-0.5, X2=1e-3)
    qd0 = model.state(delta_1_1=-0.5)
    floor = gi.Plane((0, 0, 0), (0, 1, 0))
    res = gi.simulate(model, q0, qd0, (0.0, 0.05), walls=[floor], restitution=e)
    assert res.status == "finished", res.message
    first = res.impacts[0]
    P = model.n_joints
    assert first.joints == (P + 1,)  # the closest point of link 1, not a joint
    x_hit = first.points[0, 0] + 0.5  # abscissa along the link (O1 at X1 = -0.5, the link along X1)
    assert x_hit == pytest.approx(0.5, abs=1e-3)  # mid-span (symmetric shape; the rigid part is level)
    assert abs(first.points[0, 1]) <= 1e-9
    # Newton's law at that point, from the velocity of the material point by central differences
    # of p(q + s qdot) at the impact configuration (public kinematics only).
    k = int(np.nonzero(res.t == first.time)[0][0])
    q = res.q[k]
    T0 = transforms(model, q)[0]

    def height(qq, x):
        v, _ = gi.model.link_deflection(model, qq, 0, np.array([x]))
        return float((transforms(model, qq)[0] @ np.array([x, v[0], 0.0, 1.0]))[1])

    x_loc = float(np.linalg.solve(T0[:3, :3], first.points[0] - T0[:3, 3])[0])
    h = 1e-6
    vn = [(height(q + h * qd, x_loc) - height(q - h * qd, x_loc)) / (2 * h) for qd in (first.qdot_before, first.qdot_after)]
    assert vn[0] < -0.1
    assert vn[1] == pytest.approx(-e * vn[0], rel=1e-7)
    assert first.energy_after.total == pytest.approx(first.energy_before.total, rel=1e-12) if e == 1.0 else \
        first.energy_after.total < first.energy_before.total
    # No material point (64 per link) beyond the floor at any stored sample.
    heights = np.array([points_along(model, qk)[..., 1].min() for qk in res.q])
    assert heights.min() >= -1e-9


def test_link_contacts_can_be_switched_off():
    # joints only: the bulge goes through the floor unnoticed (the published model), which the
    # penetration check between events catches.
    model = flat_link()
    res = gi.simulate(model, model.state(X1=-0.5, X2=1e-3), model.state(delta_1_1=-0.5), (0.0, 0.05),
                      walls=[gi.Plane((0, 0, 0), (0, 1, 0))], link_contacts=False)
    assert all(j <= model.n_joints for r in res.impacts for j in r.joints)
    heights = np.array([points_along(model, qk)[..., 1].min() for qk in res.q])
    assert heights.min() < -1e-4


def test_a_link_starting_beyond_a_wall_is_refused():
    model = flat_link()
    with pytest.raises(ValueError, match="link 1 bends .* beyond wall 1"):
        gi.simulate(model, model.state(X1=-0.5, X2=1e-3, delta_1_1=-0.01), np.zeros(7), (0.0, 0.01),
                    walls=[gi.Plane((0, 0, 0), (0, 1, 0))])


def test_link_impacts_are_stored_and_drawn(tmp_path):
    model = flat_link()
    res = gi.simulate(model, model.state(X1=-0.5, X2=1e-3), model.state(delta_1_1=-0.5), (0.0, 0.01),
                      walls=[gi.Plane((0, 0, 0), (0, 1, 0))], restitution=0.5)
    back = gi.load_result(res.save(tmp_path / "r.npz"))
    for a, b in zip(res.impacts, back.impacts):
        assert a.joints == b.joints
        np.testing.assert_array_equal(a.points, b.points)
    from gibbsimpact.plotting import _contacts_text

    assert _contacts_text(res, res.impacts[0]) == "link 1"
    fig = res.plot("configurations")
    assert any("link 1" in ax.get_title() for ax in fig.axes)
