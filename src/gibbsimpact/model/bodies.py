"""Rigid bodies attached to links: payloads at a tip, motor/hub inertias at a joint (docs/theory.md §6.8).

A :class:`RigidBody` sits at the abscissa ``at`` of its link, with its centre at the offset c from
the centreline point. It moves with the deflected centreline point at x_a and turns with the
section's linearised rotation phi = (0, -w'(x_a), v'(x_a)) (the tip-body model of the beam
literature), in the form that the link tables hold exactly (every material point linear in delta,
each elastic coordinate moving it along one axis):

* its mass m and the part s = min(J_yy, J_zz) of its bending inertia are two points of mass m/2 on
  the link axis, at the levers lambda = c_x +- sqrt(s/m) from the section, moved by
  e_(a_k) (psi_k(x_a) + lambda psi_k'(x_a)): they turn with the section;
* the rest, the rotary inertia J - s (I - e_x e_x^T) (positive semidefinite) and the lateral
  offset (c_y, c_z), keeps the link frame's orientation, like the links' own rotary inertia.

So the body's bending inertia turns with the section exactly when J_yy = J_zz (any body symmetric
about the link axis: a sphere, a cylinder or disc on the axis, an axial rod) and, for in-plane
bending, whenever J_yy >= J_zz. On a flexible link the body must sit on the link axis
(c_y = c_z = 0) with the link axis a principal axis (J_xy = J_xz = 0); on a rigid link any body
is exact.
"""

from __future__ import annotations

from dataclasses import dataclass
from numbers import Real

import numpy as np

from .arguments import items_of


def _vector3(name: str, value) -> tuple:
    v = np.asarray(value, dtype=float) if not isinstance(value, str) else None
    if v is None or v.shape != (3,) or not np.all(np.isfinite(v)):
        raise ValueError(f"RigidBody {name}={value!r} must be three finite numbers (x, y, z) in the link frame")
    return tuple(float(a) for a in v)


def _inertia_matrix(value) -> tuple:
    """The inertia tensor J (3, 3) [kg m^2] from 3 principal values or a 3x3 matrix, checked."""
    J = np.asarray(value, dtype=float) if not isinstance(value, str) else np.zeros(0)
    if J.shape == (3,):
        J = np.diag(J)
    if J.shape != (3, 3) or not np.all(np.isfinite(J)):
        raise ValueError(f"RigidBody inertia={value!r} must be 3 principal values (J_xx, J_yy, J_zz) or a "
                         "symmetric 3x3 matrix in kg m^2 about the body's centre, in link-frame axes")
    scale = max(np.abs(J).max(), 1e-300)
    if np.abs(J - J.T).max() > 1e-12 * scale:
        raise ValueError(f"RigidBody inertia={value!r} is not symmetric; give J = J^T")
    J = 0.5 * (J + J.T)
    # A mass distribution has second moments Sigma = tr(J)/2 I - J >= 0: the principal values of J
    # are >= 0 and obey the triangle inequality J_1 <= J_2 + J_3.
    sigma = np.linalg.eigvalsh(0.5 * np.trace(J) * np.eye(3) - J)
    if sigma.min() < -1e-12 * scale:
        raise ValueError(f"RigidBody inertia={value!r} is not the inertia of a mass distribution: its principal "
                         "values must be >= 0 and each at most the sum of the other two (triangle inequality)")
    return tuple(tuple(float(a) for a in row) for row in J)


@dataclass(frozen=True)
class RigidBody:
    """A rigid body attached to a link: a payload, or a motor/hub inertia at the joint.

    It adds to its link's tables (module docstring, docs/theory.md §6.8) the pseudo-inertia
    P_b = m r_c r_c^T + [[Sigma, 0], [0, 0]], r_c = (x_a + c, 1), Sigma = tr(J)/2 I - J.

    Parameters
    ----------
    mass : float
        m [kg], > 0.
    center : (float, float, float)
        c [m], offset of the body's centre of mass from the centreline point at ``at``, in
        link-frame axes (x along the link). On a flexible link only c_x may be non-zero.
    inertia : (3,) or (3, 3)
        J [kg m^2] about the body's centre, in link-frame axes: principal values
        (J_xx, J_yy, J_zz) or a symmetric matrix; positive semidefinite with the triangle
        inequality. Default 0: a point mass. On a flexible link J_xy = J_xz = 0.
    at : float or None
        x_a [m], the abscissa on the link in [0, l]: None (default) is the tip x_a = l,
        0 the joint (a hub).
    """

    mass: float
    center: tuple = (0.0, 0.0, 0.0)
    inertia: tuple = (0.0, 0.0, 0.0)
    at: float | None = None

    def __post_init__(self):
        m = self.mass
        if isinstance(m, bool) or not isinstance(m, Real) or not np.isfinite(m) or m <= 0:
            raise ValueError(f"RigidBody mass={m!r} must be a positive number of kilograms")
        object.__setattr__(self, "mass", float(m))
        object.__setattr__(self, "center", _vector3("center", self.center))
        object.__setattr__(self, "inertia", _inertia_matrix(self.inertia))
        a = self.at
        if a is not None and (isinstance(a, bool) or not isinstance(a, Real) or not np.isfinite(a) or a < 0):
            raise ValueError(f"RigidBody at={a!r} must be None (the tip) or an abscissa >= 0 in metres on the link")
        object.__setattr__(self, "at", None if a is None else float(a))

    @property
    def section_inertia(self) -> float:
        """s = min(J_yy, J_zz) [kg m^2], the part of the bending inertia that turns with the section
        (module docstring): two axial points of mass m/2 at +-sqrt(s/m) from the centre carry it."""
        return float(min(self.inertia[1][1], self.inertia[2][2]))

    @property
    def second_moments(self) -> np.ndarray:
        """Sigma = int rho rho^T dm = tr(J)/2 I - J (3, 3) [kg m^2] about the body's centre."""
        J = np.array(self.inertia)
        return 0.5 * np.trace(J) * np.eye(3) - J


def check_bodies(bodies, length: float, flexible: bool) -> tuple:
    """The Link's ``bodies`` as a tuple of RigidBody with ``at`` resolved (None -> the tip l [m]);
    raises ValueError naming the entry and the fix."""
    out = []
    for k, b in enumerate(items_of(bodies, RigidBody, "Link bodies", "; build it as RigidBody(mass=...)")):
        at = length if b.at is None else b.at
        if at > length * (1 + 1e-12):
            raise ValueError(f"Link bodies[{k}] at={at!r} is beyond the link's length {length:g} m; give 0 <= at <= l "
                             "(None: the tip)")
        J = np.array(b.inertia)
        if flexible and (b.center[1] != 0.0 or b.center[2] != 0.0 or J[0, 1] != 0.0 or J[0, 2] != 0.0):
            raise ValueError(
                f"Link bodies[{k}] on a flexible link has center={b.center!r}, inertia={b.inertia!r}: a body on a bending "
                "link must sit on the link axis (center=(c_x, 0, 0)) with the link axis as a principal axis "
                "(J_xy = J_xz = 0), docs/theory.md §6.8; put it on a rigid link for a lateral offset")
        out.append(RigidBody(b.mass, b.center, b.inertia, min(at, length)))
    return tuple(out)
