"""Per-model tables for the vectorised evaluation of link points (contact/closest_points.py).

Built once per model (:func:`_tables`, cached while the model lives): the stencils of v, w
and their s-derivatives, the sample grid with its local points r = r0 + A qe, and the
coefficient templates of the assumed-mode and Hermite-element bases that the refinement
uses (the method and the sampling rule: contact/closest_points.py). :func:`_state` gives the
frames of K states from one kernel call, and the effective coordinates qe.
"""

from __future__ import annotations

import weakref
from typing import NamedTuple

import numpy as np

from .. import kernel as _k
from ..dynamics.kinematics import as_vector
from ..model.elements import hermite_local
from ..model.modes import _normalisation, _sigma_terms, frequency_root
from ..model.shapes import foreshortening_matrix

_MIN_SAMPLES = 17


class _Tables:
    """Per-model shape data for the vectorised evaluation of link deflections.

    Every deflection value is a stencil: v (resp. w) at shape coordinate s of link i is
    sum_k wt_k(s) qe[ix_k], qe = (q with the slope coordinates of Pb links times d, 0),
    the last entry a zero slot for padding. Modal links: wt = psi_k (all modes, the other
    direction's weights 0); Hermite links: the 4 local functions of the element holding s.
    """

    def __init__(self, model):
        self._link_kinds(model)
        self._mode_coefficients(model)
        self._element_nodes(model)
        self.S = _sample_count(model.chain.links)
        self._sample_grid()
        self.r0, self.A = self._local_samples()
        # Stiffened links (never Pb: s = x): (i, the link, its delta indices (m,), H at the samples (S, m, m) [1/m]).
        self.stiffened = [(i, lk, np.asarray(model.delta_index[i]), foreshortening_matrix(lk, self.s_grid[i]))
                          for i, lk in enumerate(model.chain.links) if lk.stiffened]
        self.flex_links = np.flatnonzero(self.flexible)
        self.has_pb = bool(self.pb.any())
        self.offset1, self.scale1 = np.zeros((1, self.n)), np.ones((1, self.n))   # x = offset + scale s, no Pb link
        self.modal_template, self.modal_x = self._modal_template()
        self.hermite_template = self._hermite_template()
        S = self.S
        self.samples_per_element = np.where(self.fe & ((S - 1) % self.ne == 0), (S - 1) // self.ne, 0)
        self.qdot1 = np.zeros(self.N)
        job = _k.JOB_FRAMES
        self.frames_offset = int(_k.layout(self.n, self.N, 1, job, model.n_joints)[_k.SECTIONS.index("frames")])

    def _link_kinds(self, model):
        """Per link (n,): length, Pb flag and q index of d, modal / finite-element / flexible flags, the
        shape coordinate's range Lc; and width, the number of stencil slots per direction."""
        n, N = model.n_links, model.n_dof
        links, kinds = model.chain.links, model.joint_specs
        self.n, self.N = n, N
        self.length = np.array([lk.length for lk in links])
        self.pb = np.array([k.guide for k in kinds], dtype=bool)
        self.d_index = np.array([model.theta_index[i] if self.pb[i] else 0 for i in range(n)], dtype=int)
        self.modal = np.array([bool(lk.modes) for lk in links])
        self.fe = np.array([lk.elements > 0 for lk in links])
        self.flexible = self.modal | self.fe
        # Shape coordinate: s = x on [0, l]; s = xi on [0, 1] for a Pb link.
        self.Lc = np.where(self.pb, 1.0, self.length)
        self.width = max([4] + [len(lk.modes) for lk in links])

    def _mode_coefficients(self, model):
        """Assumed-mode links: beta, ca, cb, cc, cs (n, width), direction mask and q index (n, 2, width)."""
        n, N, width = self.n, self.N, self.width
        # Modal coefficients: psi^(k)(s) = beta^k [ca e^(beta s) + (-1)^k cb e^(-beta s) + cc cos^(k) + cs sin^(k)].
        shp = (n, width)
        self.beta, self.ca, self.cb, self.cc, self.cs = (np.zeros(shp) for _ in range(5))
        self.dmask = np.zeros((n, 2, width))   # direction of each mode: slot 0 = v (y), 1 = w (z)
        self.midx = np.full((n, 2, width), N)  # q index of each mode
        for i, lk in enumerate(model.chain.links):
            idx = model.delta_index[i]
            for k, md in enumerate(lk.modes):
                z = frequency_root(md.kind, int(md.number))
                beta = z / lk.length
                C = _normalisation(md.kind, int(md.number), float(lk.length))
                if md.kind == "pinned-pinned":
                    a, b, c, s = 0.0, 0.0, 0.0, C
                else:
                    sigma, one_minus, one_plus = _sigma_terms(md.kind, z)
                    a, b, c, s = 0.5 * C * one_minus, 0.5 * C * one_plus, -C, C * sigma
                self.beta[i, k], self.ca[i, k], self.cb[i, k], self.cc[i, k], self.cs[i, k] = beta, a, b, c, s
                slot = 0 if md.direction == "y" else 1
                self.dmask[i, slot, k] = 1.0
                self.midx[i, :, k] = idx[k]

    def _element_nodes(self, model):
        """Hermite links: n_e and h (n,) on the shape coordinate, q index (n, n_e + 1, 2 directions,
        2) of (deflection, slope) at node j; pb_slopes: (q indices of the slopes, q index of d) per Pb link."""
        self.ne = np.array([max(lk.elements, 1) for lk in model.chain.links])
        self.h = self.Lc / self.ne
        self.node_q = np.full((self.n, int(self.ne.max()) + 1, 2, 2), self.N)
        self.pb_slopes = []
        for i, lk in enumerate(model.chain.links):
            if lk.modes or not lk.elements:
                continue
            idx = model.delta_index[i]
            ne = lk.elements
            for set_k, direction in enumerate(lk.element_directions):
                slot = 0 if direction == "y" else 1
                base = idx[2 * ne * set_k:2 * ne * (set_k + 1)]
                self.node_q[i, 1:ne + 1, slot, 0] = base[0::2]
                self.node_q[i, 1:ne + 1, slot, 1] = base[1::2]
            if self.pb[i]:
                self.pb_slopes.append((idx[1::2], model.theta_index[i]))

    def _sample_grid(self):
        """s_grid (n, S): S samples evenly spaced on [0, Lc], the far end exactly Lc."""
        u = np.linspace(0.0, 1.0, self.S)
        self.s_grid = self.Lc[:, None] * u[None, :]
        self.s_grid[:, -1] = self.Lc  # the far end exactly

    def _local_samples(self):
        """r0 (2, n, S, 3) and A (2 n S 3, N + 1): local samples r(s) and dr/ds = r0 + A qe."""
        n, N, S, width = self.n, self.N, self.S, self.width
        # Local samples r(s) and dr/ds of every link, linear in qe: r = r0 + A qe, rows (order, link, sample,
        # component) [docs/theory.md §7.2: x = s, or x = l + (s - 1) d on a Pb link; v, w from the stencils].
        L = np.repeat(np.arange(n), S)
        wt, ix = _stencils(self, L, self.s_grid.ravel(), 2)
        r0 = np.zeros((2, n, S, 3))
        A = np.zeros((2, n, S, 3, N + 1))
        for i in range(n):
            if self.pb[i]:
                r0[0, i, :, 0] = self.length[i]
                A[0, i, :, 0, self.d_index[i]] = self.s_grid[i] - 1.0
                A[1, i, :, 0, self.d_index[i]] = 1.0
            else:
                r0[0, i, :, 0] = self.s_grid[i]
                r0[1, i, :, 0] = 1.0
        wt = wt.reshape(2, n, S, 2, width)
        ix = ix.reshape(n, S, 2, width)
        for o in range(2):
            for c in range(2):
                np.add.at(A[o, :, :, 1 + c], (np.arange(n)[:, None, None], np.arange(S)[None, :, None], ix[:, :, c]),
                          wt[o, :, :, c])
        A = A.reshape(-1, N + 1)
        if A.size > 200_000:  # long Hermite links: a sparse matrix (each row has at most 4 entries)
            from scipy.sparse import csr_matrix

            A = csr_matrix(A)
        return r0, A

    def _modal_template(self):
        """Template (n, 3 orders, 2 (v, w), nb, width) of the assumed-mode basis, and modal_x (3, nb), its x row."""
        n, width = self.n, self.width
        # Assumed-mode basis for the refinement (_ModalBasis): F = (1, s, E_j, 1/E_j, cos_j, sin_j),
        # E_j = e^(beta_j s); template (n, 3 orders, 2 (v, w), nb, width) times the modal coordinates.
        nb = 2 + 4 * width
        tm = np.zeros((n, 3, 2, nb, width))
        j = np.arange(width)
        for i in range(n):
            bt, ca, cb, cc, cs = self.beta[i], self.ca[i], self.cb[i], self.cc[i], self.cs[i]
            for slot in range(2):
                dm = self.dmask[i, slot]
                # psi = ca E + cb /E + cc cos + cs sin; psi' = beta (ca E - cb /E - cc sin + cs cos);
                # psi'' = beta^2 (ca E + cb /E - cc cos - cs sin)
                for k, (fa, fb, fc, fs) in enumerate(((ca, cb, cc, cs), (bt * ca, -bt * cb, bt * cs, -bt * cc),
                                                      (bt**2 * ca, bt**2 * cb, -bt**2 * cc, -bt**2 * cs))):
                    tm[i, k, slot, 2 + j, j] = fa * dm
                    tm[i, k, slot, 2 + width + j, j] = fb * dm
                    tm[i, k, slot, 2 + 2 * width + j, j] = fc * dm
                    tm[i, k, slot, 2 + 3 * width + j, j] = fs * dm
        modal_x = np.zeros((3, nb))
        modal_x[0, 1] = 1.0   # x = s
        modal_x[1, 0] = 1.0   # dx/ds = 1
        return tm, modal_x

    def _hermite_template(self):
        """Template (n, 3 orders, 4 powers, 4 dofs) of the Hermite-element basis."""
        # Hermite elements (_HermiteBasis): v, v', v'' on an element as powers of eta from its dofs
        # (w_(e-1), t_(e-1), w_e, t_e): (H1, h H2, H3, h H4) = (1, eta, eta^2, eta^3) @ H0 (elements.py);
        # d/ds = (1/h) d/deta. Template (n, 3 orders, 4 powers, 4 dofs).
        H = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [-3.0, -2.0, 3.0, -1.0], [2.0, 1.0, -2.0, 1.0]])
        D = np.diag([1.0, 2.0, 3.0], 1)   # d/deta on power coefficients: c -> (c1, 2 c2, 3 c3, 0)
        template = np.zeros((self.n, 3, 4, 4))
        for i in range(self.n):
            if self.fe[i]:
                hi_ = self.h[i]
                H0 = H * np.array([1.0, hi_, 1.0, hi_])
                template[i] = (H0, D @ H0 / hi_, D @ D @ H0 / hi_**2)
        return template

    def grid_index(self, K, W):
        """Index arrays (K, 1, 1), (1, 1, n) that pick (state, link) for every (state, wall, link)."""
        key = (K, W)
        try:
            return self._grid_index[key]
        except AttributeError:
            self._grid_index = {}
        except KeyError:
            pass
        if len(self._grid_index) > 16:
            self._grid_index.clear()
        out = self._grid_index[key] = (np.arange(K)[:, None, None], np.arange(self.n)[None, None, :])
        return out


_TABLES: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _tables(model) -> _Tables:
    # The tables do not depend on the free base's chart (Model.with_base_chart): one per chart root.
    root = model.chart_root
    try:
        return _TABLES[root]
    except KeyError:
        t = _TABLES[root] = _Tables(root)
        return t


def _sample_count(links) -> int:
    """S, the samples per link (module docstring of contact/closest_points.py, sampling rule):
    S = max_i S_i, S_i = max(17, ceil(8 beta_max l / pi) + 1) for assumed modes (beta_max l the largest
    frequency root), max(17, 8 n_e + 1) for n_e Hermite elements; S - 1 then rounded up to a multiple of
    every n_e when that at most doubles it (the element nodes are samples)."""
    S = 2
    for lk in links:
        if lk.modes:
            bl = max(frequency_root(md.kind, int(md.number)) for md in lk.modes)
            S = max(S, _MIN_SAMPLES, int(np.ceil(8.0 * bl / np.pi)) + 1)
        elif lk.elements:
            S = max(S, _MIN_SAMPLES, 8 * lk.elements + 1)
    # Element nodes on the grid when that at most doubles S: S - 1 a multiple of every n_e.
    lcm = int(np.lcm.reduce([lk.elements for lk in links if lk.elements] or [1]))
    if lcm <= S - 1:
        S = -(-(S - 1) // lcm) * lcm + 1
    return S


def _stencils(tab: _Tables, L, s, orders):
    """Weights (orders, P, 2, width) and qe indices (P, 2, width) of v, w and their s-derivatives.

    L (P,) link of each point, s (P,) its shape coordinate; orders 1 .. 3 (value, first, second).
    """
    P, width = s.size, tab.width
    wt = np.zeros((orders, P, 2, width))
    ix = np.full((P, 2, width), tab.N)
    m = tab.modal[L]
    if m.any():
        Lm = L[m]
        beta = tab.beta[Lm]
        bs = beta * s[m, None]
        ep = tab.ca[Lm] * np.exp(bs)
        em = tab.cb[Lm] * np.exp(-bs)
        co, si = np.cos(bs), np.sin(bs)
        cc, cs = tab.cc[Lm], tab.cs[Lm]
        dm = tab.dmask[Lm]
        psi = [ep + em + cc * co + cs * si]
        if orders > 1:
            psi.append(beta * (ep - em - cc * si + cs * co))
        if orders > 2:
            psi.append(beta * beta * (ep + em - cc * co - cs * si))
        for o in range(orders):
            wt[o, m] = psi[o][:, None, :] * dm
        ix[m] = tab.midx[Lm]
    f = tab.fe[L]
    if f.any():
        Lf = L[f]
        sf = s[f]
        h, ne = tab.h[Lf], tab.ne[Lf]
        # Element holding s (1-based); at a node the element to its left (elements.hermite_shape).
        e = np.clip(np.ceil(sf / h).astype(int), 1, ne)
        H = hermite_local((sf - (e - 1) * h) / h, h, orders)  # (orders, 4, Pf)
        wt[:, f, :, :4] = np.transpose(H, (0, 2, 1))[:, :, None, :]
        left, right = tab.node_q[Lf, e - 1], tab.node_q[Lf, e]   # (Pf, 2 slots, 2 (w, t))
        ix[f, :, :2] = left
        ix[f, :, 2:4] = right
    return wt, ix


def _foreshorten_samples(tab: _Tables, qe, r):
    """The samples r (K, 2, n, S, 3) (local r and dr/ds, linear in qe (K, N + 1)) of stiffened links moved
    onto their foreshortened centreline, in place (formulation §15, docs/theory.md §15):

        r_x = x + u_f(x),  u_f = -1/2 delta^T H(x) delta [m],   dr_x/dx = 1 - 1/2 (v'^2 + w'^2),

    H at the sample abscissae from the tables (the same foreshortening_matrix as the material points).
    Why: a tilted link's foreshortened gap differs from the linear one by ~ sin(theta) u_f, enough to
    give it an interior minimum (a bracket of g') where the linear gap is monotone."""
    for i, _, idx, H in tab.stiffened:
        d = qe[:, idx]                                                   # (K, m)
        r[:, 0, i, :, 0] -= 0.5 * np.einsum("km,sml,kl->ks", d, H, d)
        r[:, 1, i, :, 0] -= 0.5 * (r[:, 1, i, :, 1] ** 2 + r[:, 1, i, :, 2] ** 2)


def _foreshorten_points(tab: _Tables, st, ks, links, s, pts):
    """World p, dp/ds, d2p/ds2 pts (P, 3 orders, 3) of the linear centreline at s (P,) [m] on links (P,) of the
    states ks (P,), moved onto the foreshortened centreline where the link is stiffened (returned; a copy):
    p += R e_x u_f, p' += R e_x u_f', p'' += R e_x u_f'' with u_f' = -1/2 (v'^2 + w'^2), u_f'' = -(v' v'' + w' w'')
    (v', w', v'', w'' [1/m] the local components of p', p'': R^T p')."""
    out = None
    for i, lk, idx, _ in tab.stiffened:
        sel = np.flatnonzero(links == i)
        if not sel.size:
            continue
        out = pts.copy() if out is None else out
        R = st.R[ks[sel], i]                                             # (P_i, 3, 3)
        loc = np.einsum("pji,poj->poi", R, pts[sel])                     # R^T (p, p', p'')
        d = st.qe.reshape(-1, tab.N + 1)[ks[sel]][:, idx]                # (P_i, m)
        u = -0.5 * np.einsum("pm,pml,pl->p", d, foreshortening_matrix(lk, s[sel]), d)
        v1, w1, v2, w2 = loc[:, 1, 1], loc[:, 1, 2], loc[:, 2, 1], loc[:, 2, 2]
        shift = np.stack((u, -0.5 * (v1 * v1 + w1 * w1), -(v1 * v2 + w1 * w2)), axis=1)   # (P_i, 3 orders)
        out[sel] += shift[:, :, None] * R[:, None, :, 0]
    return pts if out is None else out


class _Foreshortened:
    """A basis (closest_points._ModalBasis, _HermiteBasis) whose points lie on the foreshortened centreline of
    stiffened links (_foreshorten_points), so that the refinement's Newton iteration runs on their true gap."""

    def __init__(self, basis, tab: _Tables, st, ks, links):
        self.basis, self.tab, self.st, self.ks, self.links = basis, tab, st, ks, links

    def points(self, s):
        """(P, 3 orders, 3): p, dp/ds, d2p/ds2 at s (P,)."""
        return _foreshorten_points(self.tab, self.st, self.ks, self.links, s, self.basis.points(s))

    def compress(self, keep):
        self.basis.compress(keep)
        self.ks, self.links = self.ks[keep], self.links[keep]


def _foreshortened(basis, tab: _Tables, st, ks, links):
    """basis, wrapped in _Foreshortened when one of its links (P,) is stiffened."""
    if tab.stiffened and np.isin(links, [i for i, *_ in tab.stiffened]).any():
        return _Foreshortened(basis, tab, st, ks, links)
    return basis


class _State(NamedTuple):
    """What the evaluation of material points needs from K states: R (K, n, 3, 3), o (K, n, 3),
    qe (K (N + 1),) flat, offset and scale (K, n) of x = offset + scale s."""

    R: np.ndarray
    o: np.ndarray
    qe: np.ndarray
    offset: np.ndarray
    scale: np.ndarray


def _state(model, tab: _Tables, qs) -> _State:
    """Frames of the K states qs (K, N) from one kernel call, and the effective coordinates.

    qe: q with the slope coordinates of Pb links times d (so that v = sum_k N_k(xi) qe_k,
    docs/theory.md §7.4) and a zero slot at index N for the stencils' padding.
    """
    K, N, n = qs.shape[0], tab.N, tab.n
    job = _k.JOB_FRAMES
    fdat, idat, zeros, v = model.kernel_data
    # One kernel call (kernel.run, no run_kernel checks: as_vector gives the entry point the array
    # type it was compiled for, and the frames section's offset is cached for K = 1).
    if K == 1:
        out = _k.run(v, fdat, idat, as_vector(qs), tab.qdot1, zeros, job)
        o0 = tab.frames_offset
    else:
        out = _k.run(v, fdat, idat, as_vector(qs), np.zeros(K * N), zeros, job)
        o0 = int(_k.layout(n, N, K, job, model.n_joints)[_k.SECTIONS.index("frames")])
    T = out[o0:o0 + 48 * (n + 1) * K].reshape(K, n + 1, 3, 4, 4)[:, :n, 0]
    qe = np.concatenate((qs, np.zeros((K, 1))), axis=1)
    if not tab.has_pb:
        if K == 1:
            return _State(T[..., :3, :3], T[..., :3, 3], qe.reshape(-1), tab.offset1, tab.scale1)
        return _State(T[..., :3, :3], T[..., :3, 3], qe.reshape(-1), np.zeros((K, n)), np.ones((K, n)))
    for slopes, jd in tab.pb_slopes:
        qe[:, slopes] *= qs[:, jd, None]
    d = qs[:, tab.d_index]
    offset = np.where(tab.pb, tab.length - d, 0.0)
    scale = np.where(tab.pb, d, 1.0)
    return _State(T[..., :3, :3], T[..., :3, 3], qe.reshape(-1), offset, scale)
