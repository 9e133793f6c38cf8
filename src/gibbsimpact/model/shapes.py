"""The links' shape functions and the model-only integrals over them (docs/theory.md §2, §4, §6).

* :func:`shape_functions` -- assumed modes or Hermite element functions of one link;
* :func:`link_deflection` -- v, w of link i in a state q (also behind a Pb guide, §7.4);
* :func:`link_integrals` -- the modal integrals of one link (:class:`LinkData`), with the
  composite Gauss-Legendre rule of :func:`gauss_legendre`;
* :func:`foreshortening_matrix` -- H(x) of a stiffened link, u_f(x) = -1/2 delta^T H(x) delta;
  :func:`link_foreshortening` -- u_f and its delta-derivatives in a state q.
"""

from __future__ import annotations

import functools

from dataclasses import dataclass

import numpy as np

from .chain import Link
from .elements import element_quadrature, hermite_shape
from .modes import shape

#: Axis index in the link frame of each mode direction.
_AXIS = {"y": 1, "z": 2}


#: Default composite Gauss-Legendre rule for the modal integrals:
#: (panels, points per panel). tests/model/test_quadrature.py shows the error on M
#: is < 1e-12 relative for modes 1-4 with it.
DEFAULT_QUADRATURE = (16, 16)


def _as_function(v):
    return v if callable(v) else (lambda x, c=v: np.full_like(np.asarray(x, dtype=float), c))


def gauss_legendre(length: float, panels: int, points: int) -> tuple[np.ndarray, np.ndarray]:
    """Composite Gauss-Legendre nodes and weights on [0, length].

    Returns
    -------
    x, w : ndarray, shape (panels*points,)
    """
    t, wt = np.polynomial.legendre.leggauss(points)
    h = length / panels
    a = np.arange(panels)[:, None] * h
    x = (a + 0.5 * h * (t[None, :] + 1.0)).ravel()
    w = np.tile(0.5 * h * wt, panels)
    return x, w


@dataclass(frozen=True, eq=False)
class LinkData:
    """Model-only quantities of one link, all in the link frame.

    With ``r0(x) = (x, 0, 0, 1)`` and ``psihat_k(x) = (e_dir psi_k(x), 0)``
    (4-vectors), mu the mass per length:

    * ``P0 = int mu r0 r0^T dx`` (4, 4) [kg m^2 / kg m / kg]
    * ``C[k] = int mu r0 psihat_k^T dx`` (m, 4, 4)
    * ``D[k, l] = int mu psihat_k psihat_l^T dx`` (m, m, 4, 4)
    * ``m_r0 = int mu r0 dx`` (4,), ``m_psi[k] = int mu psihat_k dx`` (m, 4)
    * ``M_dd[k, l] = trace D[k, l]`` (m, m) [kg]: the modal mass block
    * ``K[k, l] = int EI psi_k'' psi_l'' dx`` (m, m) [N/m]
    * ``end_t[k]``: tip displacement per unit delta_k (3,); ``end_phi[k]``:
      tip rotation vector per unit delta_k (3,) = (0, -w', v') at x = l.
    * ``J_body = l diag(j_x, j_y, j_z)`` (3, 3) [kg m^2]
    * ``E0 = Trans(l, 0, 0)`` (4, 4): the end transform of the undeformed link
    """

    length: float
    mass: float
    P0: np.ndarray
    C: np.ndarray
    D: np.ndarray
    m_r0: np.ndarray
    m_psi: np.ndarray
    M_dd: np.ndarray
    K: np.ndarray
    end_t: np.ndarray
    end_phi: np.ndarray
    J_body: np.ndarray
    E0: np.ndarray

    @property
    def first_frequency(self) -> float:
        """omega_1 [rad/s], the lowest natural frequency of the link's elastic coordinates with the link
        clamped at its frame: sqrt of the smallest generalised eigenvalue of (K, M_dd); nan for a rigid link."""
        if self.K.size == 0:
            return float("nan")
        import scipy.linalg as sl

        return float(np.sqrt(sl.eigh(self.K, self.M_dd, eigvals_only=True).min()))
    has_rotary: bool
    end_is_rigid: bool
    directions: tuple = ()


def shape_functions(link: Link, x, derivative: int = 0) -> tuple[tuple, np.ndarray]:
    """The link's shape functions at abscissae x (K,) [m]: (directions (m,), psi (m, K)).

    Assumed modes or Hermite element functions in the order of the link's
    elastic coordinates; ``derivative`` 0 .. 2 gives the x-derivatives.
    """
    x = np.atleast_1d(np.asarray(x, dtype=float))
    l = link.length
    if link.elements:
        psi = hermite_shape(link.elements, l, x, derivative)
        return tuple(d for d in link.element_directions for _ in range(psi.shape[0])), \
            np.concatenate([psi] * len(link.element_directions))
    psi = np.array([shape(md, l, x, derivative) for md in link.modes]).reshape(len(link.modes), x.size)
    return tuple(md.direction for md in link.modes), psi


def link_deflection(model, q, i: int, x, derivative: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Deflection of link i (0-based) at material abscissae x (K,) [m]: (v (K,), w (K,)) [m].

    v along the link frame's y axis, w along z (docs/theory.md §2, §4, §7.4);
    ``derivative`` 0 .. 2 gives x-derivatives. A link behind a FixedPrismatic guide
    (protruding length d) bends only on sigma = x - (l - d) in [0, d]:
    v = sum_k d^(a_k) N_k(sigma / d) delta_k (stretching elements), 0 behind the guide.
    """
    q = np.asarray(q, dtype=float)
    x = np.atleast_1d(np.asarray(x, dtype=float))
    lk = model.chain.links[i]
    idx = model.delta_index[i]
    v, w = np.zeros(x.size), np.zeros(x.size)
    if len(idx) == 0:
        return v, w
    delta = q[idx]
    if model.chain.joints[i].spec.guide:
        d = q[model.theta_index[i]]
        sigma = x - (lk.length - d)
        inside = sigma >= 0.0
        N = hermite_shape(lk.elements, 1.0, np.clip(sigma / d, 0.0, 1.0), derivative)  # (m, K)
        a = np.tile([0.0, 1.0], lk.elements)
        # d/dx = (1/d) d/dxi
        v = np.where(inside, (d ** (a - derivative) * delta) @ N, 0.0)
        return v, w
    directions, psi = shape_functions(lk, x, derivative)
    for p_k, dk, s in zip(psi, delta, directions):
        if s == "y":
            v = v + p_k * dk
        else:
            w = w + p_k * dk
    return v, w


def line_quadrature(link: Link, quadrature: tuple[int, int] = DEFAULT_QUADRATURE) -> tuple[np.ndarray, np.ndarray]:
    """The link's quadrature rule on [0, l]: nodes x (G,) [m] and weights w (G,) [m]; composite
    Gauss-Legendre with ``quadrature`` = (panels, points), or for a finite-element link the rule
    aligned with its element nodes (elements.element_quadrature)."""
    return gauss_legendre(link.length, *(element_quadrature(link.elements) if link.elements else quadrature))


def foreshortening_matrix(link: Link, x) -> np.ndarray:
    """H (K, m, m) [1/m] of a link at abscissae x (K,) [m] (formulation §15):

        H_kl(x) = [dir_k = dir_l] int_0^x psi_k' psi_l' dxi,   u_f(x) = -1/2 delta^T H(x) delta

    (u_f [m] the axial displacement of an inextensible centreline, -1/2 int_0^x (v'^2 + w'^2)).
    H at the breaks b_j (element nodes, or 64 equal panels for assumed modes) summed piece by
    piece, plus the piece [b_j, x]; 8 Gauss-Legendre points a piece: exact for Hermite elements
    (psi_k' psi_l' has degree 4), relative error < 1e-13 for the first four modes.
    """
    x = np.atleast_1d(np.asarray(x, dtype=float))
    breaks, at_breaks, pieces = _foreshortening_table(link)
    j = np.clip(np.searchsorted(breaks, x, side="right") - 1, 0, breaks.size - 1)
    return at_breaks[j] + pieces(breaks[j], x)


@functools.lru_cache(maxsize=64)
def _foreshortening_table(link: Link):
    """The breaks b_j (B,) [m], H(b_j) (B, m, m) [1/m] and the piece integral of a link, cached per link:
    H at the breaks does not depend on the state, and the event loop asks for H(x*) at every
    right-hand side of a span contact phase (contact.closest_points, dynamics.link_points)."""
    breaks = np.linspace(0.0, link.length, (link.elements or 64) + 1)
    directions = np.array(shape_functions(link, [link.length])[0])
    same = np.equal.outer(directions, directions)
    t, wt = np.polynomial.legendre.leggauss(8)

    def pieces(a, b):  # int_a^b psi' psi'^T for each pair (a, b) (P,) -> (P, m, m)
        xs = a[:, None] + 0.5 * (b - a)[:, None] * (t[None, :] + 1.0)
        d1 = shape_functions(link, xs.ravel(), 1)[1].reshape(-1, *xs.shape)  # (m, P, 8)
        return np.einsum("kpg,lpg,pg->pkl", d1, d1, 0.5 * (b - a)[:, None] * wt[None, :]) * same

    at_breaks = np.concatenate([np.zeros((1,) + same.shape), np.cumsum(pieces(breaks[:-1], breaks[1:]), axis=0)])
    at_breaks.flags.writeable = False
    return breaks, at_breaks, pieces


def link_foreshortening(model, q, i: int, x) -> tuple[np.ndarray, np.ndarray]:
    """Axial displacement u_f (K,) [m] of link i (0-based) at abscissae x (K,) [m] and its
    derivatives du_f/d delta = -H(x) delta (K, m) (formulation §15); zeros for a link without
    geometric stiffening (then r = (x, v, w) as in the linear beam)."""
    x = np.atleast_1d(np.asarray(x, dtype=float))
    lk = model.chain.links[i]
    idx = model.delta_index[i]
    if not lk.stiffened:
        return np.zeros(x.size), np.zeros((x.size, idx.size))
    delta = np.asarray(q, dtype=float)[idx]
    eta = foreshortening_matrix(lk, x) @ delta
    return -0.5 * eta @ delta, -eta


def mass_points(link: Link, quadrature: tuple[int, int] = DEFAULT_QUADRATURE):
    """The link's mass as weighted points: x (G+2B,) [m], w mu (G+2B,) [kg], lever (G+2B,) [m].

    A point at section x with axial lever s lies at (x + s, 0, 0) in the undeformed link frame
    and moves with the section at x: its displacement per delta_k is
    e_(a_k) (psi_k(x) + s psi_k'(x)) (docs/theory.md §6.8). The line's points (the quadrature
    of :func:`line_quadrature`, weights w mu(x)) have s = 0. Each attached body (B of them)
    adds two points of mass m/2 at its section x_a with levers c_x +- a, a = sqrt(s_b / m),
    s_b = RigidBody.section_inertia: they carry its mass, its first moment along the axis and the
    bending inertia s_b that turns with the section; the rest of its pseudo-inertia is
    :func:`body_remainder`. Every link table that integrates over the mass (P0, C, D, m_r0,
    m_psi) sums over these points.
    """
    x, w = line_quadrature(link, quadrature)
    mu = np.asarray(_as_function(link.mass_per_length)(x), dtype=float) * np.ones_like(x)
    if np.any(~np.isfinite(mu)) or np.any(mu <= 0):
        raise ValueError("Link mass_per_length(x) must be positive and finite on [0, length]")
    xs, ms, levers = [x], [w * mu], [np.zeros_like(x)]
    for b in link.bodies:
        a = np.sqrt(b.section_inertia / b.mass)
        xs.append(np.full(2, b.at))
        ms.append(np.full(2, 0.5 * b.mass))
        levers.append(b.center[0] + np.array([a, -a]))
    return np.concatenate(xs), np.concatenate(ms), np.concatenate(levers)


def body_remainder(link: Link) -> tuple[np.ndarray, np.ndarray]:
    """What the attached bodies add to P0 (4, 4) [kg m^2, kg m, kg] and m_r0 (4,) [kg m] beyond
    their points in :func:`mass_points`: with c = (c_x, c_y, c_z), X = x_a + c_x,
    Sigma = tr(J)/2 I - J, the body's pseudo-inertia about the link frame is
    P_b = m (X, c_y, c_z, 1)(X, c_y, c_z, 1)^T + [[Sigma, 0], [0, 0]]; its points carry
    m (X, 0, 0, 1)(X, 0, 0, 1)^T + s_b e_x e_x^T (mass_points). The rest is constant in delta: the
    lateral offset (on a flexible link c_y = c_z = 0) and Sigma - s_b e_x e_x^T, the pseudo-inertia
    of the rotary inertia J - s_b (I - e_x e_x^T) that keeps the link frame's orientation.
    """
    P, m_r = np.zeros((4, 4)), np.zeros(4)
    for b in link.bodies:
        rc = np.array([b.at + b.center[0], b.center[1], b.center[2], 1.0])
        on_axis = rc * np.array([1.0, 0.0, 0.0, 1.0])
        P += b.mass * (np.outer(rc, rc) - np.outer(on_axis, on_axis))
        S = b.second_moments
        S[0, 0] -= b.section_inertia
        P[:3, :3] += S
        m_r += b.mass * (rc - on_axis)
    return P, m_r


def _stiffness(link: Link, quadrature, directions) -> np.ndarray:
    """K[k, l] = int EI psi_k'' psi_l'' dx (m, m) [N/m], over the link's line quadrature."""
    x, w = line_quadrature(link, quadrature)
    EI_fun = {"y": _as_function(link.EI_z), "z": _as_function(link.EI_y)}
    psi2 = shape_functions(link, x, 2)[1]
    m = len(directions)
    K = np.zeros((m, m))
    for d in set(directions):
        ei = np.asarray(EI_fun[d](x), dtype=float) * np.ones_like(x)
        if np.any(~np.isfinite(ei)) or np.any(ei <= 0):
            raise ValueError("Link EI(x) must be positive and finite on [0, length]")
        sel = np.array([dk == d for dk in directions])
        K[np.ix_(sel, sel)] = (psi2[sel] * (w * ei)) @ psi2[sel].T
    return K


def section_tables(link: Link, x: float) -> tuple[np.ndarray, np.ndarray]:
    """The section of a link at abscissa x [m] per unit coordinate: t (m, 3), the displacement
    (0, v, w)(x) [m per unit delta_k], and phi (m, 3), the rotation vector (theta_x, -w'(x), v'(x))
    [rad per unit delta_k] (formulation §2 at x = l: end_t, end_phi; §17: A_p(x_a) of a tree).
    Values below 1e-12 (t) and 1e-12 / l (phi) are exact zeros: clamped-clamped and pinned-pinned
    shapes vanish at x = l to round-off, so that the tip transform is constant."""
    l = link.length
    directions = shape_functions(link, [x], 0)[0]
    v = shape_functions(link, [x], 0)[1][:, 0]
    dv = shape_functions(link, [x], 1)[1][:, 0]
    m = len(directions)
    t = np.zeros((m, 3))
    phi = np.zeros((m, 3))
    for k, direction in enumerate(directions):
        t[k, _AXIS[direction]] = v[k]
        if direction == "y":
            phi[k, 2] = dv[k]
        else:
            phi[k, 1] = -dv[k]
    t[np.abs(t) < 1e-12] = 0.0
    phi[np.abs(phi) < 1e-12 / l] = 0.0
    return t, phi


def link_integrals(link: Link, quadrature: tuple[int, int] = DEFAULT_QUADRATURE) -> LinkData:
    """Precompute the modal integrals of ``link`` (:class:`LinkData`) over its mass points.

    The sums run over :func:`mass_points` (the line quadrature and the attached bodies), with
    position X = x + s and shape Psi_k = psi_k(x) + s psi_k'(x) at each point; the bodies'
    off-axis parts add :func:`body_remainder`. A finite-element link uses a rule aligned with
    its element nodes (elements.element_quadrature) instead of ``quadrature``.
    """
    l = link.length
    x, wm, lever = mass_points(link, quadrature)
    directions, psi = shape_functions(link, x, 0)
    directions = list(directions)
    psi = psi + lever * shape_functions(link, x, 1)[1]
    x = x + lever
    K = _stiffness(link, quadrature, directions)
    m = len(directions)
    axes = [_AXIS[d] for d in directions]
    P_b, m_rb = body_remainder(link)

    mass = wm.sum()
    s1 = wm @ x
    s2 = wm @ (x * x)
    P0 = np.zeros((4, 4))
    P0[0, 0], P0[0, 3], P0[3, 0], P0[3, 3] = s2, s1, s1, mass
    P0 += P_b
    m_r0 = np.array([s1, 0.0, 0.0, mass]) + m_rb

    C = np.zeros((m, 4, 4))
    m_psi = np.zeros((m, 4))
    D = np.zeros((m, m, 4, 4))
    int_psi = psi @ wm
    int_xpsi = psi @ (wm * x)
    int_psipsi = (psi * wm) @ psi.T
    ax = np.array(axes, dtype=int)
    km = np.arange(m)
    C[km, 0, ax] = int_xpsi
    C[km, 3, ax] = int_psi
    m_psi[km, ax] = int_psi
    D[km[:, None], km[None, :], ax[:, None], ax[None, :]] = int_psipsi
    M_dd = np.einsum("klaa->kl", D)

    end_t, end_phi = section_tables(link, l)
    J_body = l * np.diag(link.rotary_inertia)
    E0 = np.eye(4)
    E0[0, 3] = l
    arrays = dict(P0=P0, C=C, D=D, m_r0=m_r0, m_psi=m_psi, M_dd=M_dd, K=K, end_t=end_t, end_phi=end_phi,
                  J_body=J_body, E0=E0)
    for a in arrays.values():
        a.setflags(write=False)
    return LinkData(
        length=l,
        mass=float(mass),
        has_rotary=bool(np.any(J_body)),
        # a foreshortening link's end moves along its axis (u_f(l) != 0 when bent)
        end_is_rigid=not (np.any(end_t) or np.any(end_phi) or link.stiffened),
        directions=tuple(directions),
        **arrays,
    )
