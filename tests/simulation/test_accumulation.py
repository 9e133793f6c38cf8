"""The accumulation monitor (simulation/accumulation.py): when resting contact resolves an accumulation
of impacts and when the run stops with status "zeno" instead (docs/theory.md §14.5)."""

import time

import numpy as np
import pytest

import gibbsimpact as gi
from gibbsimpact.dynamics.link_points import link_points

from issue25_reproducers import ITEM6, build


def test_flexible_link_lying_on_a_wall_stops_with_zeno_instead_of_crawling():
    # Issue 25 item 6: a rod with one clamped-clamped mode dropped flat 5 mm onto a floor (e = 0)
    # lands at t = sqrt(2 h / g); then O1, O2 and its span take impacts 5.7e-8 s apart. O1, O2 come
    # to rest, but the span cannot (resting contact along a span is not modelled), so its impacts
    # went on: 858 impacts in 30 s of CPU for 3.4e-6 s. Now the second accumulation that the span
    # takes part in ends the run with status "zeno" and a message naming it, a few impacts after
    # the landing.
    model, walls, kw = build(ITEM6)
    started = time.process_time()
    with pytest.warns(gi.ValidityWarning, match="Newton's law applied at link 1"):
        res = gi.simulate(model, walls=walls, max_cpu_time=60.0, **kw)
    cpu = time.process_time() - started
    assert res.status == "zeno", res.message
    assert "the span of link 1 kept taking impulses from wall 1" in res.message
    assert "not for a link's span" in res.message
    t_land = np.sqrt(2 * 0.005 / 9.81)
    assert abs(res.impacts[0].time - t_land) <= 1e-9
    # Two accumulations of zeno_count = 10 impacts each, plus the landing.
    assert len(res.impacts) <= 3 * 10 + 1
    assert abs(res.t[-1] - t_land) <= 1e-5
    assert cpu <= 30.0, cpu
    # No material point (64 per link, from the public kinematics) below the floor by more than contact_tol.
    lowest = min(float(link_points(model, q, 64)[..., 1].min()) for q in res.q)
    assert lowest >= -1e-9, lowest
