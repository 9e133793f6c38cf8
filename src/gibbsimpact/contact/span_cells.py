"""Several contact points along one link: the lowest point of every cell of the link (issue 25 item 1).

A flexible beam lying on a wall touches it at several places at once (both ends and every
interior minimum of its gap), so one candidate per (wall, link) -- the closest point
(contact/closest_points.py) -- lets only one interior point rest while the others sink and take
micro-impacts. Here link i's shape coordinate s is cut into m_i *cells* of equal length
(:func:`cell_count`), each a contact candidate of its own, identified by (wall, link, cell) so that
it persists from one call to the next:

    g_wic(q) = min over s in the closed cell [s_c, s_(c+1)] of g_w(p(q, i, s))             (1)

The minimum of a continuous function over a fixed closed interval is continuous in q, so (1)
can carry events ("hit", "sink", drift) like a joint's gap. It is reached either at an interior
local minimum of the link's gap (phi_x = 0, phi_xx >= 0: a *stationary* point that rolls and
slides along the link, contact/span_resting.py equation (2)) or at an end of the cell, a fixed
material point (its gap acceleration has no sliding term). A cell whose minimum is at an end of
the link's search interval has no candidate of its own (the end joint stands for it,
candidates.interior).

Number of cells. On a plane the gap along a Hermite element is a cubic in s, which has at most
one local minimum: m_i = n_e (one cell per element, the nodes as cell ends) finds every minimum.
For assumed modes the minima of a deflection whose shortest mode has wavenumber beta_max are at
least one wavelength 2 pi / beta_max apart, so m_i = floor(beta_max l / (2 pi)) + 1 cells hold at
most one each; rigid links (on obstacles) have one. The count follows from the link's own mode
content, not from the sample grid: refining the samples moves no cell.

Method: the samples and brackets of closest_points (g, g' on the sample grid; sign changes of g'
and the cubic's hidden dips; safeguarded Newton refinement), each interior minimum assigned to the
cell that holds its bracket; a cell's value is the lowest of its two end samples and its refined
minima (ties: the end). Cells meet at samples (s_c on the grid: round(c (S - 1) / m) samples).
Links with one cell take closest_points' own result (unchanged; its rigid-obstacle closed form).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .candidates import closest_points, interior, search_interval
from .closest_points import (_TIE, _foreshortened_minimum, _hidden_brackets, _normals, _refine, _sample_gaps,
                             _walls)
from .link_tables import _state, _tables


#: A cell's minimum closer than this to an end of the link (relative to its length) is not interior: the end
#: joint stands for it (the step of span_resting's differences; candidates.END_TOL = 1e-6 for one cell).
CELL_END_TOL = 1e-4


class CellMinima(NamedTuple):
    """The candidate of every (wall, column) pair, columns = (link, cell, cells) of :func:`link_cells`.

    x : (W, C) abscissa [m] of the lowest point of the cell; gap : (W, C) its gap [m];
    normal : (W, C, 3) the wall's unit normal there; stationary : (W, C) bool, an interior local
    minimum of the link's gap (True) or an end of the cell (False); inside : (W, C) bool, farther
    than CELL_END_TOL l from the ends of the link's search interval (else the end joint stands for it).
    """

    x: np.ndarray
    gap: np.ndarray
    normal: np.ndarray
    stationary: np.ndarray
    inside: np.ndarray


def cell_count(model, i: int) -> int:
    """m_i (module docstring): elements of a finite-element link, floor(beta_max l / (2 pi)) + 1 for modes, else 1."""
    lk = model.chain.links[i]
    if lk.elements:
        return int(lk.elements)
    if lk.modes:
        tab = _tables(model)
        return int(float(tab.beta[i].max()) * lk.length // (2.0 * np.pi)) + 1
    return 1


def link_cells(model, links) -> list:
    """The columns (i, c, m) of the links (0-based, in order): cell c = 0 .. m - 1 of link i's m cells."""
    return [(i, c, m) for i in links for m in (cell_count(model, i),) for c in range(m)]


def link_minima(model, q, walls, cells, refine_below: float = np.inf) -> CellMinima:
    """CellMinima of the columns ``cells`` ((i, c, m), link_cells) at q (N,) or (K, N) (leading axis K).

    Links with one cell: closest_points (stationary where interior); several: equation (1).
    refine_below [m]: as closest_points (a link whose lowest sample is farther keeps sample values).
    """
    qa = np.asarray(q, dtype=float)
    qs = qa.reshape(-1, qa.shape[-1])
    K, W, C = len(qs), len(walls), len(cells)
    x, gap = np.zeros((K, W, C)), np.zeros((K, W, C))
    nrm, stat, ins = np.zeros((K, W, C, 3)), np.zeros((K, W, C), dtype=bool), np.zeros((K, W, C), dtype=bool)
    single = [a for a, (_, _, m) in enumerate(cells) if m == 1]
    multi = [a for a, (_, _, m) in enumerate(cells) if m > 1]
    if single:
        links = [cells[a][0] for a in single]
        cp = closest_points(model, qs, walls, refine_below=refine_below)
        x[..., single], gap[..., single], nrm[..., single, :] = cp.x[..., links], cp.gap[..., links], \
            cp.normal[..., links, :]
        ins[..., single] = stat[..., single] = interior(model, qs, cp.x)[..., links]
    if multi:
        out = _cell_minima(model, qs, walls, [cells[a] for a in multi], refine_below)
        for arr, part in zip((x, gap, nrm, stat, ins), out):
            arr[:, :, multi] = part
    res = CellMinima(x, gap, nrm, stat, ins)
    return res if qa.ndim == 2 else CellMinima(*(a[0] for a in res))


def _cell_minima(model, qs, walls, cells, refine_below):
    """Equation (1) for the columns ``cells`` (C,) of links with several cells: x, gap (K, W, C) [m],
    normal (K, W, C, 3), stationary and inside (K, W, C) bool."""
    tab, wp = _tables(model), _walls(tuple(walls))
    K, W, S = len(qs), len(walls), tab.S
    st = _state(model, tab, qs)
    p0, g, g1 = _sample_gaps(tab, wp, st, K, W)
    links = np.array([i for i, _, _ in cells])
    j0 = np.array([round(c * (S - 1) / m) for _, c, m in cells])
    j1 = np.array([round((c + 1) * (S - 1) / m) for _, c, m in cells])
    # The cell's ends: the lower of its two end samples (ties: the proximal end).
    ga, gb = g[:, :, links, j0], g[:, :, links, j1]
    best_j = np.where(gb < ga, j1, j0)
    best_g = np.minimum(ga, gb)
    best_s = tab.s_grid[links, best_j]
    kk = np.arange(K)[:, None, None]
    best_p = p0[kk, links, best_j]
    stationary = np.zeros((K, W, len(cells)), dtype=bool)
    scale = 1.0 + np.abs(p0).max()
    _cell_interior_minima(tab, wp, st, g, g1, refine_below, (links, j0, j1), best_s, best_g, best_p, stationary,
                          scale)
    x, xa, xb = (_abscissa(tab, st, links, np.broadcast_to(s, best_s.shape))
                 for s in (best_s, tab.s_grid[links, j0], tab.s_grid[links, j1]))
    _foreshorten_cells(model, wp, st, qs, links, (x, xa, xb), best_g, best_p, stationary, _TIE * scale)
    a, b = search_interval(model, qs)
    tol = CELL_END_TOL * tab.length[links]
    inside = (x - a[:, None, links] > tol) & (b[:, None, links] - x > tol)
    normal = np.stack([_normals(wp, k, best_p[:, k]) for k in range(W)], axis=1)
    return x, best_g, normal, stationary, inside


def _cell_interior_minima(tab, wp, st, g, g1, refine_below, cols, best_s, best_g, best_p, stationary, scale):
    """The refined interior minima of the links' gaps (closest_points' brackets) replace a cell's end value
    where lower beyond round-off (in place: best_s, best_g, stationary (K, W, C), best_p (K, W, C, 3))."""
    links, j0, j1 = cols
    fl = tab.flex_links
    g1f, gf = g1[:, :, fl], g[:, :, fl]
    ks, ws, ls, js = np.nonzero((g1f[..., :-1] < 0.0) & (g1f[..., 1:] >= 0.0))
    lo = hi = np.full(ks.size, np.nan)
    hidden = _hidden_brackets(tab, wp, st, gf, g1f)
    if hidden is not None:
        lo, hi = np.concatenate((lo, hidden[4])), np.concatenate((hi, hidden[5]))
        ks, ws, ls, js = (np.concatenate((u, v)) for u, v in zip((ks, ws, ls, js), hidden[:4]))
    # The column holding each bracket (-1: a link without cells here).
    col_of = np.full((tab.n, tab.S), -1)
    for c, (i, a, b) in enumerate(zip(links, j0, j1)):
        col_of[i, a:b] = c
    link = fl[ls]
    col = col_of[link, js]
    keep = (col >= 0) & (gf.min(axis=-1)[ks, ws, ls] <= refine_below)
    if not keep.any():
        return
    ks, ws, link, js, col, lo, hi = (v[keep] for v in (ks, ws, link, js, col, lo, hi))
    s, gs, ps = _refine(tab, wp, st, ks, ws, link, js, g[ks, ws, link, js], g[ks, ws, link, js + 1],
                        g1[ks, ws, link, js], g1[ks, ws, link, js + 1], (lo, hi))
    # Lowest last (fancy assignment keeps the last of repeated indices); it beats the ends beyond round-off.
    order = np.argsort(-gs)
    ks, ws, col, s, gs, ps = ks[order], ws[order], col[order], s[order], gs[order], ps[order]
    better = gs < best_g[ks, ws, col] - _TIE * scale
    ks, ws, col = ks[better], ws[better], col[better]
    best_s[ks, ws, col], best_g[ks, ws, col], best_p[ks, ws, col] = s[better], gs[better], ps[better]
    stationary[ks, ws, col] = True


def _abscissa(tab, st, links, s):
    """x (K, W, C) [m] of the shape coordinates s (K, W, C) of the links (C,) (on a Pb link: its protruding part)."""
    if not tab.has_pb:
        return np.array(s, dtype=float)
    return np.where(s == tab.Lc[links], tab.length[links], st.offset[:, None, links] + st.scale[:, None, links] * s)


def _foreshorten_cells(model, wp, st, qs, links, xs, best_g, best_p, stationary, tie):
    """Cells of stiffened links on their foreshortened centreline (closest_points._foreshorten), in place:
    every cell's point, gap and slopes g', g'' at its abscissa x [m] (a stationary minimum is where the
    search's Newton iteration converged, on this same centreline: it is kept), and a cell's end is replaced
    when the foreshortened gap falls from that end into the cell: then Newton's iteration from the end, kept
    inside the cell [x_a, x_b], gives the interior minimum (stationary) when it lies strictly inside and lower
    by tie [m].

    xs = (x, x_a, x_b) (K, W, C) [m]: the cells' points and ends. Why: a dip growing out of a resting end
    (issue 25 item 5) must be seen from g = 0, while the samples' brackets see it only once a sample next to
    the end has turned its slope (tests/contact/test_span_cells.py). The samples, brackets and Newton
    refinement run on the foreshortened centreline since fore25 (closest_points), so a stationary minimum
    needs no second Newton pass here: that pass only confirmed it (to X_TOL l, moving x by an ulp) at the
    cost of a second evaluation of the curve (docs/benchmarks.md, the search's cost per call)."""
    x, xa, xb = xs
    for i in np.unique(links):
        if not model.chain.links[i].stiffened:
            continue
        cols = np.flatnonzero(links == i)
        rows = type(wp)(*(np.repeat(arr, cols.size, axis=0) for arr in wp))    # (W C_i): wall-major
        for k, q in enumerate(qs):
            R, o, x0 = st.R[k, i], st.o[k, i], x[k][:, cols].ravel()
            stat = stationary[k][:, cols].ravel()
            xn, pn, gn, g1, g2, curve = _foreshortened_minimum(model, rows, q, i, x0, R, o, False, slopes=True)
            lo, hi = xa[k][:, cols].ravel(), xb[k][:, cols].ravel()
            # The gap falls from the end into the cell (g' > 0 at the distal end, < 0 at the proximal one) and
            # g'' > 0 there: Newton's iteration steps into the cell.
            into = ~stat & (g2 > 0.0) & (((x0 >= hi) & (g1 > 0.0)) | ((x0 <= lo) & (g1 < 0.0)))
            if into.any():  # Newton from those ends, kept inside their cells
                xd, pd, gd = _foreshortened_minimum(model, rows, q, i, x0, R, o, into, (lo, hi), curve=curve)
                dip = into & (xd > lo) & (xd < hi) & (gd < gn - tie)
                xn, pn, gn = np.where(dip, xd, xn), np.where(dip[:, None], pd, pn), np.where(dip, gd, gn)
                stat = stat | dip
            x[k][:, cols], best_p[k][:, cols], best_g[k][:, cols] = xn.reshape(-1, cols.size), \
                pn.reshape(-1, cols.size, 3), gn.reshape(-1, cols.size)
            stationary[k][:, cols] = stat.reshape(-1, cols.size)

