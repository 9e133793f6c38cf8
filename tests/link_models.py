"""Chains and walls shared by the tests of contact candidates (tests/contact/test_candidates.py) and of
contact along links in the event loop (tests/simulation/test_link_contacts.py)."""

from __future__ import annotations

import numpy as np
from scipy.optimize import minimize_scalar

import gibbsimpact as gi
from gibbsimpact.contact import candidates as lp

from conftest import random_state

CC = "clamped-clamped"


def _case1():
    link = gi.Link(1.0, 1.0, 20.0, modes=[gi.Mode(CC, "y")], geometric_stiffening=False)
    return gi.Model(gi.Chain([link, link]))


def _rigid():
    link = gi.Link(0.8, 1.0, 20.0, rotary_inertia=(1e-4, 1e-4, 1e-4))
    return gi.Model(gi.Chain([link, link, link]))


def _spatial_modal():
    a = gi.Link(1.0, 1.0, (20.0, 15.0), modes=[gi.Mode(CC, "y"), gi.Mode(CC, "z"), gi.Mode(CC, "y", 2)], geometric_stiffening=False)
    b = gi.Link(0.7, 1.2, 10.0, modes=[gi.Mode("clamped-free", "z"), gi.Mode("pinned-pinned", "y"),
                                       gi.Mode("clamped-free", "y", 2)], geometric_stiffening=False)
    return gi.Model(gi.Chain([a, b]))


def _fe():
    return gi.Model(gi.Chain([gi.Link(1.0, 1.0, 20.0, elements=4, geometric_stiffening=False), gi.Link(0.9, 1.0, 20.0, elements=3, geometric_stiffening=False)]))


def _spatial_fe():
    link = gi.Link(1.0, 1.0, 20.0, elements=4, element_directions=("y", "z"), geometric_stiffening=False)
    return gi.Model(gi.Chain([link, gi.Link(0.6, 1.0, 20.0, rotary_inertia=(1e-4, 1e-4, 1e-4))]))


def _fe_off_grid():
    """11 and 13 elements: the sample grid (105 points) misses nodes, brackets straddle them."""
    return gi.Model(gi.Chain([gi.Link(1.0, 1.0, 20.0, elements=11, geometric_stiffening=False), gi.Link(0.8, 1.0, 20.0, elements=13, geometric_stiffening=False)]))


def _prismatic(kinds):
    """A fixed-base planar arm: a 3-element host and a 2-element second link behind R, Pa or Pb."""
    host = gi.Link(1.0, 1.0, 10.0, elements=3, geometric_stiffening=False)
    arm = gi.Link(0.6, 0.5, 2.0, elements=2, geometric_stiffening=False)
    joints = {"R-Pb": [gi.Revolute(), gi.FixedPrismatic(angle=0.3, range=(0.15, 0.6))],
              "R-Pa": [gi.Revolute(), gi.SlidingPrismatic(angle=0.6, half_length=0.04, range=(0.05, 0.95))],
              "Pb-R": [gi.FixedPrismatic(angle=0.5, range=(0.6, 1.0)), gi.Revolute()]}[kinds]
    return gi.Model(gi.Chain([host, arm], joints=joints, base=gi.FixedBase((0.1, 0.2), 0.3)))


def _prismatic_state(model, rng, delta=0.02):
    q = np.zeros(model.n_dof)
    qd = rng.normal(scale=0.5, size=model.n_dof)
    for i, kind in enumerate(model.joint_kinds):
        jt = model.chain.joints[i]
        q[model.theta_index[i]] = rng.uniform(-0.8, 0.8) if kind == "R" else rng.uniform(*jt.range)
    for idx in model.delta_index:
        q[idx] = rng.normal(scale=delta, size=idx.size)
    return q, qd


MODELS = {
    "rigid": _rigid, "case1": _case1, "spatial-modal": _spatial_modal, "fe": _fe, "spatial-fe": _spatial_fe,
    "fe-off-grid": _fe_off_grid,
    "R-Pb": lambda: _prismatic("R-Pb"), "R-Pa": lambda: _prismatic("R-Pa"), "Pb-R": lambda: _prismatic("Pb-R"),
}


def _state(model, rng, delta=0.05):
    if not model.free_base:
        return _prismatic_state(model, rng, delta)
    return random_state(model, rng, delta=delta)


def _walls_near(model, q, rng):
    """A plane, a circle and a sphere that pass close to the chain (so that bulges matter)."""
    a, b = lp.search_interval(model, q)
    pts = np.concatenate([lp.material_points(model, q, i, np.linspace(a[i], b[i], 50)) for i in range(model.n_links)])
    nv = rng.normal(size=3)
    if model.planar:
        nv[2] = 0.0
    nv /= np.linalg.norm(nv)
    low = pts[np.argmin(pts @ nv)]
    plane = gi.Plane(low - 0.01 * nv, nv)
    c = pts.mean(axis=0) + rng.normal(scale=0.05, size=3)
    circle = gi.Circle(np.max(np.hypot(*(pts[:, :2] - c[:2]).T)) + 0.01, c[:2])
    sphere = gi.Sphere(np.max(np.linalg.norm(pts - c, axis=1)) + 0.01, c)
    return [plane, circle, sphere]


def _walls_hugging(model, q, i, rng):
    """A plane, a circle and a sphere on the side towards which link i bulges (its mid-point off
    the chord): the minimum of their gaps along link i is then inside the link."""
    a, b = lp.search_interval(model, q)
    pa, pm, pb = lp.material_points(model, q, i, [a[i], 0.5 * (a[i] + b[i]), b[i]])
    chord = (pb - pa) / np.linalg.norm(pb - pa)
    u = pm - 0.5 * (pa + pb)
    u -= (u @ chord) * chord
    if model.planar:
        u[2] = 0.0
    bulge = np.linalg.norm(u)
    u /= bulge
    tilt = rng.normal(scale=0.1 * bulge, size=3) * (0 if model.planar else 1)
    plane = gi.Plane(pm + 0.01 * u, -u + tilt)
    D = (np.linalg.norm(pb - pa) ** 2 / (4 * bulge)) * rng.uniform(1.0, 2.0)
    c = pm - D * u
    uc = u[:2] / np.linalg.norm(u[:2])
    cc = pm[:2] - D * uc
    allp = np.concatenate([lp.material_points(model, q, k, np.linspace(0, model.chain.links[k].length, 50))
                           for k in range(model.n_links)])
    circle = gi.Circle(np.max(np.hypot(*(allp[:, :2] - cc).T)) + 0.01, cc)
    sphere = gi.Sphere(np.max(np.linalg.norm(allp - c, axis=1)) + 0.01, c)
    return [plane, circle, sphere]


def _obstacles_near(model, q, i, rng, clearance=0.005):
    """An obstacle circle and sphere of radius 0.05-0.2 m beside link i, ``clearance`` [m] off the point at a random
    abscissa, on the side of a random direction normal to the chord (towards a bulge or away from it)."""
    a, b = lp.search_interval(model, q)
    x = rng.uniform(0.2, 0.8)
    pa, pm, pb = lp.material_points(model, q, i, [a[i], a[i] + x * (b[i] - a[i]), b[i]])
    chord = (pb - pa) / np.linalg.norm(pb - pa)
    u = rng.normal(size=3)
    if model.planar:
        u[2] = 0.0
    u -= (u @ chord) * chord
    u /= np.linalg.norm(u)
    R = rng.uniform(0.05, 0.2)
    c = pm + (R + clearance) * u
    return [gi.Circle(R, c[:2], inside=False), gi.Sphere(R, c, inside=False)]


def _samples(model, q, i, K=100_000):
    """10^5 abscissae of link i's search interval and their material points (K, 3)."""
    a, b = lp.search_interval(model, q)
    x = np.linspace(a[i], b[i], K)
    return x, lp.material_points(model, q, i, x)


def _brute_force(model, q, wall, i, samples):
    """(x*, gap) by the samples of the gap along link i and a bounded minimisation around the best."""
    x, p = samples
    g = wall.gap(p)
    k = int(np.argmin(g))
    lo, hi = x[max(k - 1, 0)], x[min(k + 1, x.size - 1)]
    res = minimize_scalar(lambda t: float(wall.gap(lp.material_points(model, q, i, [t]))[0]), bounds=(lo, hi),
                          method="bounded", options={"xatol": 1e-14 * (x[-1] - x[0]), "maxiter": 500})
    return (res.x, res.fun) if res.fun < g[k] else (x[k], g[k])


def _check_against_brute_force(model, q, walls, res, label):
    """Every (wall, link) pair of closest_points' res against _brute_force (<= 1e-10 m); its gap and normal
    are those of the material point at x*."""
    samples = [_samples(model, q, i) for i in range(model.n_links)]
    for w, wall in enumerate(walls):
        for i in range(model.n_links):
            x_bf, g_bf = _brute_force(model, q, wall, i, samples[i])
            assert abs(res.gap[w, i] - g_bf) <= 1e-10, (label, w, i, res.x[w, i], x_bf, res.gap[w, i], g_bf)
            p = lp.material_points(model, q, i, [res.x[w, i]])
            assert abs(wall.gap(p)[0] - res.gap[w, i]) <= 1e-13
            assert np.max(np.abs(wall.normal(p)[0] - res.normal[w, i])) <= 1e-12
