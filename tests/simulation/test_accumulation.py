"""The accumulation monitor (simulation/accumulation.py): when resting contact resolves an accumulation
of impacts and when the run stops with status "zeno" instead (docs/theory.md §14.5)."""

import time

import numpy as np
import pytest

import gibbsimpact as gi
from gibbsimpact.dynamics.link_points import link_points

from issue25_reproducers import ITEM6, build


def test_flexible_link_lying_on_a_wall_comes_to_rest_instead_of_crawling():
    # Issue 25 item 6: a rod with one clamped-clamped mode dropped flat 5 mm onto a floor (e = 0)
    # lands at t = sqrt(2 h / g); then O1, O2 and its span took impacts 5.7e-8 s apart: 858 impacts in
    # 30 s of CPU for 3.4e-6 s. Resting contact along a link's span (item 1, span_resting.py) is the
    # real fix the issue names: the landing's accumulation now ends with O1, O2 and the span point
    # resting, and the run finishes at t_end with the floor carrying the rod's weight.
    model, walls, kw = build(ITEM6)
    started = time.process_time()
    with pytest.warns(gi.ValidityWarning, match="Newton's law applied at link 1") as caught:
        res = gi.simulate(model, walls=walls, max_cpu_time=60.0, **kw)
    # At a span the warning names the stepped contact phases too (docs/theory.md §15.5).
    assert any("accumulation='rest' or 'step', docs/theory.md §15.5" in str(w.message) for w in caught)
    cpu = time.process_time() - started
    assert res.status == "finished", res.message
    assert res.t[-1] == kw["t_span"][1]
    t_land = np.sqrt(2 * 0.005 / 9.81)
    assert abs(res.impacts[0].time - t_land) <= 1e-9
    assert len(res.impacts) <= 10 + 1  # at most one accumulation after the landing
    assert cpu <= 30.0, cpu
    # Static balance at the end: the contact forces carry the weight m g (1e-6 relative).
    assert res.contact_forces[-1].sum() == pytest.approx(model.total_mass * 9.81, rel=1e-6)
    # No material point (64 per link, from the public kinematics) below the floor by more than contact_tol.
    lowest = min(float(link_points(model, q, 64)[..., 1].min()) for q in res.q)
    assert lowest >= -1e-9, lowest
