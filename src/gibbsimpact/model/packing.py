"""The model packed for the compiled kernel: one float64 and one int64 array (gibbsimpact.kernel.layout).

``pack(model)`` is the one place where a Model becomes the kernel's data (fdat, idat); the
layout constants and kind codes it writes are the kernel's own (``gibbsimpact.kernel.layout``).
"""

from __future__ import annotations

import numpy as np

from ..kernel.layout import (_CI, _F_BASE, _F_LINKS, _GAUSS, _H, _LI, BASE_FIXED, BASE_FREE, BASE_PLANAR, END_GENERAL,
                             END_RIGID, JOINT_PA, JOINT_PB, JOINT_R, KIND_MODE, KIND_PA, KIND_PB,
                             KIND_ROTATION, KIND_TRANSLATION)
from .elements import assemble as assemble_elements, element_stiffness, hermite_shape
from .shapes import foreshortening_matrix, mass_points, section_tables, shape_functions


def _pb_tables(link):
    """Unit-interval tables of a Pb link with n_e elements (docs/theory.md §7.4, §7.6)."""
    ne = link.elements
    if ne == 0:
        return []
    t, wt = np.polynomial.legendre.leggauss(_GAUSS)
    xi = ((np.arange(ne)[:, None] + 0.5 * (t[None, :] + 1.0)) / ne).ravel()
    w = np.tile(0.5 * wt / ne, ne)
    N = [hermite_shape(ne, 1.0, xi, k).T.ravel() for k in range(3)]  # (G, m) row-major
    Kunit = assemble_elements(element_stiffness(1.0, 1.0 / ne), ne)
    a = np.tile([0.0, 1.0], ne)  # a_k: 0 for a deflection dof, 1 for a slope dof
    return [xi, w, *N, Kunit.ravel(), a]


def _fs_tables(link, quadrature):
    """The per-call foreshortening data of a stiffened link (formulation §15; kernel/moments.py
    _fs_moments), over the link's mass points (mass_points: the line quadrature with weights
    W_g = w mu [kg] and the points of attached bodies, the same material as the modal integrals),
    at X_g = x_g + s_g with shapes psi + s psi' and H(x) + s psi' psi'^T (s the point's lever):

    * per-call sum: [G, P, 0, x (G) [m], W (G) [kg], psi (G, m), k (P), l (P), H_p(x) (G, P) [1/m],
      H(l) (m, m)], the P pairs k <= l where H(x) is not zero for some x (banded for elements);
    * tensors: [0, 0, 1, H(l) (m, m), A0 = sum W H (m, m), A1 = sum W x H, B_k = sum W psi_k H
      (m, m, m), A4_kilj = sum W H_ki H_lj (m^4)], the same sums taken once.

    Tensors when their contraction, ~2 m^4 + 4 m^3 products a call, is cheaper than the sum,
    ~G (P + m^2 + 10 m): a few assumed modes (G = 256 points, m = 1: 6 against 3 000), an arm of
    up to ~6 elements; the sum for finer meshes (16 elements: 2.2e6 against 1.8e5).
    """
    x, wm, s = mass_points(link, quadrature)
    directions, d1 = shape_functions(link, x, 1)
    psi = (shape_functions(link, x)[1] + s * d1).T
    # a point at lever s from its section x (an attached body's, mass_points) turns with the section:
    # to second order it is at x + s + u_f(x) - s/2 (v'^2 + w'^2), so its H is H(x) + s psi' psi'^T
    same = np.equal.outer(np.array(directions), np.array(directions))
    H = foreshortening_matrix(link, x) + np.einsum("g,kg,lg->gkl", s, d1, d1) * same
    x = x + s
    Hl = foreshortening_matrix(link, [link.length])[0]
    k, l = np.nonzero(np.triu(np.any(H != 0.0, axis=0)))
    G, m = x.size, psi.shape[1]
    if 2 * m**4 + 4 * m**3 < G * (k.size + m * m + 10 * m):
        return [[0, 0, 1], Hl.ravel(), np.einsum("g,gkl->kl", wm, H).ravel(),
                np.einsum("g,gkl->kl", wm * x, H).ravel(), np.einsum("g,gj,gkl->jkl", wm, psi, H).ravel(),
                np.einsum("g,gki,glj->kilj", wm, H, H).ravel()]
    return [[G, k.size, 0], x, wm, psi.ravel(), k, l, H[:, k, l].ravel(), Hl.ravel()]


def base_block(model) -> np.ndarray:
    """T_0 (4, 4), the kernel's base transform (fdat[_F_BASE:_F_BASE + 16], row-major).

    Fixed base: its constant transform. Spatial free base: [[R_ref, 0], [0, 1]] with R_ref the model's
    base chart (formulation §18; I unless Model.with_base_chart changed it): the kernel writes X into the
    origin column and turns by Rx(theta_-1) Ry(theta_0) after it, so T_1 = Trans(X) R_ref Rx Ry Rz(theta_1).
    Planar base: I.
    """
    if not model.free_base:
        return np.asarray(model.base_transform, dtype=float)
    T = np.eye(4)
    if model.chain.base == "free":
        T[:3, :3] = model.base_chart
    return T


def with_base_block(fdat: np.ndarray, T: np.ndarray) -> np.ndarray:
    """A copy of a packed fdat (F,) whose base transform is T (4, 4) (base_block)."""
    out = fdat.copy()
    out[_F_BASE:_F_BASE + 16] = np.ravel(T)
    return out


def _tree_tables(model):
    """The tree tables of the kernel (kernel.layout._tree_tables) and the extra twist entries:
    (tables (I,) int64, NE, first (n,), slot (n,)): a link p with r > 1 children has its deltas'
    twists on children 2 .. r as extra entries e = first[p] + (j - 1) m_p + k (anchor: child j),
    and slot[i] = layout's r of link i (the twists of its parent's deltas acting on it)."""
    chain = model.chain
    n, N = model.n_links, model.n_dof
    par = list(chain.parents) + [n - 1]
    anc = np.zeros((n + 1, n + 1), dtype=np.int64)
    for b in range(n + 1):
        a = b
        while a >= 0:
            anc[a, b] = 1
            a = par[a]
    anchors, first, slot = [], np.full(n, -1), np.zeros(n, dtype=np.int64)
    for p, kids in enumerate(chain.children):
        m, d0 = model.delta_index[p].size, (model.delta_index[p][0] if model.delta_index[p].size else 0)
        if len(kids) > 1 and m:
            first[p] = len(anchors)
            for j, ch in enumerate(kids[1:]):
                slot[ch] = 2 * N + len(anchors) - d0
                anchors += [ch] * m
    leaves = [i for i in chain.free_tips if i != n - 1]
    tables = np.concatenate([par, anc.ravel(), anchors, [len(leaves)], leaves]).astype(np.int64)
    return tables, len(anchors), first, slot


def _first_frame(chain, p):
    """The first frame that link p's deltas move: its first child's, the tip frame n for the last
    link, and n for any other leaf too (a leaf's deltas move no frame: their twists stay zero)."""
    kids = chain.children[p]
    return kids[0] if kids else chain.n_links


def _tree_block(model, i):
    """fdat blocks of link i's joint (formulation §17): its constant rotation R (9) or None, and
    its attachment table on the parent [x_a, t(x_a) (3 m_p), phi(x_a) (3 m_p), H(x_a) (m_p m_p,
    a stiffened parent)] or None (the parent's tip: its end tables)."""
    chain = model.chain
    jt = chain.joints[i]
    R = getattr(jt, "axis_rotation", None) or getattr(jt, "rotation", None)
    rot = None if R is None else np.asarray(R, dtype=float).ravel()
    xa, p = chain.attach[i], chain.parents[i]
    if xa is None:
        return rot, None
    host = chain.links[p]
    t, phi = section_tables(host, xa)
    table = [[xa], t.ravel(), phi.ravel()]
    if host.stiffened:
        table.append(foreshortening_matrix(host, [xa])[0].ravel())
    return rot, np.concatenate(table)


def pack(model):
    """The model as (fdat float64 (F,), idat int64 (I,)) for the kernel (kernel/layout.py).

    idat: the header, the coordinate table ci (N, _CI), the link table li (n, _LI) and the tree
    tables; fdat: the base transform (16), gravity (4) and one block per link (_link_block).
    """
    idat, ci, li, first, slot = _int_tables(model)
    _base_coordinates(model, ci)
    f = [base_block(model).ravel(), np.append(model.gravity, 0.0)]
    off = _F_LINKS
    for i in range(model.n_links):
        block = _link_block(model, i, ci, li, off, first, slot)
        f += block
        off += sum(np.size(b) for b in block)
    _second_twists(model, ci)
    fdat = np.ascontiguousarray(np.concatenate([np.ravel(np.asarray(b, dtype=float)) for b in f]))
    assert fdat.size == off
    return fdat, np.ascontiguousarray(idat)


def _int_tables(model):
    """(idat (I,), its views ci (N, _CI) and li (n, _LI), first (n,), slot (n,)): idat with its header
    (n, N, base kind, extra tips, the variant's two flags, offsets) and tree tables written, ci's
    unset entries -1 (_tree_tables for first and slot)."""
    n, N = model.n_links, model.n_dof
    chain = model.chain
    free = model.free_base
    tables, NE, first, slot = _tree_tables(model)
    idat = np.zeros(_H + _CI * N + _LI * n + tables.size, dtype=np.int64)
    idat[0], idat[1] = n, N
    idat[2] = BASE_FIXED if not free else (BASE_PLANAR if chain.base == "planar" else BASE_FREE)
    idat[3] = len(model.extra_tips)
    idat[4] = int(any(jt.spec.prismatic for jt in chain.joints))  # the kernel variant (variant())
    # a link end moved by its modes, or a child attached along a flexible parent
    idat[5] = int(any(not ld.end_is_rigid for ld in model.link_data)
                  or any(a is not None and model.delta_index[p].size for a, p in zip(chain.attach, chain.parents)))
    idat[6], idat[7] = _H + _CI * N + _LI * n, NE
    idat[idat[6]:] = tables
    ci = idat[_H:_H + _CI * N].reshape(N, _CI)
    li = idat[_H + _CI * N:idat[6]].reshape(n, _LI) if n else np.zeros((0, _LI), dtype=np.int64)
    ci[:, 3] = -1
    ci[:, 5] = -1
    ci[:, 6] = -1
    return idat, ci, li, first, slot


def _base_coordinates(model, ci):
    """ci rows of the floating base's coordinates: X1 X2 (X3) translations, theta_-1, theta_0 rotations."""
    if model.free_base and model.chain.base == "planar":
        for a in range(2):
            ci[a, :3] = (KIND_TRANSLATION, a, 0)
    elif model.free_base:
        for a in range(3):
            ci[a, :3] = (KIND_TRANSLATION, a, 0)
        ci[3, :3] = (KIND_ROTATION, 0, 0)
        ci[4, :3] = (KIND_ROTATION, 1, 0)


_AXIS = {"y": 1, "z": 2}


def _link_block(model, i, ci, li, off, first, slot) -> list:
    """Link i's fdat block (a list of arrays, at offset ``off``), with its rows of ci (its joint
    variable and deltas) and li written."""
    chain = model.chain
    ld, lk, jt = model.link_data[i], chain.links[i], chain.joints[i]
    th, idx = model.theta_index[i], model.delta_index[i]
    m = idx.size
    jk = jt.spec.kernel_code
    if jk == JOINT_R:
        ci[th, :3] = (KIND_ROTATION, 2, i)
    elif jk == JOINT_PA:
        ci[th, :3] = (KIND_PA, 0, i)
    elif jk == JOINT_PB:
        # d_i moves frames i.. by a translation and deforms link i (its own shape chi, slot m).
        ci[th, :6] = (KIND_PB, 1, i, i, m, -1)
    for l, c in enumerate(idx):
        ci[c, :6] = (KIND_MODE, _AXIS[ld.directions[l]], _first_frame(chain, i), i, l, -1)
        if first[i] >= 0:
            ci[c, 6:] = (first[i] + l, len(chain.children[i]) - 1)
    # A moving end always takes the Rodrigues path (exact at phi = 0: R = I, dR[u] = a skew(u)).
    end = END_RIGID if ld.end_is_rigid else END_GENERAL
    li[i] = (m, idx[0] if m else 0, th, off, end, jk, -1, -1, -1, slot[i])
    block = _link_constants(ld, lk, jt)
    if jk == JOINT_PB:
        block += _pb_tables(lk)
    if lk.stiffened:
        li[i, 6] = off + sum(np.size(b) for b in block)
        block += _fs_tables(lk, model.quadrature)
    for field, table in zip((7, 8), _tree_block(model, i)):
        if table is not None:
            li[i, field] = off + sum(np.size(b) for b in block)
            block.append(table)
    return block


def _link_constants(ld, lk, jt) -> list:
    """The fixed part of a link's fdat block: pseudo-inertia P0 (16), m_r0 (4), l, the modal tables
    cx, c1 (m), M_psi (m m), K (m m), end tables t, phi, and the joint's [gamma, c, n_e, mu, EI]."""
    m = ld.K.shape[0]
    P0 = np.array(ld.P0, dtype=float)
    J = ld.J_body
    # Rotary inertia as a pseudo-inertia: Sigma = tr(J)/2 I - J (module docstring, item 5).
    P0[:3, :3] += 0.5 * np.trace(J) * np.eye(3) - J
    axes = np.array([_AXIS[d] for d in ld.directions], dtype=int)
    cx = ld.C[np.arange(m), 0, axes] if m else np.zeros(0)
    c1 = ld.C[np.arange(m), 3, axes] if m else np.zeros(0)
    Mpsi = ld.D[np.arange(m)[:, None], np.arange(m)[None, :], axes[:, None], axes[None, :]] if m else np.zeros((0, 0))
    mu = lk.mass_per_length if not callable(lk.mass_per_length) else 0.0
    ei = lk.EI_z if not callable(lk.EI_z) else 0.0
    joint = [getattr(jt, "angle", 0.0), getattr(jt, "half_length", 0.0), lk.elements, mu, ei]
    return [P0.ravel(), ld.m_r0, [ld.length], cx, c1, Mpsi.ravel(), np.asarray(ld.K).ravel(),
            np.asarray(ld.end_t).ravel(), np.asarray(ld.end_phi).ravel(), joint]


def _second_twists(model, ci):
    """ci[:, 5]: a second twist (B[ss + N + c]): the protruding length D of a flexible Pb link that
    carries a Pa carriage moves the carriage's frame i.. once more, through its deflection (_pa_step)."""
    joints = model.chain.joints
    for i, jt in enumerate(joints):
        if i > 0 and jt.spec.carriage and joints[i - 1].spec.guide and model.delta_index[i - 1].size:
            ci[model.theta_index[i - 1], 5] = i
