"""The kernel's data layout: fdat/idat of a packed model, kind codes, JOB bits, output sections.

One float64 array (fdat) and one int64 array (idat) per model, so that a call passes few
arguments (numba's dispatch cost grows with their number); ``gibbsimpact.model.packing.pack``
writes them with the constants below. ``layout`` and ``contact_layout`` give the offsets of the
sections of the entry points' outputs.
"""

from __future__ import annotations

import numpy as np

# -- data layout --------------------------------------------------------------
# idat: [n, N, base kind, X, prismatic (0/1), general ends (0/1), offset of the tree tables, NE]
#       + per coordinate (N rows of _CI ints) + per link (n rows of _LI ints) + the tree tables
#       (X: extra contact points, the tips of host links whose child joint is prismatic, then the
#       tips of the leaves but the last link; NE: extra twist entries, _tree_tables)
_H = 8
# kind, axis, first frame, own link (-1), local index, first frame of a second twist (-1),
# first extra twist entry (-1), number of extra twist entries (their stride: the own link's m)
_CI = 8
# m, first delta index in q, joint variable index in q (-1: a weld), offset in fdat, end kind,
# joint kind, offset in fdat of the foreshortening tables (-1: a linear beam; model/packing._fs_tables),
# offset in fdat of the joint's constant rotation (9, row-major; -1: none), offset in fdat of the
# attachment table on the parent (-1: the parent's tip; [x_a, t (3 m_p), phi (3 m_p), H(x_a) (m_p m_p,
# a stiffened parent)]), r: the twists of the parent's deltas acting on this link are B[SS + r + c]
# (c their index in q; r = 0 for the parent's first child, 2 N + e - c_0 for an extra twist entry e)
_LI = 10
KIND_TRANSLATION, KIND_ROTATION, KIND_MODE, KIND_PA, KIND_PB = 0, 1, 2, 3, 4
END_RIGID, END_GENERAL = 0, 2  # a link end fixed to its frame, or moved by its modes
JOINT_R, JOINT_PA, JOINT_PB, JOINT_WELD = 0, 1, 2, 3
BASE_FIXED, BASE_FREE, BASE_PLANAR = 0, 1, 2
# fdat: base T0 (16), g~ (4), then per link: P0+Sigma (16), m_r0 (4), length,
#       cx (m), c1 (m), Mpsi (m*m), K (m*m), end_t (3m), end_phi (3m),
#       gamma, c, n_e, mu, EI (_F_JOINT values: the joint and the constants of a Pb link),
#       and for a Pb link its unit-interval tables (_pb_moments): xi (G), w (G),
#       N (G m), N' (G m), N'' (G m), Kunit (m m), a (m), G = 4 n_e Gauss points;
#       for a stiffened link its foreshortening tables (packing._fs_tables, moments._fs_moments).
_F_BASE, _F_G, _F_LINKS = 0, 16, 20
_F_JOINT = 5
_GAUSS = 4  # Gauss-Legendre points per (stretching) element: exact for degree <= 7


def inline(f):
    """Mark a kernel helper that numba compiles as part of its caller (compile.py: an
    ``njit(inline="always")`` dispatcher, inlined before typing), as if its code were written there.

    For the parts a long kernel function is split into for reading, one item of the derivation
    each, where they take arrays: a separately compiled helper that takes arrays costs ~0.1-0.4 s
    of compile time (more for every layer above it, which re-optimises it) and a reference count
    per array and call. Inlining keeps the branches on ``pris is None``, ``ends is None`` removed
    (a helper registered with ``register_jitable(inline="always")`` would keep them). Not for a
    helper called in an inner loop: the inlined copy still counts a reference per array argument
    and call (measured: the mass-matrix entry as an inlined helper, 0.65 us more per
    forward_dynamics on case 1), nor for small helpers of integers only (work_slots), which are
    cheaper compiled once. As plain Python (NUMBA_DISABLE_JIT=1) the function runs as it is.
    """
    f.kernel_inline = True
    return f


# -- work arrays of a kernel call ------------------------------------------------------
# Every 4x4 matrix of a call lives in one array B (k, 4, 4) and every 4-vector in one array V
# (k, 4), each named by its index k (mat4.py). Work slots relative to w (the running frame of
# chain_frames): w T, w+1 Td, w+2 Tdd0, then the scratch of _end_step and _pa_step
# (w+3 .. w+19), and of the later stages (w+20 .. w+23).
_W_SIZE = 24


def _tree_tables(idat):
    """Offset in idat of the tree tables (formulation §17), n1 = n + 1 frames (link frames 0 .. n-1,
    frame n the last link's tip): parent frame par[j] (n1; -1 on the base), ancestor table
    anc[a, b] (n1 n1; 1 when frame a is b or an ancestor of b), the anchor frame of each extra
    twist entry (NE), the number L of leaf tips among the contact points and their links (L)."""
    return idat[6]


def _anc(idat, a, b):
    """True when frame a is frame b or one of its ancestors (_tree_tables): a coordinate whose
    twist acts from frame a moves frame b. On a serial chain, a <= b."""
    n1 = idat[0] + 1
    return idat[idat[6] + n1 + n1 * a + b] != 0


def _piece(idat, N, c, k):
    """(slot, start frame) of piece k of coordinate c's twist, or (-1, -1) where it has none:
    k = 0 its twist S_c (B[SS + slot]) from its first frame f_c, k = 1 its second twist S2_c from
    f2_c (item 7), k >= 2 its extra twist entries (a parent's delta acting on its second, third ..
    child, formulation §17; _tree_tables). Slots relative to SS."""
    b = _H + _CI * c
    if k == 0:
        return c, idat[b + 2]
    if k == 1:
        return (N + c, idat[b + 5]) if idat[b + 5] >= 0 else (-1, -1)
    if k - 2 >= idat[b + 7]:
        return -1, -1
    e = idat[b + 6] + (k - 2) * idat[_H + _CI * N + _LI * idat[b + 3]]
    return 2 * N + e, idat[_tree_tables(idat) + (idat[0] + 1) * (idat[0] + 2) + e]


def work_slots(n, N, mmax, ne=0):
    """Offsets of a kernel call's work arrays for n links, N coordinates, at most mmax own
    modes a link and ne extra twist entries: (TS, TDS, TDDS, SS, WK, PS, PVS, PIC, FC, XS, MR, MRD,
    QV, QDV, MUC, YY, EE).

    B (k, 4, 4): T, Td, Tdd0 of frames 0 .. n (n + 1 each, from TS, TDS, TDDS), twists S_c then
    second twists S2_c (2 N, from SS), then the extra twist entries (ne: a parent's delta acting on
    its second, third .. child, _tree_tables), _W_SIZE work slots (from WK): what frames, points and
    Jacobians need; then the body moments P, Pv (n + 1 each, from PS, PVS): what energies and
    momenta need too; then the composites Pi^c, F^c (n + 1 each) and X_d (N, from XS): what M, h
    and dV need too. V (k, 4): m_r and mdot_r (n + 1 each), q_l and qd_l (mmax + 1 a link each,
    from QV, QDV), then the composites mu^c (n + 1) and y_c, e_c (N each). work_sizes gives k.
    """
    n1 = n + 1
    SS = 3 * n1
    WK = SS + 2 * N + ne
    PS = WK + _W_SIZE
    PIC = PS + 2 * n1
    QV = 2 * n1
    QDV = QV + (mmax + 1) * n
    MUC = QDV + (mmax + 1) * n
    return (0, n1, 2 * n1, SS, WK, PS, PS + n1, PIC, PIC + n1, PIC + 2 * n1, 0, n1, QV, QDV, MUC, MUC + n1,
            MUC + n1 + N)


def work_sizes(ws, N, moments, dynamics):
    """(rows of B, rows of V) of work_slots ws: frames only, with the body moments (moments), or
    with the composites too (dynamics)."""
    TS, TDS, TDDS, SS, WK, PS, PVS, PIC, FC, XS, MR, MRD, QV, QDV, MUC, YY, EE = ws
    if dynamics:
        return XS + N, EE + N
    if moments:
        return PIC, MUC
    return PS, 0


def _joint_field(fdat, idat, link, k):
    """Entry k of link ``link``'s _F_JOINT values: 0 gamma [rad], 1 c [m], 2 n_e, 3 mu [kg/m], 4 EI [N m^2]."""
    base = _H + _CI * idat[1] + _LI * link
    m = idat[base]
    return fdat[idat[base + 3] + 21 + 8 * m + 2 * m * m + k]


def _mmax(idat):
    n = idat[0]
    N = idat[1]
    mmax = 0
    for i in range(n):
        mmax = max(mmax, idat[_H + _CI * N + _LI * i])
    return mmax


# Bits of ``job`` in ``kernel``.
JOB_M, JOB_H, JOB_SOLVE, JOB_ENERGY, JOB_MOMENTUM, JOB_POINTS, JOB_JACOBIANS, JOB_FRAMES = 1, 2, 4, 8, 16, 32, 64, 128
#: q̈ only: alone, the whole output is q̈ (N,) (forward_dynamics returns it as it is; a slice of
#: a larger output costs ~0.3 us a call). Its status is the return value.
JOB_QDDOT = 256
#: Check the states first: a non-finite entry of qs or qds makes the kernel return -2.0 and write
#: nothing (the documented entry points' validation, at the cost of a loop over 2 K N numbers; the
#: solver's right-hand side leaves it out: its trial states may be non-finite, and their NaN
#: accelerations make it shrink the step). It adds no output section.
JOB_FINITE = 512


# Sections of ``kernel``'s output, in order (``layout`` gives their offsets).
SECTIONS = ("status", "ydot", "M", "h", "dV", "energy", "momentum", "points", "jacobians", "frames")
_S_STATUS, _S_YDOT, _S_M, _S_H, _S_DV, _S_EN, _S_MO, _S_PTS, _S_JAC, _S_FR = range(10)


def layout(n, N, K, job, npts):
    """Start offsets (11,) of the sections of ``kernel``'s output (SECTIONS), then its length;
    npts contact points (n + 1 frame origins and the extra tips)."""
    hv = (job & JOB_H) != 0
    off = np.zeros(11, dtype=np.int64)
    # status: always but for JOB_QDDOT alone; ydot: (qdot, qddot) with JOB_SOLVE, else qddot with JOB_QDDOT
    off[_S_STATUS + 1] = 0 if (job & ~JOB_FINITE) == JOB_QDDOT else 3
    off[_S_YDOT + 1] = 2 * N if job & JOB_SOLVE else (N if job & JOB_QDDOT else 0)
    off[_S_M + 1] = N * N if job & JOB_M else 0
    off[_S_H + 1] = N if hv else 0
    off[_S_DV + 1] = N if hv else 0
    off[_S_EN + 1] = 3 * K if job & JOB_ENERGY else 0
    off[_S_MO + 1] = 9 * K if job & JOB_MOMENTUM else 0
    off[_S_PTS + 1] = 3 * npts * K if job & JOB_POINTS else 0
    off[_S_JAC + 1] = 3 * npts * N * K if job & JOB_JACOBIANS else 0
    off[_S_FR + 1] = 48 * (n + 1) * K if job & JOB_FRAMES else 0
    for i in range(10):  # sizes -> offsets
        off[i + 1] += off[i]
    return off


#: Wall kinds of contact_terms (walls.py: Plane, Circle, Sphere; Wall.packed()).
WALL_PLANE, WALL_CIRCLE, WALL_SPHERE = 0, 1, 2


def contact_layout(N, k):
    """Offsets (12,) of contact_terms' output sections W, M^-1 W, G, c, g, v, n, pd, a0, lambda,
    qddot for N coordinates and k pairs, and its size (after the status entry at 0)."""
    o = np.zeros(12, dtype=np.int64)
    sizes = (N * k, N * k, k * k, k, k, k, 3 * k, 3 * k, 3 * k, k, N)
    o[0] = 1
    for i in range(11):
        o[i + 1] = o[i] + sizes[i]
    return o
