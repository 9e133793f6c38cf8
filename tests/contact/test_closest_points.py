"""contact/closest_points.py on stiffened links (geometric_stiffening=True): the search's samples and its
refinement run on the foreshortened centreline, checked against a route sharing no code with the search
(the public material points, dynamics/link_points.material_points, on a 2000-point grid)."""

from __future__ import annotations

import numpy as np
import pytest

import gibbsimpact as gi
from gibbsimpact.contact.closest_points import closest_points
from gibbsimpact.contact.span_cells import link_cells, link_minima
from gibbsimpact.dynamics.link_points import material_points

from link_models import _check_against_brute_force, _state, _walls_hugging, _walls_near

FLOOR = [gi.Plane((0, 0, 0), (0, 1, 0))]


def _arm(stiffened=True):
    """A 3-element arm (1 m, EI = 20 N m^2) on a fixed base 0.6 m above the floor."""
    link = gi.Link(1.0, 1.0, (20.0, 20.0), elements=3, geometric_stiffening=stiffened)
    return gi.Model(gi.Chain([link], base=gi.FixedBase((0.0, 0.6), 0.0)), gravity=(0.0, -9.81, 0.0))


def _tilted_state(theta=-0.1, k=0.03):
    """q (7,): the arm tilted by theta [rad], element 3 (x in [2/3, 1] m) bent so that its linear gap has the
    slope g_lin' = sin(theta) + cos(theta) v' = -k (1 - x)^2 (<= 0: monotone, lowest at the tip), i.e.
    v' = (|sin theta| - k (1 - x)^2) / cos theta; elements 1, 2 the cubic v = A x^2 + B x^3 from the clamped
    base to (v, v') = (0, v'(2/3)). The foreshortened gap's slope adds |sin theta| (v'^2 / 2) ~ 5e-4 > 0, so
    it rises again near the tip: an interior minimum at x ~ 0.87 m, ~4e-5 m below the tip."""
    s, c = abs(np.sin(theta)), np.cos(theta)
    vp = lambda x: (s - k * (1.0 - x) ** 2) / c  # noqa: E731
    t2, t3 = vp(2.0 / 3.0), vp(1.0)
    v3 = (s / 3.0 - k / 81.0) / c                      # int_{2/3}^1 v' dx
    B = t2 * 9.0 / 4.0
    A = -B * 2.0 / 3.0
    return np.array([theta, A / 9.0 + B / 27.0, 2.0 * A / 3.0 + B / 3.0, 0.0, t2, v3, t3])


@pytest.fixture(scope="module")
def arm():
    return _arm()


def test_a_foreshortened_dip_where_the_linear_gap_is_monotone(arm):
    """The linear gap along element 3 falls all the way to the tip; the foreshortened one (the material points')
    has an interior minimum ~4e-5 m below the tip. closest_points and cell 3's column must equal the minimum of
    the public material points' gaps over a 2000-point grid of that cell (dx = 1.7e-4 m), below it by at most
    the grid's own error 1/2 max|g''| dx^2 (max|g''| from the grid's second differences); on main both held
    the tip's gap, 4.3e-5 m too high (docs/benchmarks.md, drift25: the cell search missed the dip)."""
    q = _tilted_state()
    xs = np.linspace(2.0 / 3.0, 1.0, 2000)
    g_lin = material_points(_arm(False), q, 0, xs)[:, 1]
    assert np.all(np.diff(g_lin) < 0.0)                     # the premise: no linear minimum in the cell
    g = material_points(arm, q, 0, xs)[:, 1]
    dx = xs[1] - xs[0]
    g2_max = np.abs(np.diff(g, 2)).max() / dx**2              # max|g''| [1/m]
    grid_error = 0.5 * g2_max * dx**2
    j = np.argmin(g)
    assert 0 < j < xs.size - 1 and g[-1] - g[j] > 10 * 1e-6   # interior, deeper than contact_tol = 1e-6 m
    cp = closest_points(arm, q, FLOOR)
    cm = link_minima(arm, q, FLOOR, link_cells(arm, [0]))
    for gap, x in ((cp.gap[0, 0], cp.x[0, 0]), (cm.gap[0, 2], cm.x[0, 2])):
        assert gap <= g[j] + 1e-14
        assert g[j] - gap <= grid_error + 1e-14
        assert x == pytest.approx(xs[j], abs=dx)
    assert cm.stationary[0, 2] and cm.inside[0, 2]


@pytest.mark.slow   # 15 s for the 10^5-sample brute force of 2 x 6 pairs with 24 elements
@pytest.mark.parametrize("kind", ["off-grid elements", "modes"])
def test_stiffened_links_against_brute_force(kind, rng):
    """Stiffened links at random deflected states (delta ~ 0.08), walls near the chain and hugging a bulge:
    every (wall, link) pair's closest point equals the minimum of the public material points' gaps (10^5
    samples and a bounded minimisation) to 1e-10 m. With 11 and 13 elements the samples miss nodes, so a
    bracket that straddles a node is cut there by the sign of the foreshortened g'."""
    if kind == "modes":
        cc = "clamped-clamped"
        links = [gi.Link(1.0, 1.0, 20.0, modes=[gi.Mode(cc, "y"), gi.Mode(cc, "y", 2)]),
                 gi.Link(0.8, 1.0, 20.0, modes=[gi.Mode(cc, "y")])]
    else:
        links = [gi.Link(1.0, 1.0, 20.0, elements=11), gi.Link(0.8, 1.0, 20.0, elements=13)]
    model = gi.Model(gi.Chain(links))
    assert all(lk.stiffened for lk in model.chain.links)
    for trial in range(2):
        q, _ = _state(model, rng, delta=0.08)
        walls = _walls_near(model, q, rng) + _walls_hugging(model, q, trial, rng)
        _check_against_brute_force(model, q, walls, closest_points(model, q, walls), (kind, trial))
