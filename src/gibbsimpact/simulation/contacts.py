"""Wall contacts of the event loop: gaps of every (wall, contact point) pair, the contact band,
the impact stage and the events of a flight phase (docs/theory.md §10, §11, §14).

The rules are stated in gibbsimpact.simulate's module docstring; simulate.py drives these stages.
"""

from __future__ import annotations

import numpy as np

from .. import kernel as _k
from ..dynamics.gibbs_appell import energy, mass_matrix
from .flight import EventSpec
from ..contact.friction import solve_frictional_impulses
from ..contact.impact import actuator_impulses, held_impulses, solve_impulses
from ..dynamics.kinematics import joint_positions, joint_positions_and_jacobians, joint_positions_batch
from .results import ImpactRecord
from ..contact.walls import has_obstacle, packed_walls, tangent_basis
from ..contact.candidates import body_candidates, end_joints
from ..contact.span_cells import link_cells, link_minima
from ..dynamics.link_points import body_centers, body_jacobian, body_tables


def flexible_links(model) -> list:
    """0-based indices of the links with elastic coordinates, in order."""
    return [i for i in range(model.n_links) if model.delta_index[i].size]


def link_columns(model, walls=()) -> list:
    """0-based indices of the links with a link column in Contacts, in order: the flexible links, or every
    link when one of ``walls`` is an obstacle (its gap is convex along a line: a rigid link's closest
    point to it can lie between the link's ends, and a rigid rod can strike a post with its span)."""
    return list(range(model.n_links)) if has_obstacle(walls) else flexible_links(model)


def link_column_cells(model, walls=()) -> list:
    """The link columns of Contacts as (link i, cell c, cells m) (0-based i, c): the cells of every link of
    link_columns (contact.span_cells.link_cells: one per element of a finite-element link)."""
    return link_cells(model, link_columns(model, walls))


def link_column_name(i: int, c: int, m: int, sep: str = " ") -> str:
    """Name of the link column (i, c, m): "link 2" for a link with one cell, else "link 2.3" (cell 3 of
    link 2, counted from its proximal end); sep "" gives the file form "link2", "link2.3"."""
    return f"link{sep}{i + 1}" + (f".{c + 1}" if m > 1 else "")


#: Gap [m] of a link candidate whose closest point is at an end of the link (its end joint stands for it).
NOT_INTERIOR = 1e300


class Contacts:
    """Gaps, normals and Jacobians of every (wall, contact point) pair (docs/theory.md §10; issue 9 item 2).

    Columns c = 0 .. C-1 of the (W, C) gap matrix: the P joint points (model.contact_point_names),
    then one column per cell of every flexible link i (``cells`` (i, c, m), ``flex`` their links;
    every link when a wall is an obstacle: link_columns, link_column_cells): the lowest material point
    of cell c of link i on wall w (contact.span_cells; with one cell the point of link i closest to
    wall w, gibbsimpact.linkpoints), deflection included. A link column holds that point's gap
    when it is *interior* (farther than 1e-6 l_i from the link's ends), else NOT_INTERIOR: at
    an end, the end joint's own column is the candidate, so nothing is counted twice. Its
    event fires where a link bulges into a wall between its joints. Rigid links have no column
    unless a wall is an obstacle (else their closest point is always an end). Link columns
    rest like the joints (contact.span_resting: the contact point rolls and slides along the link).

    Then one column per attached body with a centre offset (contact.candidates.body_candidates,
    ``bodies``): the gap of its centre, a point candidate like a joint (docs/theory.md §6.8); it
    cannot rest either.

    link_contacts=False: joints (and bodies) only (C = P + B), the model of the published case studies.

    Cost: a link is searched (gibbsimpact.linkpoints.closest_points) only where its column can
    hold a gap <= refine_below; elsewhere it gets NOT_INTERIOR without a search (skip rule
    below). Notation: s in [0, 1] along the link's search interval (x = s l_i; on a Pb link
    the protruding part, x = l_i - d + s d), u = s (1 - s), p(s) [m] the material points,
    G(s) = g(p(s)) [m] on one wall, the end joints A = p(0), B = p(1) (linkpoints.end_joints;
    every mode and element shape is 0 at x = 0) with gaps g_A, g_B [m].

    * Walls: every gap is 1-Lipschitz (|grad g| = 1) and, except on obstacles, concave along a
      straight line (Plane: linear; Circle, Sphere: the inside, g = R - |P (p - c)| with |P (.)|
      convex). Rules (1), (3), (4) below use the concavity; an obstacle's pairs take rule (5).
    * Chord c(s) = (1 - s) A + s B [m]. The axial coordinate of p(s) in the link frame is
      linear in s, so p(s) - c(s) = R_i (0, phi(s)), phi = (v, w)(s) - (1 - s) (v, w)(0)
      - s (v, w)(1) = sum_k e_k phi_k(s), linear in the elastic coordinates (e_k = delta_k; on
      a Pb link a slope coordinate's e_k = delta_k d / l_i, its shape tabulated at d = l_i),
      and every phi_k (2,) [m per unit of e_k] is 0 at s = 0 and s = 1, so that
      lam_k = max over 0 < s < 1 of |phi_k(s)| / u is finite. By the Lipschitz bound,

          G(s) >= g(c(s)) - Lam u,        Lam = sum_k |e_k| lam_k [m]                    (2)

      (the tables of lam_k and of max|psi_k| in (1): 1.1 times their maxima over 4097
      samples, as the old rule (1) took 1.1 times the maximum over 401).
    * A stiffened link (formulation §15) is not straight along its axis: its points (the end
      joint B included) move by u_f(x) = -1/2 int_0^x (v'^2 + w'^2), so p(s) - c(s) = R_i (a(s), phi(s)),
      a(s) = u_f(s l) - s u_f(l) = s int_x^l |u_f'| - (1 - s) int_0^x |u_f'|, each term in [0, u l M],
      M = max_x |u_f'| <= 1/2 (sum_k |delta_k| mu_k)^2 (mu_k: 1.1 times the sampled max_x |psi_k'(x)|
      [1/m]). So |a(s)| <= Lam_f u, Lam_f = l/2 (sum_k |delta_k| mu_k)^2 [m]: such a link takes
      Lam + Lam_f for Lam in (2) - (5), and 2 D_i + Lam_f / 4 for 2 D_i in (1) (max |a| <= Lam_f / 4).

    Skip rule, per (wall, link), with t = min(g_A, g_B, refine_below), h_A = g_A - t >= 0,
    h_B = g_B - t >= 0: the pair is skipped when one of these holds, each of which gives
    G(s) > t for every s in (0, 1):

    * (1) min(g_A, g_B) - 2 D_i > refine_below, D_i = sum_k |e_k| max_x |psi_k(x)| [m]:
      |phi_k| <= 2 max|psi_k| and g(c(s)) >= min(g_A, g_B) (concavity).
    * Plane: (sqrt(h_A) + sqrt(h_B))^2 > Lam. g(c(s)) = (1 - s) g_A + s g_B, so by (2)

          G(s) - t >= (1 - s) h_A + s h_B - Lam u = u (h_A / s + h_B / (1 - s) - Lam)
                   >= u ((sqrt(h_A) + sqrt(h_B))^2 - Lam)                              (3)

      (min over s of a / s + b / (1 - s) is (sqrt(a) + sqrt(b))^2: Cauchy-Schwarz).
    * Circle, sphere: 4 T > Lam and S^2 + L^2 > 2 T Lam, with T = R - t,
      S = sqrt(h_A (2 T - h_A)) + sqrt(h_B (2 T - h_B)), L = |P (B - A)| [m]. Here
      g(c(s)) = R - sqrt(Z), Z = |P (c(s) - c_w)|^2 = (1 - s) rho_A^2 + s rho_B^2 - u L^2
      exactly (rho = R - g <= T), and G(s) > t follows from T - Lam u > 0 (4 T > Lam) and

          (T - Lam u)^2 - Z >= (1 - s)(T^2 - rho_A^2) + s (T^2 - rho_B^2) + u (L^2 - 2 T Lam)
                            >= u (S^2 + L^2 - 2 T Lam) > 0                              (4)

      as T^2 - rho_A^2 = h_A (2 T - h_A). (With both joints on the wall: the chord's sagitta
      L^2 / (8 R) exceeds the largest offset Lam / 4 of the link from its chord.)
    * (5) Obstacle (g = |P (p - c)| - R): rho_min - R - Lam / 4 > t, rho_min the distance of
      the chord from the centre (projected by P): by (2), G(s) >= g(c(s)) - Lam u >= rho_min
      - R - Lam / 4 (kernel.contact._skip_obstacle).

    Why a skip never hides a contact: the search returns an interior point s* with
    G(s*) <= refine_below only as a refined minimum that beats both end samples (linkpoints:
    by the margin _TIE = 64 eps (1 + max|p|), which also covers the round-off of these
    bounds' gaps; an unrefined sample is above refine_below), so G(s*) < min(g_A, g_B), and
    then G(s*) > t would mean G(s*) > refine_below, a contradiction. A skipped pair would thus
    have held NOT_INTERIOR (always so when min(g_A, g_B) < refine_below: the skip changes
    nothing then) or a gap above refine_below > 0: its column is never <= refine_below, and
    the switch between search and skip never fakes a sign change. (3), (4) hold with the
    joints on the wall (t = g_A or g_B), where (1), the old rule, always searched.
    """

    #: Samples of the tables lam_k, max|psi_k| (their maxima, plus 10 %).
    _TABLE_SAMPLES = 4097

    def __init__(self, model, walls, link_contacts=True):
        self.model, self.walls = model, walls
        self.N, self.n_joints = model.n_dof, model.n_joints
        # Link columns: cell c of m of link i (contact.span_cells), flex the link of each.
        self.cells = link_column_cells(model, walls) if (walls and link_contacts) else []
        self.flex = [i for i, _, _ in self.cells]
        self.bodies = body_candidates(model) if walls else ()
        self._body_tables = body_tables(model, self.bodies)
        self.n_cols = self.n_joints + len(self.flex) + len(self.bodies)
        # Link minima farther than this from a wall are not refined (a sample's gap: sign exact).
        self.refine_below = 0.01 * (1.0 + sum(ld.length for ld in model.link_data))
        self._key, self._g = None, None
        self._pkey, self._pg = None, None
        # resting : None or callable () -> (W, C) bool, the pairs resting now (contact.resting.RestingContacts
        # .active): a resting link column stays continuous at its link's ends (gaps_batch).
        self.resting, self._resting_key = None, None
        # The end joint at each link column's cell (F, 2): (proximal, distal) for the link's first / last cell, else -1;
        # -1 for a link with one cell (its closest point: not watched so, a modal rod resting at both ends then
        # crawled, tests/simulation/test_accumulation.py; see end_held).
        ends = end_joints(model)
        self._cell_ends = np.array([(ends[i, 0] if c == 0 else -1, ends[i, 1] if c == m - 1 else -1)
                                    if m > 1 else (-1, -1) for i, c, m in self.cells], dtype=int).reshape(-1, 2)
        # The compiled event gaps (kernel.event_gaps): packed walls, and the skip rule's (link,
        # wall) pairs (f, w, a, b) with their tables (_bound_tables).
        for w in walls:
            if not hasattr(w, "packed"):
                raise TypeError(f"wall {w!r}: the event layer needs gibbsimpact Plane, Circle or Sphere walls")
        self._wk, self._wp = packed_walls(walls)
        self._rules = np.zeros((0, 4), dtype=np.int64)
        if self.flex:
            self._bound_tables()

    def _bound_tables(self):
        """Tables of the skip rule (class docstring).

        _table (N, 2 F) [m per unit of e_k]: lam_k of link f in column f, 2 max_x |psi_k(x)|
        in column F + f (each 1.1 times its sampled maximum); _rules (F W, 4) int64: per (link f,
        wall w) pair (f, w, the link's end joints a, b, or -1, -1 for a link without an end
        point: searched always); _pb_slopes: (slope indices, d index, l_i) of the Pb links
        (e_k = delta_k d / l_i for a slope).
        """
        from ..model.shapes import link_deflection

        model, N, F = self.model, self.N, len(self.flex)
        u = np.linspace(0.0, 1.0, self._TABLE_SAMPLES)
        inner = slice(1, -1)
        table, slopes = np.zeros((N, 2 * F)), np.zeros((N, F))
        self._pb_slopes = []
        first = {}   # link -> its first column: a link's cells share its tables (they bound the whole link)
        for f, i in enumerate(self.flex):
            if i in first:
                g = first[i]
                table[:, f], table[:, F + f], slopes[:, f] = table[:, g], table[:, F + g], slopes[:, g]
                continue
            first[i] = f
            lk = model.chain.links[i]
            x = u * lk.length
            q = np.zeros(N)
            if model.chain.joints[i].spec.guide:
                # d = l: x = l - d + s d = s l; a slope coordinate's shape scales with d (e_k = delta_k d / l).
                q[model.theta_index[i]] = lk.length
                self._pb_slopes.append((model.delta_index[i][1::2], model.theta_index[i], lk.length))
            for c in model.delta_index[i]:
                q[c] = 1.0
                v, w = link_deflection(model, q, i, x)
                if lk.stiffened:   # mu_k = 1.1 max|psi_k'| [1/m]
                    slopes[c, f] = 1.1 * float(np.max(np.hypot(*link_deflection(model, q, i, x, 1))))
                q[c] = 0.0
                # phi_k = (v, w)(s) - (1 - s) (v, w)(0) - s (v, w)(1); lam_k = max |phi_k| / (s (1 - s)).
                phi = np.hypot(v - (1.0 - u) * v[0] - u * v[-1], w - (1.0 - u) * w[0] - u * w[-1])
                table[c, f] = 1.1 * float(np.max(phi[inner] / (u[inner] * (1.0 - u[inner]))))
                table[c, F + f] = 2.0 * 1.1 * float(np.max(np.hypot(v, w)))
        self._table = table
        # Stiffened links' axial bound (class docstring): mu_k per column, and l_i (F,) [m]; None without one.
        self._axial = (slopes, np.array([model.chain.links[i].length for i in self.flex])) if slopes.any() else None
        ends = end_joints(model)[self.flex]
        # The (link, wall) pairs of the skip rule: (f, w, a, b), a = b = -1 for a link without an
        # end joint (never skipped).
        self._rules = np.array([(f, w, a, b) if (a >= 0 and b >= 0) else (f, w, -1, -1)
                                for f, (a, b) in enumerate(ends) for w in range(len(self.walls))],
                               dtype=np.int64).reshape(-1, 4)

    def _bounds(self, qs) -> np.ndarray:
        """Lam and 2 D_i [m] (K, 2 F) of the states qs (K, N) (class docstring)."""
        # |e_k| = |delta_k| (a Pb link's slope coordinate: |delta_k| d / l_i); Lam = sum_k |e_k| lam_k,
        # 2 D_i = sum_k |e_k| 2 max|psi_k|.
        e = np.abs(qs)
        for slopes, jd, length in self._pb_slopes:
            e[:, slopes] *= np.abs(qs[:, jd, None]) / length
        E = e @ self._table
        if self._axial is not None:   # Lam_f = l/2 (sum_k |delta_k| mu_k)^2 (stiffened links: never Pb)
            lam_f = 0.5 * self._axial[1] * (e @ self._axial[0]) ** 2
            F = lam_f.shape[1]
            E[:, :F] += lam_f
            E[:, F:] += 0.25 * lam_f
        return E

    def _event_gaps(self, qs, points, rules=True):
        """The compiled kernel.event_gaps for the states qs (K, N) with contact points (K, P, 3) [m]:
        their joint gaps (K, W, P) [m], and the rest of its output (rules=True: the skip rule of
        the pairs of _rules, then the states that need a link search; see skipped, gaps_batch)."""
        K, W, P = len(qs), len(self.walls), self.n_joints
        if rules and self.flex:
            E, R = self._bounds(qs), self._rules
        else:
            E, R = np.zeros((K, 0)), self._rules[:0]
        r = _k.lazy("event_gaps")(np.ascontiguousarray(points, dtype=float).reshape(-1), P, self._wk, self._wp,
                                  E, R, self.refine_below)
        return r[:K * W * P].reshape(K, W, P), r[K * W * P:]

    def _link_bounds(self, qs, g_joints, points):
        """The skip rule's inputs as Python lists: Lam and 2 D_i [m] (K, 2 F), the joint gaps
        g_joints (K, W, P) [m] and positions points (K, P, 3) [m] (the skip-rule tests read them)."""
        return self._bounds(qs).tolist(), np.asarray(g_joints).tolist(), np.asarray(points).tolist()

    def skipped(self, q) -> np.ndarray:
        """(W, F) bool, or (K, W, F) for q (K, N): the (wall, link) pairs that the skip rule
        (class docstring) proves to have a link column of NOT_INTERIOR or above refine_below."""
        qs = np.atleast_2d(np.asarray(q, dtype=float))
        K = len(qs)
        rest = self._event_gaps(qs, joint_positions_batch(self.model, qs))[1]
        out = np.zeros((K, len(self.walls), len(self.flex)), dtype=bool)
        out[:, self._rules[:, 1], self._rules[:, 0]] = rest[:K * len(self._rules)].reshape(K, -1) != 0.0
        return out if np.ndim(q) == 2 else out[0]

    def _held(self):
        """(W, F) bool, the link columns whose event gap is the cell's minimum wherever it lies (the resting
        columns and those of end_held), or None when none is."""
        if self.resting is None or not self.flex:
            return None
        held = self.resting()[:, self.n_joints:self.n_joints + len(self.flex)] | self.end_held()
        return held if held.any() else None

    def end_held(self) -> np.ndarray:
        """(W, F) bool: the link columns of a cell at a link's end whose end joint rests on that wall (docs/theory.md
        §15.3, a dip out of a resting end).

        Such a cell's minimum sits at the resting end, g = g_end ~ 0, until an interior dip next to it goes
        below the end: with NOT_INTERIOR there the column would jump from 1e300 to ~g_end and, with g_end
        already below 0 by the end's allowed drift, no fall through 0 is left to fire. Their event gap is
        the continuous minimum (1) of contact.span_cells over the closed cell instead, watched at the level
        -contact_tol (stages._phase_events): the same level as the end's own drift event, so the end alone
        fires it no earlier than its drift event would, and a dip is caught at g = -contact_tol at the latest.
        """
        W, F = len(self.walls), len(self.flex)
        if self.resting is None or not F:
            return np.zeros((W, F), dtype=bool)
        active = np.concatenate((self.resting(), np.zeros((W, 1), dtype=bool)), axis=1)  # column -1: no end
        ends = self._cell_ends  # (F, 2) joint column of the cell's link end, -1 for none
        return active[:, ends[:, 0]] | active[:, ends[:, 1]]

    def _link_gaps(self, qs, need=None, out=None):
        """Link columns (K, W, F) [m], the closest points' abscissae x (K, W, F) [m], their normals
        (K, W, F, 3) and whether they are interior (K, W, F), for the states qs (K, N).

        need : (K,) bool, the states with a pair that the skip rule does not skip (the others
        hold NOT_INTERIOR without a search); None searches every state.
        out : None, or a (K, W, F) array that receives the link columns (then only they are
        computed, and None is returned: gaps_batch).
        """
        K, W, F = len(qs), len(self.walls), len(self.flex)
        need = np.ones(K, dtype=bool) if need is None else need
        details = out is None
        if details:
            out = np.full((K, W, F), NOT_INTERIOR)
            x, nrm, inside = np.zeros((K, W, F)), np.zeros((K, W, F, 3)), np.zeros((K, W, F), dtype=bool)
        else:
            out[...] = NOT_INTERIOR
        if need.any():
            cm = link_minima(self.model, qs[need], self.walls, self.cells, refine_below=self.refine_below)
            # A resting column keeps the cell's minimum when it reaches the link's end (details=False: the
            # events' gaps): its point hands over to the end joint there without a jump, so its drift
            # events see a continuous gap (span_resting.span_abscissae holds it at the end's material point).
            held = None if details else self._held()
            inside = cm.inside if held is None else cm.inside | held
            out[need] = np.where(inside, cm.gap, NOT_INTERIOR)
            if details:
                x[need], nrm[need], inside[need] = cm.x, cm.normal, cm.inside
        return (out, x, nrm, inside) if details else None

    def gap_single(self, q: np.ndarray, w: int, c: int, full=None) -> float:
        """g[w, c] at q [m]; a joint column costs one joint-position call (cached per q), not a link search.

        full : the gap-matrix function to use for other entries (default self.gaps).
        """
        if w < len(self.walls) and c < self.n_joints:
            key = q.tobytes()
            if key != self._pkey:
                p = joint_positions(self.model, q)
                # The joint gaps of the same compiled code as gaps_batch (the root search brackets
                # a sign change that gaps_batch found: the same round-off).
                self._pg, self._pkey = self._event_gaps(q[None, :], p[None], rules=False)[0][0], key
            return float(self._pg[w, c])
        return float((self.gaps if full is None else full)(q)[w, c])

    @property
    def names(self) -> list:
        """Names of the C columns: the joint points, "link i" for the closest point of link i, then
        "body k" for the k-th body candidate (contact_points.body_name)."""
        return [f"O{j + 1}" for j in range(self.n_joints)] + [link_column_name(*cell) for cell in self.cells] + \
            [f"body {k + 1}" for k in range(len(self.bodies))]

    def gaps(self, q: np.ndarray) -> np.ndarray:
        """g (W, C) [m]; cached per q (every event function of a step sees the same q)."""
        rkey = None if self.resting is None else self.resting().tobytes()
        if rkey != self._resting_key:  # the resting pairs changed: so may the link columns (gaps_batch)
            self._key, self._resting_key = None, rkey
        key = q.tobytes()
        if key != self._key:
            self._g = self.gaps_batch(np.asarray(q, dtype=float).reshape(1, -1))[0]
            self._key = key
        return self._g

    def gaps_batch(self, qs: np.ndarray) -> np.ndarray:
        """g (K, W, C) [m] of the states qs (K, N): one kernel call and one kernel.event_gaps call
        for all of them (joint gaps and the skip rule), link searches only where it cannot skip."""
        if not self.walls:
            return np.zeros((len(qs), 0, self.n_cols))
        pts = joint_positions_batch(self.model, qs)  # (K, P, 3)
        P, F = self.n_joints, len(self.flex)
        g_joints, rest = self._event_gaps(qs, pts)
        if not (self.flex or self.bodies):
            return g_joints
        g = np.empty((len(qs), len(self.walls), self.n_cols))
        g[:, :, :P] = g_joints
        search = rest[len(qs) * len(self._rules):] != 0.0  # (K,) states that need a link search
        if self._held() is not None:  # a resting column is searched always (its value at a link's end)
            search[:] = True
        if F and search.any():
            self._link_gaps(qs, search, out=g[:, :, P:P + F])
        else:
            g[:, :, P:P + F] = NOT_INTERIOR
        if self.bodies:
            pb = body_centers(self.model, qs, self.bodies, self._body_tables)[0]  # (K, B, 3)
            g[:, :, P + F:] = np.stack([w.gap(pb) for w in self.walls], axis=1)
        return g

    def full(self, q: np.ndarray, abscissae: bool = False):
        """g (W, C) [m], unit normals (W, C, 3), Jacobians (W, C, 3, N), points (W, C, 3) [m] and
        valid (W, C) bool: the columns that can be candidates of an impact (joints; interior link points);
        with abscissae, sixth the abscissa x (W, C) [m] of each link column's point on its link (NaN elsewhere)."""
        p, Jac = joint_positions_and_jacobians(self.model, q)
        W, P = len(self.walls), self.n_joints
        g = np.array([w.gap(p) for w in self.walls]).reshape(W, P)
        nrm = np.array([w.normal(p) for w in self.walls]).reshape(W, P, 3)
        J = np.broadcast_to(Jac, (W,) + Jac.shape)
        pts = np.broadcast_to(p, (W,) + p.shape)
        valid = np.ones((W, P), dtype=bool)
        xs = np.full((W, self.n_cols), np.nan)
        if self.flex:
            from ..contact.candidates import material_jacobian

            search = self._event_gaps(q[None, :], p[None])[1][len(self._rules):] != 0.0
            gl, x, nl, inside = (a[0] for a in self._link_gaps(q[None, :], search))
            F = len(self.flex)
            Jl, pl = np.zeros((W, F, 3, self.N)), np.full((W, F, 3), np.nan)
            for w, f in np.argwhere(inside):
                pl[w, f], Jl[w, f], _ = material_jacobian(self.model, q, np.zeros(self.N), self.flex[f], x[w, f])
            g, nrm = np.concatenate((g, gl), axis=1), np.concatenate((nrm, nl), axis=1)
            J, pts = np.concatenate((J, Jl), axis=1), np.concatenate((pts, pl), axis=1)
            valid = np.concatenate((valid, inside), axis=1)
            xs[:, P:P + F] = x
        if self.bodies:
            pb, Jb = zip(*(body_jacobian(self.model, q, i, b) for i, b in self.bodies))
            pb, Jb = np.array(pb), np.array(Jb)  # (B, 3), (B, 3, N)
            g = np.concatenate((g, np.array([w.gap(pb) for w in self.walls])), axis=1)
            nrm = np.concatenate((nrm, np.array([w.normal(pb) for w in self.walls])), axis=1)
            J = np.concatenate((J, np.broadcast_to(Jb, (W,) + Jb.shape)), axis=1)
            pts = np.concatenate((pts, np.broadcast_to(pb, (W,) + pb.shape)), axis=1)
            valid = np.concatenate((valid, np.ones((W, len(pb)), dtype=bool)), axis=1)
        return (g, nrm, J, pts, valid, xs) if abscissae else (g, nrm, J, pts, valid)


def gap_lipschitz(model) -> float:
    """L_q = 1 + 2 sum l_i [m per unit of q], a bound on |dg/dq|: a translation moves a joint 1:1, a rotation
    by at most its lever arm."""
    return 1.0 + 2.0 * sum(ld.length for ld in model.link_data)


def contact_band(contact_tol: float, lipschitz: float, rtol: float, atol: float, q: np.ndarray) -> float:
    """The contact band b [m] at q (N,): gaps within it belong to one impact (module docstring).

    b = max(2 contact_tol, L_q (atol + rtol max|q|)), L_q [m per unit of q] a bound on |dg/dq|.
    """
    return max(2.0 * contact_tol, lipschitz * (atol + rtol * float(np.abs(q).max(initial=0.0))))


def impact_stage(model, contacts, e_wall, t, q, qd, band, grazing_velocity, sink_pair, resting=None,
                 prescribed=None, compliant=None):
    """The impact at (t, q, qd), if there is one.

    resting : None or (W, J) bool, the pairs in resting contact: they take e = 0 (gibbsimpact.resting).
    prescribed : None or (n_p,) int, coordinates whose actuators hold their velocity (formulation §16): the
        impulse problem is solved on the free ones, the record carries the actuators' impulses.
    compliant : None or (W,) bool, the walls of the compliant law: never candidates (simulation.compliant).
    Raises contact.impact.HeldContactError when a contact is moved by prescribed coordinates only.
    Returns (record or None, near (W, J) bool: the pairs in the contact band g <= band [m]).
    """
    g, nrm, Jac, pts, valid = contacts.full(q)
    # Candidates: every pair within the contact band (a pair caught by its "sink"
    # event sits just below its phase-start gap); a link column only with an interior point.
    near = g <= band
    if compliant is not None:
        near &= ~compliant[:, None]
    if not np.any(near & valid):
        return None, near
    pairs = np.argwhere(near & valid)  # (k, 2): wall, column
    normals = nrm[pairs[:, 0], pairs[:, 1]]
    Jk = Jac[pairs[:, 0], pairs[:, 1]]  # (k, 3, N)
    Wmat = np.einsum("kc,kcn->nk", normals, Jk)
    v_before = Wmat.T @ qd
    # An impact: some candidate approaches faster than grazing, or the pair whose
    # "sink" event fired is still approaching (it must be stopped).
    sinking = sink_pair is not None and np.any(
        (pairs[:, 0] == sink_pair[0]) & (pairs[:, 1] == sink_pair[1]) & (v_before < 0)
    )
    if not (np.any(v_before < -grazing_velocity) or sinking):
        return None, near
    M = mass_matrix(model, q)
    e_k = e_wall[pairs[:, 0]]
    if resting is not None:
        e_k = np.where(resting[pairs[:, 0], pairs[:, 1]], 0.0, e_k)
    mu_k = np.array([contacts.walls[w].friction for w in pairs[:, 0]])
    friction, held = {}, {}
    if np.any(mu_k > 0):
        # Moreau's law with Coulomb's cone (friction.py): tangents t1, t2 of each contact.
        T = tangent_basis(normals)  # (k, 2, 3)
        Wt = np.einsum("kac,kcn->nka", T, Jk)
        sol, qdot_after = _solve(M, Wmat, qd, prescribed, lambda M_, r, v: solve_frictional_impulses(
            M_, Wmat[r], Wt[r], v, e_k, mu_k), Wt)
        world = lambda a: np.einsum("ka,kac->kc", a, T)  # noqa: E731
        friction = dict(friction_impulses=world(sol.tangential_impulses), slip_before=world(sol.slip_before),
                        slip_after=world(sol.slip_after))
        rounds = sol.rounds
        impulse = Wmat @ sol.impulses + np.einsum("nka,ka->n", Wt, sol.tangential_impulses)
    else:
        sol, qdot_after = _solve(M, Wmat, qd, prescribed, lambda M_, r, v: solve_impulses(M_, Wmat[r], v, e_k))
        rounds = len(sol.rounds)
        impulse = Wmat @ sol.impulses
    if prescribed is not None:
        held = dict(actuator_impulses=actuator_impulses(M, qd, qdot_after, impulse, prescribed))
    rec = ImpactRecord(
        time=t, joints=tuple(int(j) + 1 for j in pairs[:, 1]), wall=tuple(int(w) for w in pairs[:, 0]),
        normals=normals, impulses=sol.impulses, v_before=sol.v_before, v_after=sol.v_after,
        restitution=e_k, qdot_before=qd.copy(), qdot_after=qdot_after.copy(),
        energy_before=energy(model, q, qd), energy_after=energy(model, q, qdot_after),
        rounds=rounds, points=pts[pairs[:, 0], pairs[:, 1]].copy(), **friction, **held,
    )
    return rec, near


def _solve(M, W, qd, prescribed, solve, Wt=None):
    """(solution, qdot_after (N,)) of solve(M, rows, qdot) on every coordinate, or on the free ones with the
    prescribed (n_p,) holding their velocity (contact.impact.held_impulses; W (N, k), Wt (N, k, 2) or None)."""
    if prescribed is None:
        sol = solve(M, slice(None), qd)
        return sol, sol.qdot_after
    W_all = W if Wt is None else np.hstack((W, Wt.reshape(W.shape[0], -1)))
    return held_impulses(M, W_all, qd, prescribed, solve)


def phase_events(near, g_start, band, sink_depth, row0=0, skip=None):
    """EventSpec of one phase and the kind of each event ("hit", "sink", "leave").

    near : (W, J) pairs in the contact band at the phase start; g_start : (W, J) their gaps [m];
    row0 : the gap-matrix row of near's first row (the joint limits sit below the walls);
    skip : None or (W, J) bool, pairs without these events (resting pairs: see resting.drift_events).
    """
    rows, kinds = [], []
    for w, j in np.ndindex(near.shape):
        w_i = w + row0
        if skip is not None and skip[w, j]:
            continue
        if near[w, j]:
            # Sink level min(g_start, 0) - sink_depth: the event function starts at
            # sink_depth > 0 (above the gap's round-off), so a bounce lower than one
            # solver step that falls back is still a sign change (never tunnels).
            rows.append((w_i, j, sink_depth - min(float(g_start[w, j]), 0.0), -1.0))
            kinds.append(("sink", w_i, j))
            rows.append((w_i, j, -1.5 * band, 1.0))
            kinds.append(("leave", w_i, j))
        else:
            rows.append((w_i, j, 0.0, -1.0))
            kinds.append(("hit", w_i, j))
    a = np.array(rows, dtype=float).reshape(-1, 4)
    return event_spec(a), kinds


def event_spec(a) -> EventSpec:
    """EventSpec from rows (wall row, joint, offset, direction) (K, 4)."""
    a = np.asarray(a, dtype=float).reshape(-1, 4)
    return EventSpec(a[:, 0].astype(int), a[:, 1].astype(int), a[:, 2], a[:, 3])
