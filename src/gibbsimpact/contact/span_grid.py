"""Fixed material points along flexible links: the span's contact points of a time-stepping contact phase
(docs/theory.md §15.5; simulation/stepping.py).

Each cell c of the m cells of a flexible link i (contact/span_cells.py: one per finite element, or per
modal wavelength) is cut into n = POINTS_PER_CELL equal parts; the grid is the material points

    x_ij = l_i j / (m n),   j = 1 .. m n - 1                                                   (1)

(the link's own ends are its joints' points). A Hermite element resting on two or more of its points
that are on a plane is flat between them (its gap, a cubic in x, has four roots); between two points
d = l_i / (m n) apart a load q [N/m] sags the span by about q d^4 / (384 EI), so the material points
below the grid sink less than that: 6e-8 m for a 1 kg/m beam with EI = 20 N m^2 on 4 elements, a
factor 16 less at each doubling of the elements or cells. The cells' lowest points (contact/span_cells.py)
stay contact points of the phase as well: wherever a link bulges below its grid by more than a
step's motion, its lowest point is held.

Prismatic hosts (Pb links, whose material points slide through the guide) have no grid: their
cells' lowest points stand for them.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..dynamics.link_points import material_point_jacobians

#: Parts of each cell between grid points (equation (1)): the nodes of a cell and 3 points inside.
POINTS_PER_CELL = 4


class SpanGrid(NamedTuple):
    """The grid of equation (1): link (G,) int (0-based), x (G,) [m] abscissae, column (G,) int, the gap
    matrix's column of the cell each point lies in (the point at a node: the cell after it)."""

    link: np.ndarray
    x: np.ndarray
    column: np.ndarray


def span_grid(model, cells, n_joints: int, pb=None, per_cell: int = POINTS_PER_CELL) -> SpanGrid:
    """The grid of equation (1) of the flexible links among ``cells`` ((i, c, m) per link column,
    contact.span_cells.link_cells; the columns after the n_joints joint points), less the links marked
    in pb (n,) bool (Pb links; None: none)."""
    link, x, column = [], [], []
    for f, (i, c, m) in enumerate(cells):
        lk = model.chain.links[i]
        if not (lk.elements or lk.modes) or (pb is not None and pb[i]):
            continue
        j = np.arange(c * per_cell, (c + 1) * per_cell)
        j = j[(j > 0)]
        link += [i] * j.size
        x += list(lk.length * j / (m * per_cell))
        column += [n_joints + f] * j.size
    return SpanGrid(np.array(link, dtype=int), np.array(x, dtype=float), np.array(column, dtype=int))


def grid_terms(model, walls, q, grid: SpanGrid, near=None):
    """Gaps g (W, G') [m], unit normals n (W, G', 3) and point Jacobians J (G', 3, N) at q (N,) of the grid points
    (G' = G), or of those where near (G,) bool holds (one vectorised call per link,
    dynamics.link_points.material_point_jacobians)."""
    sel = np.ones(grid.x.size, dtype=bool) if near is None else np.asarray(near, dtype=bool)
    link, x = grid.link[sel], grid.x[sel]
    G, N = x.size, model.n_dof
    p, J = np.zeros((G, 3)), np.zeros((G, 3, N))
    for i in np.unique(link):
        at = link == i
        p[at], J[at] = material_point_jacobians(model, q, int(i), x[at])
    g = np.array([w.gap(p) for w in walls]).reshape(len(walls), G)
    n = np.array([w.normal(p) for w in walls]).reshape(len(walls), G, 3)
    return g, n, J
