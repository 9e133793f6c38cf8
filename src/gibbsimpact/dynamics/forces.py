"""Applied generalised forces: joint inputs and structural damping (docs/theory.md §9).

The equations of motion with applied forces are

    M qddot = Q(t, q, qdot) - h - dV/dq,      Q = Q_in + Q_damp            (1)

* Q_in (N,) [N or N m per coordinate]: a callable ``Q(t, q, qdot)``, a
  constant vector, or named inputs ``{"theta_1": f, ...}`` whose value is a
  torque [N m] on a joint angle, a force [N] on a translation, or a
  generalised force on an elastic coordinate; ``f`` is a number or a callable
  ``f(t, q, qdot)``.
* Q_damp = -C qdot with C = block-diag(beta_i K_i) (N, N) [N s/m]: stiffness-
  proportional (Rayleigh) damping of each link's elastic coordinates,
  beta_i = 2 zeta_i / omega_1,i, zeta_i = ``Link.damping`` the damping ratio of
  the link's first elastic mode, omega_1,i [rad/s] the lowest generalised
  eigenvalue of (K_i, M_dd,i) (the link clamped at its frame). A mode of
  frequency omega then has the ratio zeta_i omega / omega_1,i.

Power balance (Lagrange): d/dt (T + V) = qdot^T Q, so a driven or damped run
conserves E(t) - E(0) - W(t) with the work W = int qdot^T Q dt, which the
simulation integrates alongside the state (the energy audit).
"""

from __future__ import annotations

import math
from numbers import Real
from typing import Callable

import numpy as np


def _pb_stiffness(link, d: float) -> np.ndarray:
    """K(d) (m, m) of a link behind a FixedPrismatic guide with protruding length d [m]:
    K_kl = EI d^(a_k + a_l - 3) K^_kl (docs/theory.md §7.6; assembled eq. (27) with h = d / n_e)."""
    from ..model.elements import assemble, element_stiffness

    return assemble(element_stiffness(link.EI_z, d / link.elements), link.elements)


def damping_depends_on_q(model) -> bool:
    """True when a damped link slides through a FixedPrismatic guide (its K depends on d)."""
    return any(lk.damping > 0 and lk.elements and jt.spec.guide
               for lk, jt in zip(model.chain.links, model.chain.joints))


def damping_matrix(model, q=None) -> np.ndarray:
    """C = block-diag(beta_i K_i), shape (N, N) [N s/m, N s, N m s by block]; zeros when no link is damped.

    For a link behind a FixedPrismatic guide K_i = K_i(d_i), the stiffness of the
    protruding part at q (N,) (required then), and beta_i uses omega_1 of the link
    at full length (d = l): the damping coefficient is a material constant.
    """
    N = model.n_dof
    C = np.zeros((N, N))
    for i, (link, ld, idx) in enumerate(zip(model.chain.links, model.link_data, model.delta_index)):
        zeta = link.damping
        if zeta == 0.0:
            continue
        beta = 2.0 * zeta / ld.first_frequency
        K = ld.K
        if model.chain.joints[i].spec.guide and link.elements:
            if q is None:
                raise ValueError("damping_matrix(model, q): a damped link slides through a FixedPrismatic guide, "
                                 "so C depends on its protruding length; give q")
            K = _pb_stiffness(link, float(q[model.theta_index[i]]))
        C[np.ix_(idx, idx)] = beta * K
    C.setflags(write=False)
    return C


class CallbackError(Exception):
    """A function the user gave (an input, the progress callback) failed during a run.

    callback : str, which one, as the user named it (``inputs['theta_2']``, ``inputs(t, q, qdot)``, ``progress``)
    coordinate : str or None, the coordinate its value acts on
    t : float [s], the simulated time of the failing call
    cause : str, what went wrong (the exception it raised, or the value it returned)
    """

    def __init__(self, callback: str, coordinate, t: float, cause: str):
        self.callback, self.coordinate, self.t, self.cause = callback, coordinate, float(t), cause
        on = f" (on {coordinate})" if coordinate else ""
        super().__init__(f"{callback}{on} failed at t = {self.t:.9g} s: {cause}")


def _check_Q(Q, N: int, what: str) -> np.ndarray:
    a = np.asarray(Q, dtype=float)
    if a.shape != (N,) or not np.all(np.isfinite(a)):
        raise ValueError(f"simulate {what} must give {N} finite numbers (one per coordinate), got {Q!r}")
    return a


def _guarded_vector(fun, model):
    """Q(t, q, qdot) of a callable ``inputs``, raising CallbackError when it raises or gives a non-finite or
    misshapen value (the run then stops with its results kept)."""
    N, names = model.n_dof, model.coordinate_names

    def Q(t, q, qd):
        try:
            v = np.asarray(fun(t, q, qd), dtype=float)
        except Exception as exc:  # noqa: BLE001 - any failure of user code, named
            raise CallbackError("inputs(t, q, qdot)", None, t, f"raised {exc!r}") from exc
        if v.shape != (N,):
            raise CallbackError("inputs(t, q, qdot)", None, t, f"returned shape {v.shape}, not ({N},)")
        bad = ~np.isfinite(v)
        if bad.any():
            k = int(np.argmax(bad))
            raise CallbackError("inputs(t, q, qdot)", names[k], t, f"returned {float(v[k])!r}")
        return v

    return Q


def _guarded_term(f, name, coordinate):
    """f(t, q, qdot) -> float of one named input, raising CallbackError when it raises or is not finite."""
    what = f"inputs[{name!r}]"

    def term(t, q, qd):
        try:
            v = f(t, q, qd)
            x = float(v)
        except Exception as exc:  # noqa: BLE001 - any failure of user code, named
            raise CallbackError(what, coordinate, t, f"raised {exc!r}") from exc
        if not math.isfinite(x):
            raise CallbackError(what, coordinate, t, f"returned {x!r}")
        return x

    return term


def generalized_force(model, inputs, t0: float, q0: np.ndarray, qdot0: np.ndarray) -> Callable | None:
    """Q_in(t, q, qdot) -> (N,) from the ``inputs`` argument of simulate, or None when there are none.

    inputs : None, a callable Q(t, q, qdot) -> (N,), a constant (N,) vector,
        or a dict {coordinate name: number or callable f(t, q, qdot) -> float}.
    t0, q0, qdot0 : the initial state [s], (N,), (N,): each callable is evaluated
        there once, and a ValueError names the input whose name is unknown, whose
        call fails or whose value is not finite. Later, during the run, a callable that
        raises or returns a non-finite value raises CallbackError (name, coordinate, time).
    """
    N = model.n_dof
    names = model.coordinate_names
    if inputs is None:
        return None
    if callable(inputs):
        _check_Q(_call(inputs, "inputs", t0, q0, qdot0), N, "inputs(t, q, qdot)")
        return _guarded_vector(inputs, model)
    if isinstance(inputs, dict):
        terms = []
        for name, f in inputs.items():
            key = str(name).replace("theta_m1", "theta_-1")
            if key not in names:
                raise ValueError(f"simulate inputs: unknown coordinate {name!r}; this model has {', '.join(names)}")
            k = names.index(key)
            if callable(f):
                v = _call(f, f"inputs[{name!r}]", t0, q0, qdot0)
                if np.ndim(v) != 0 or not np.isfinite(v):
                    raise ValueError(f"simulate inputs[{name!r}](t, q, qdot) must return one finite number, got {v!r}")
                terms.append((k, _guarded_term(f, name, key)))
            elif isinstance(f, Real) and not isinstance(f, bool) and np.isfinite(f):
                terms.append((k, float(f)))
            else:
                raise ValueError(f"simulate inputs[{name!r}]={f!r} must be a finite number or a callable f(t, q, qdot)")

        def Q_named(t, q, qd):
            Q = np.zeros(N)
            for k, f in terms:
                Q[k] += f(t, q, qd) if callable(f) else f
            return Q

        return Q_named
    Q0 = _check_Q(inputs, N, "inputs")
    return lambda t, q, qd: Q0


def _call(f, what, t0, q0, qdot0):
    try:
        return f(t0, q0.copy(), qdot0.copy())
    except Exception as exc:  # noqa: BLE001 - report any failure of user code with its name
        raise ValueError(f"simulate {what} failed when called at the initial state (t = {t0:g} s): {exc!r}") from exc
