"""Contact points beyond a wall at the start (gibbsimpact.simulation.outside): what simulate refuses,
named by what is outside, where and how far (issue 23 item 12)."""

from __future__ import annotations

import re

import numpy as np
import pytest

import gibbsimpact as gi
from gibbsimpact.dynamics.link_points import material_points
from gibbsimpact.simulation.outside import outside_walls
from conftest import deepest_point

FLOOR = gi.Plane((0.0, 0.0, 0.0), (0.0, 1.0, 0.0))
# The circle's arc through (0, 0) and (1, 0) is 0.109 m above the floor at x = 0 and 1.
CIRCLE = gi.Circle(1.2, (0.5, 1.2))


def bent_link():
    """One finite-element link on a fixed base at (0, 0.15) m, turned 3 deg, its middle bent down by
    delta_1_1 = -0.25 m: both joints inside FLOOR and CIRCLE, the middle 7.8 cm beyond either."""
    link = gi.Link(1.0, 1.0, 10.0, elements=2, geometric_stiffening=False)
    model = gi.Model(gi.Chain([link], base=gi.FixedBase((0.0, 0.15), np.radians(3.0))), gravity=(0.0, -9.81, 0.0))
    return model, model.state(delta_1_1=-0.25, delta_1_2=0.2, delta_1_3=0.02)


@pytest.mark.parametrize("wall", [FLOOR, CIRCLE], ids=["plane", "circle"])
def test_the_deepest_point_of_a_bent_link_against_material_points(wall):
    model, q = bent_link()
    assert np.all(wall.gap(model.joint_positions(q)) > 0.03)
    (o,) = outside_walls(model, q, [wall], 1e-9)
    x_ref, depth_ref = deepest_point(model, q, 0, wall)
    assert (o.wall, o.joint, o.link) == (0, None, 0) and depth_ref > 0.07
    # At the minimum dg/dx = 0: an error dx in x* moves the gap by g'' dx^2 / 2 (below 1e-18 m for
    # dx ~ 1e-9 m); what is left is the round-off of two routes to p(x), ~1e-15 m.
    assert o.depth == pytest.approx(depth_ref, abs=1e-12)
    assert o.x == pytest.approx(x_ref, abs=1e-6)
    np.testing.assert_allclose(o.point, material_points(model, q, 0, [o.x])[0], rtol=0, atol=1e-15)
    assert wall.gap(np.array([o.point]))[0] == pytest.approx(-o.depth, abs=1e-15)
    assert outside_walls(model, q, [wall], 1e-9, link_contacts=False) == []  # the joints are inside


def test_simulate_names_the_link_not_a_joint():
    model, q = bent_link()
    with pytest.raises(ValueError) as info:
        gi.simulate(model, q, np.zeros_like(q), (0.0, 0.01), walls=[FLOOR])
    msg = str(info.value)
    x_ref, depth_ref = deepest_point(model, q, 0, FLOOR)
    assert msg.startswith("initial state q0 puts a link outside a wall: link 1 bends ")
    m = re.search(r"link 1 bends (\S+) m beyond wall 1 \(plane .*\) between its joints: its point at x = (\S+) m "
                  r"\(of 1 m\) is at \[(\S+), (\S+), (\S+)\] m\. Move the chain inside\.$", msg)
    assert m, msg
    assert float(m[1]) == pytest.approx(depth_ref, rel=5e-3)  # 3 significant digits
    assert float(m[2]) == pytest.approx(x_ref, rel=5e-6)      # 6 significant digits
    np.testing.assert_allclose([float(m[k]) for k in (3, 4, 5)], material_points(model, q, 0, [x_ref])[0],
                               rtol=0, atol=5e-7)             # rounded to 6 decimals
    # Joints only: nothing is outside at the start.
    res = gi.simulate(model, q, np.zeros_like(q), (0.0, 1e-4), walls=[FLOOR], link_contacts=False)
    assert res.t[0] == 0.0


def test_a_joint_outside_is_named_as_before():
    # A ceiling at y = 0.2 m: the tip O2 (y = 0.222309 m) is beyond it, the bent middle far below.
    model, q = bent_link()
    with pytest.raises(ValueError, match=r"puts a joint outside a wall: joint O2 at \[0\.997583, 0\.222309, 0\.0\] m "
                                         r"is 0\.0223 m outside wall 1 \(plane[^;]*\)\. Move the chain inside\.$"):
        gi.simulate(model, q, np.zeros_like(q), (0.0, 0.01), walls=[gi.Plane((0, 0.2, 0), (0, -1, 0))])


def test_a_rigid_rod_starting_through_an_obstacle_is_refused():
    # The rod's span at x = 0.3 m crosses a post of R = 0.1 m at the origin 0.05 m deep (|p - c| - R = -0.05).
    model = gi.Model(gi.Chain([gi.Link(1.0, 1.0, 20.0)], base="planar"), gravity=(0.0, -9.81, 0.0))
    with pytest.raises(ValueError, match=r"link 1 passes 0\.05 m beyond wall 1 \(circle R=0\.1 m centre \(0, 0\) "
                                         r"\(obstacle[^)]*\)\) between its joints: its point at x = 0\.3 m .*"
                                         r"Move the chain out of the obstacle\.$"):
        gi.simulate(model, model.state(X1=-0.3, X2=0.05), np.zeros(3), (0.0, 0.1),
                    walls=[gi.Circle(0.1, inside=False)])
