"""model.shapes.foreshortening_matrix: H(x) against a closed form, and its cost per call (issue 25: the
event loop of a span contact phase asks for H(x*) at every right-hand side)."""

import numpy as np
import pytest

import gibbsimpact as gi
from gibbsimpact.model import shapes


def test_foreshortening_matrix_is_exact_and_costs_one_shape_evaluation(monkeypatch):
    # Two Hermite elements of a link of length l = 2 m: a state whose v = a x^2 (exact in the cubic
    # basis: node values a x_n^2, slopes 2 a x_n) has u_f(x) = -1/2 int_0^x (2 a xi)^2 dxi = -2/3 a^2 x^3.
    link = gi.Link(2.0, 1.0, 10.0, elements=2)
    dirs = shapes.shape_functions(link, [0.0])[0]
    assert len(dirs) == 4  # (v, v') at the middle and end nodes (clamped at x = 0)
    a = 0.3
    delta = np.array([a * 1.0, 2 * a * 1.0, a * 4.0, 2 * a * 2.0])
    x = np.array([0.25, 1.0, 1.7, 2.0])
    H = shapes.foreshortening_matrix(link, x)
    u = -0.5 * np.einsum("k,pkl,l->p", delta, H, delta)
    assert u == pytest.approx(-2.0 / 3.0 * a * a * x**3, rel=1e-13)
    # The table at the element nodes is the link's own (cached): a lookup evaluates the shape
    # functions once (the piece [b_j, x]), not once per element as well.
    calls = []
    real = shapes.shape_functions
    monkeypatch.setattr(shapes, "shape_functions", lambda *args: calls.append(1) or real(*args))
    again = shapes.foreshortening_matrix(link, x)
    assert len(calls) == 1
    assert np.array_equal(again, H)
