"""The immutable model: a chain, gravity, the coordinates q and the precomputed link data.

Everything that depends only on the model (modal integrals, stiffness
matrices, end values of the mode shapes) is computed once here, when the Model
is built (link_integrals, model/shapes.py), so the dynamics kernel
(:mod:`gibbsimpact.dynamics`) only does q-dependent work. The links and the
chain are model/chain.py, the joints model/joints.py.

Coordinates (docs/theory.md §1), in this order::

    q = [X1, X2, X3, theta_-1, theta_0, theta_1 ... theta_n,
         delta_1,1 ... delta_1,m1, ..., delta_n,1 ... delta_n,mn]
"""

from __future__ import annotations

import functools
import re
from math import isfinite
from typing import Sequence

import numpy as np

from ..kernel import compiled, output, variant
from .chain import Chain, Link
from .joints import JOINT_TYPES, FixedBase, FixedPrismatic, Revolute, SlidingPrismatic, Weld
from .packing import base_block, pack, with_base_block
from .shapes import DEFAULT_QUADRATURE, LinkData, gauss_legendre, link_deflection, link_integrals, shape_functions

# Link, the joints and the shape functions lived in this module before it was split (joints.py,
# chain.py, shapes.py); imports of them from gibbsimpact.model.model keep working.
__all__ = [
    "DEFAULT_QUADRATURE", "Link", "Revolute", "FixedBase", "SlidingPrismatic", "FixedPrismatic", "Weld", "JOINT_TYPES",
    "Chain", "gauss_legendre", "LinkData", "shape_functions", "link_deflection", "link_integrals", "Model",
]


_F64 = np.dtype(np.float64)
_EYE3 = np.eye(3)
_EYE3.setflags(write=False)


@functools.cache
def _dynamics():
    """gibbsimpact.dynamics.gibbs_appell, for the alias methods of Model (Model.mass_matrix calls
    dynamics.mass_matrix, ...); imported at their first use, since dynamics comes after model in
    the stage order (docs/architecture.md)."""
    from ..dynamics import gibbs_appell

    return gibbs_appell


@functools.cache
def _kinematics():
    """gibbsimpact.dynamics.kinematics, for Model.joint_positions and joint_jacobians (as _dynamics)."""
    from ..dynamics import kinematics

    return kinematics


class Model:
    """Immutable simulation model: a chain, gravity and precomputed link data.

    Parameters
    ----------
    chain : Chain
    gravity : (3,) array_like
        Gravitational acceleration in the inertial frame [m/s^2].
    quadrature : (int, int)
        Composite Gauss-Legendre rule (panels, points) for the modal integrals.

    Attributes
    ----------
    n_dof : int
        N = 3 + (n + 2) + sum m_i (free base), 2 + n + sum m_i (planar base),
        n + sum m_i (fixed base).
    coordinate_names : tuple of str, length N
        ``X1 X2 X3 theta_-1 theta_0 theta_1 ... theta_n delta_1_1 ...`` (free base),
        ``X1 X2 j_1 ... j_n delta_1_1 ...`` (planar base), ``j_1 ... j_n delta_1_1 ...``
        (fixed base), with j_i = ``theta_i`` (revolute) or ``d_i`` (prismatic); a weld has none
        (formulation §17: joint variables in link order, welds skipped, then each link's deltas).
    """

    def __init__(self, chain: Chain, gravity: Sequence[float] = (0.0, -9.81, 0.0), quadrature=DEFAULT_QUADRATURE):
        if isinstance(chain, (list, tuple)):
            chain = Chain(chain)
        if not isinstance(chain, Chain):
            raise ValueError(f"Model chain={chain!r} must be a gibbsimpact.Chain")
        g = np.asarray(gravity, dtype=float) if not isinstance(gravity, str) else np.array([])
        if g.shape != (3,) or not np.all(np.isfinite(g)):
            raise ValueError(f"Model gravity={gravity!r} must be three finite numbers (m/s^2), e.g. (0, -9.81, 0)")
        self._chain = chain
        self._quadrature = (int(quadrature[0]), int(quadrature[1]))
        self._gravity = g
        g.setflags(write=False)
        self._links = tuple(link_integrals(lk, quadrature) for lk in chain.links)
        # Free base: q = [X1, X2, X3, theta_-1, theta_0, theta_1 .. theta_n, deltas]; planar base:
        # [X1, X2, j_1 .. j_n, deltas]; fixed base: [j_1 .. j_n, deltas] (docs/theory.md §1, §8).
        base = {"free": ["X1", "X2", "X3", "theta_-1", "theta_0"], "planar": ["X1", "X2"]}.get(
            chain.base if chain.free_base else "", [])
        kinds = [j.spec for j in chain.joints]
        # a weld has no coordinate (formulation §17): joint variables in link order, welds skipped
        names = base + [kd.coordinate_name(i) for i, kd in enumerate(kinds, start=1) if kd.has_coordinate]
        joint_index = []
        for kd in kinds:
            joint_index.append(len(base) + len(joint_index) - joint_index.count(-1) if kd.has_coordinate else -1)
        delta_index = []
        directions = []
        k = len(names)
        for i, (lk, ld) in enumerate(zip(chain.links, self._links), start=1):
            idx = []
            for j in range(1, ld.K.shape[0] + 1):
                names.append(f"delta_{i}_{j}")
                idx.append(k)
                k += 1
            directions += list(ld.directions)
            delta_index.append(np.array(idx, dtype=int))
        self._names = tuple(names)
        self._delta_index = tuple(delta_index)
        # The same indices as slices (each link's modes are contiguous): cheap views in the kernel.
        self._delta_slice = tuple(slice(int(d[0]), int(d[-1]) + 1) if d.size else slice(0, 0) for d in delta_index)
        self._theta_index = tuple(joint_index)
        n_joint = sum(kd.has_coordinate for kd in kinds)
        self._bending = tuple([""] * (len(base) + n_joint) + directions)
        # Unit of each coordinate: angles and FE node slopes in rad, the rest in m.
        units = ["m", "m", "m", "rad", "rad"][:len(base)]
        units += [kd.unit for kd in kinds if kd.has_coordinate]
        for lk, ld in zip(chain.links, self._links):
            units += (["m", "rad"] * (ld.K.shape[0] // 2)) if lk.elements else ["m"] * ld.K.shape[0]
        self._units = tuple(units)
        self._base_transform = None if chain.free_base else chain.base.transform
        self._chart = _EYE3  # R_ref of the spatial free base (formulation §18; with_base_chart)
        self._chart_root = self
        K = np.zeros((k, k))
        for d, ld in zip(delta_index, self._links):
            K[np.ix_(d, d)] = ld.K
        K.setflags(write=False)
        self._K = K
        self._total_mass = sum(ld.mass for ld in self._links)

    # -- read-only views ---------------------------------------------------
    chain = property(lambda self: self._chain, doc="The Chain.")
    gravity = property(lambda self: self._gravity, doc="Gravity (3,) [m/s^2].")
    quadrature = property(lambda self: self._quadrature, doc="(panels, points) of the modal-integral rule.")
    link_data = property(lambda self: self._links, doc="Per-link LinkData.")
    coordinate_names = property(lambda self: self._names, doc="Names of q, length N.")
    delta_index = property(lambda self: self._delta_index, doc="Indices of each link's modal coordinates in q.")
    delta_slice = property(lambda self: self._delta_slice, doc="The same as slices of q.")
    theta_index = property(lambda self: self._theta_index,
                           doc="Index in q of joint i's variable (theta_i or d_i), i = 1..n; -1 for a weld.")
    joint_index = theta_index
    free_base = property(lambda self: self._chain.free_base,
                         doc="True for a floating base: X1..X3, theta_-1, theta_0 ('free') or X1, X2 ('planar') in q.")
    planar = property(lambda self: self._chain.planar, doc="True for a planar chain (docs/theory.md §8).")
    joint_kinds = property(lambda self: tuple(j.kind for j in self._chain.joints),
                           doc="'R', 'Pa', 'Pb' or 'W' (a weld) per joint (n,).")
    joint_specs = property(lambda self: tuple(j.spec for j in self._chain.joints),
                           doc="The JointKind of each joint (n,) (model.joints.JOINT_KINDS: its properties).")
    base_transform = property(lambda self: self._base_transform, doc="T_0 (4, 4) of a fixed base, None for a free one.")
    base_chart = property(lambda self: self._chart, doc=(
        "R_ref (3, 3), the reference orientation the free base's angles are measured from: "
        "T_1 = Trans(X) R_ref Rx(theta_-1) Ry(theta_0) Rz(theta_1) (I unless made by with_base_chart)."))
    chart_root = property(lambda self: self._chart_root, doc=(
        "The model this one is a base chart of (with_base_chart), itself for a model built by Model(...): "
        "everything but R_ref is the root's, so per-model tables may be keyed on it."))
    coordinate_units = property(lambda self: self._units, doc="Unit of each coordinate, 'm' or 'rad' (N,).")
    bending_directions = property(
        lambda self: self._bending, doc="Per coordinate: 'y' or 'z' for an elastic coordinate, '' otherwise (N,).")
    stiffness_matrix = property(lambda self: self._K, doc="Block-diagonal modal stiffness K (N, N) [N/m].")
    total_mass = property(lambda self: self._total_mass, doc="Total mass [kg].")

    def __getstate__(self):
        # Pickled (a sweep's spawned workers) without kernel_call: it holds the kernel's dispatcher,
        # which a worker must take from its own import of the kernel.
        state = self.__dict__.copy()
        state.pop("_kernel_call", None)
        return state

    def with_base_chart(self, R_ref) -> "Model":
        """The same model with the free base's angles measured from R_ref (formulation §18).

        T_1 = Trans(X) R_ref Rx(theta_-1) Ry(theta_0) Rz(theta_1): X stays the world position of O_1,
        the three angles turn the base from the orientation R_ref instead of from the world axes, so
        a run can move the chart's singularity (theta_0 = +-pi/2) away from the motion. This model is
        not changed; the new one shares every table with it and differs in the packed base transform
        only (model/packing.base_block).

        R_ref : (3, 3) rotation matrix (orthonormal to 1e-9, det +1).
        """
        if self._chain.base != "free":
            raise ValueError(f"with_base_chart: the chain's base is {self._chain.base!r}; only a spatial free base "
                             "(base='free') has a chart of three angles")
        R = np.array(R_ref, dtype=float)
        if R.shape != (3, 3) or not np.all(np.isfinite(R)) or not np.allclose(R.T @ R, _EYE3, rtol=0.0, atol=1e-9) \
                or np.linalg.det(R) <= 0.0:
            raise ValueError(f"with_base_chart R_ref={np.asarray(R_ref).tolist()} must be a (3, 3) rotation matrix (R^T R = I to 1e-9, "
                             "det R = +1), e.g. the current base orientation R_ref Rx Ry Rz of the old chart")
        R.setflags(write=False)
        root = self._chart_root
        new = object.__new__(Model)
        new.__dict__.update({k: v for k, v in root.__dict__.items() if k not in ("_kernel_data", "_kernel_call")})
        new._chart = R
        fdat, idat, zeros, v = root.kernel_data
        new._kernel_data = (with_base_block(fdat, base_block(new)), idat, np.zeros_like(zeros), v)
        return new

    @property
    def kernel_data(self):
        """(fdat (F,), idat (I,), zeros (N,), v): the model packed for the compiled kernel (built once);
        v is its kernel variant (gibbsimpact.kernel.variant), a pair passed as the last two arguments."""
        try:
            return self._kernel_data
        except AttributeError:
            data = None
        if data is None:
            fdat, idat = pack(self)
            # Writable on purpose: numba types read-only arrays differently, and contact_terms
            # (resting.py) takes these zeros as a writable array (the kernel takes either).
            zeros = np.zeros(self.n_dof)
            data = self._kernel_data = (fdat, idat, zeros, variant(idat))
        return data

    @property
    def kernel_call(self) -> tuple:
        """(kernel, fdat, idat, zeros (N,), v0, v1, outputs): the compiled kernel of this model's variant
        (compiled at its first use) and its arguments, unpacked once for the documented entry points;
        ``outputs`` {job: length of the kernel's output for one state}, filled by :meth:`kernel_output`."""
        try:
            return self._kernel_call
        except AttributeError:
            fdat, idat, zeros, v = self.kernel_data
            call = self._kernel_call = (compiled(v), fdat, idat, zeros, v[0], v[1], {})
            return call

    def kernel_output(self, job: int) -> np.ndarray:
        """A new (uninitialised) output array of the kernel for one state and the JOB_* bits ``job``."""
        sizes = self.kernel_call[6]
        try:
            return np.empty(sizes[job])
        except KeyError:
            out = output(self.kernel_data[1], 1, job)
            sizes[job] = out.size
            return out

    @property
    def n_dof(self) -> int:
        return len(self._names)

    @property
    def n_links(self) -> int:
        return self._chain.n_links

    @property
    def n_joints(self) -> int:
        """Number P of contact points O_1 ... O_P (wall contact candidates).

        O_1 ... O_(n+1): the frame origins (each joint, the last link's tip; for a Pa
        link the carriage centre, for a Pb link its rear end). Then, in joint order,
        the tip of every host link whose child joint i >= 2 is prismatic: that tip is
        not a frame origin (a carriage rides along the host; a guide sits at its tip).
        """
        try:
            return self._n_joints  # computed once: the event layer asks for it at every gap evaluation
        except AttributeError:
            pass
        P = self._n_joints = self._chain.n_links + 1 + len(self.extra_tips)
        return P

    @property
    def extra_tips(self) -> tuple:
        """The links (0-based) whose tips are contact points but no frame origin, in contact-point
        order (n_joints): hosts of a prismatic child joint, then the leaves of a tree but the last
        link (formulation §17: every link end that carries no child)."""
        joints = self._chain.joints
        hosts = [i - 1 for i, j in enumerate(joints) if i > 0 and j.spec.prismatic]
        return tuple(hosts + [i for i in self._chain.free_tips if i != len(joints) - 1])

    @property
    def tip_points(self) -> tuple:
        """Index in joint_positions (n_joints) of the contact point at each link's tip (n,): the
        frame origin of its first child attached at the tip, the tip frame n for the last link,
        or its extra tip point (extra_tips)."""
        chain, n = self._chain, self._chain.n_links
        extra = {h: n + 1 + k for k, h in enumerate(self.extra_tips)}
        out = []
        for i in range(n):
            at_tip = [j for j in chain.children[i] if chain.attach[j] in (None, chain.links[i].length)
                      and not chain.joints[j].spec.prismatic]
            out.append(n if i == n - 1 else (at_tip[0] if at_tip else extra[i]))
        return tuple(out)

    @property
    def contact_point_names(self) -> tuple:
        """A label per contact point (P,): 'O1' ... and 'tip of link i' for the extra tips."""
        names = [f"O{j}" for j in range(1, self._chain.n_links + 2)]
        names += [f"tip of link {h + 1}" for h in self.extra_tips]
        return tuple(names)

    def check_state(self, q, qdot=None, name_q: str = "q", name_qdot: str = "qdot"):
        """Validate and return ``q`` (and ``qdot``) as float arrays of shape (N,).

        The common case, float64 arrays of shape (N,) with finite entries, costs a shape compare
        and one dot product (q.q + qdot.qdot is finite exactly when every entry is, or overflowed
        beyond 1e154 with numpy's RuntimeWarning, which the full check below then clears). (The alias
        methods below leave the check of the common case to the compiled call, and come here only
        for the message of a state it refused.)
        """
        N = len(self._names)
        if q.__class__ is np.ndarray and q.dtype is _F64 and q.shape == (N,):
            if qdot is None:
                if isfinite(q.dot(q)):
                    return q
            elif qdot.__class__ is np.ndarray and qdot.dtype is _F64 and qdot.shape == (N,) \
                    and isfinite(q.dot(q) + qdot.dot(qdot)):
                return q, qdot
        qa = self._checked_vector(q, name_q, f" ordered as {', '.join(self._names)}")
        return qa if qdot is None else (qa, self._checked_vector(qdot, name_qdot, ""))

    def _checked_vector(self, a, name: str, order: str) -> np.ndarray:
        """``a`` as a float array (N,); a ValueError names its shape, or its non-finite coordinates."""
        v = np.asarray(a, dtype=float)
        N = len(self._names)
        if v.shape != (N,):
            raise ValueError(f"{name} has shape {v.shape}; this model needs shape ({N},){order}")
        if not np.all(np.isfinite(v)):
            bad = [self._names[i] for i in np.nonzero(~np.isfinite(v))[0]]
            raise ValueError(f"{name} has non-finite entries: {', '.join(bad)}")
        return v

    def _weld_hint(self, name: str) -> str:
        """' (joint i is a gi.Weld: no coordinate)' when name is theta_i of a welded joint, else ''."""
        joint = re.fullmatch(r"theta_([1-9][0-9]*)", name)
        i = int(joint[1]) if joint else 0
        if 1 <= i <= self.n_links and not self.chain.joints[i - 1].spec.has_coordinate:
            return f" (joint {i} is a gi.Weld: link {i} is clamped to its parent, no coordinate)"
        return ""

    def state(self, **values) -> np.ndarray:
        """Build a q (or qdot) vector (N,) from coordinate names; missing ones are 0.

        Example: ``model.state(X1=-0.5, theta_1=0.3)``. Names use ``theta_m1``
        as an alias of ``theta_-1``.
        """
        q = np.zeros(self.n_dof)
        for k, v in values.items():
            name = k.replace("theta_m1", "theta_-1")
            if name not in self._names:
                raise ValueError(f"unknown coordinate {k!r}{self._weld_hint(name)}; this model has {', '.join(self._names)}")
            q[self._names.index(name)] = float(v)
        return q

    # -- algorithms (one-line aliases of the pure functions of gibbsimpact.dynamics) --------------
    # Each is one call of the compiled kernel, which validates q and qdot (check=True: their sizes
    # and finite entries, with Model.check_state's messages on the error path), so that an alias
    # costs what its kernel call costs (benchmarks/bench_entry.py).
    def mass_matrix(self, q):
        """Mass matrix M(q), shape (N, N) [kg, kg m, kg m^2 by block]."""
        return _dynamics().mass_matrix(self, q, check=True)

    def bias_forces(self, q, qdot):
        """Velocity-product terms h(q, qdot), shape (N,) [N, N m]."""
        return _dynamics().bias_forces(self, q, qdot, check=True)

    def potential_forces(self, q):
        """Gradient dV/dq of gravity plus strain energy, shape (N,) [N, N m]."""
        return _dynamics().potential_forces(self, q, check=True)

    def forward_dynamics(self, q, qdot):
        """Generalised accelerations qddot, shape (N,): M qddot = -h - dV/dq."""
        return _dynamics().forward_dynamics(self, q, qdot, check=True)

    def energy(self, q, qdot):
        """Energy(kinetic, gravity, strain, total) in joules."""
        return _dynamics().energy(self, q, qdot, check=True)

    def joint_positions(self, q):
        """Inertial positions of O_1 ... O_(n+1), shape (n+1, 3) [m]."""
        return _kinematics().joint_positions(self, q, check=True)

    def joint_jacobians(self, q):
        """Jacobians d O_j / d q, shape (n+1, 3, N)."""
        return _kinematics().joint_jacobians(self, q, check=True)

    def joint_velocities(self, q, qdot):
        """Inertial velocities of O_1 ... O_(n+1), shape (n+1, 3) [m/s]: dO_j/dt = J_j(q) qdot."""
        q, qdot = self.check_state(q, qdot)
        return self.joint_jacobians(q) @ qdot

    def linear_momentum(self, q, qdot):
        """Total linear momentum, shape (3,) [kg m/s]."""
        return _dynamics().linear_momentum(self, q, qdot, check=True)

    def angular_momentum(self, q, qdot, about=None):
        """Angular momentum about ``about`` (3,) [m], default the mass centre; (3,) [kg m^2/s]."""
        L, H0, c = _dynamics().momentum(self, q, qdot, check=True)
        point = c if about is None else np.asarray(about, dtype=float)
        # H_P = H_0 - P x L
        return H0 - np.cross(point, L)

    def center_of_mass(self, q):
        """Mass centre, shape (3,) [m]."""
        return _dynamics().center_of_mass(self, q, check=True)

    def __repr__(self):
        return f"Model(n_links={self.n_links}, n_dof={self.n_dof}, gravity={tuple(self._gravity)})"
