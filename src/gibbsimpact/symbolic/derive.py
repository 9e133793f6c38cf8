"""Symbolic equations of motion of a chain: model -> M(q) qddot = forcing(q, qdot).

``derive_equations(model, method)`` writes the flight-phase equations of any
chain the numeric kernel models (free-flying or fixed base, assumed-mode or
finite-element links, planar or spatial, rotary inertia) as sympy expressions
in the coordinates q and speeds qdot (symbols named after
``model.coordinate_names``; speeds ``<name>_dot``)::

    M(q) qddot = forcing(q, qdot),     forcing = Q - h(q, qdot) - dV/dq,   Q = 0

    M       (N, N)  [kg, kg m, kg m^2 by block]
    forcing (N, 1)  [N, N m]

Numbers of the model (link moments ``P0, C, D, m_r0, m_psi, M_dd, K, end_t,
end_phi, J_body``, gravity, the fixed-base frame T_0) enter as constants
(binary-exact 17-digit floats, or exact rationals with ``rational=True``).

The derivation, one file per step (in the spirit of sympy.physics.mechanics):
algebra.py (Rodrigues coefficients, 4x4 algebra on expressions), recursion.py
(frames, velocities and link moments along the chain), gibbs_appell.py and
lagrange.py (the two routes), parametric.py (symbols=...), equations.py (the
Equations result) and printer.py (operation counts, LaTeX, Python).
"""

from __future__ import annotations

import sys
import time

from . import gibbs_appell, lagrange
from .algebra import Algebra, rodrigues_coefficient
from .equations import Equations
from .parametric import ParametricModel, fix_parameters

__all__ = ["METHODS", "derive_equations", "rodrigues_coefficient"]  # rodrigues_coefficient: its documented path

#: Derivation routes of derive_equations: method -> mass_matrix_and_forcing(model, alg, q, qd).
ROUTES = {"gibbs-appell": gibbs_appell.mass_matrix_and_forcing, "lagrange": lagrange.mass_matrix_and_forcing}
METHODS = tuple(ROUTES)


def _progress_line(stage: str, done: int, total: int):
    """progress=True: one line on stderr, rewritten in place, that counts links / equations."""
    end = "\n" if done == total else ""
    print(f"\rderiving ({stage} {done}/{total})", end=end, file=sys.stderr, flush=True)


def derive_equations(model, method: str = "gibbs-appell", *, rational: bool = False,
                     symbols=False, progress=None) -> "Equations":
    """Symbolic equations of motion M(q) qddot = forcing(q, qdot) of ``model`` (Q = 0).

    Parameters
    ----------
    model : gibbsimpact.Model
    method : "gibbs-appell" (the recursive 4x4 moment form, docs/theory.md §6)
        or "lagrange" (Lagrange's equations on T and V of the same moment form).
    rational : bool
        Model numbers as exact rationals of their binary values instead of floats.
    symbols : bool or sequence of str
        Parametric equations (uniform links only). True: each link's length ``l_i``,
        mass per length ``mu_i``, stiffnesses ``EIz_i`` / ``EIy_i``, rotary inertias
        ``jx_i`` ..., and gravity ``g_1 .. g_3`` stay symbols; a sequence of those
        names keeps only them symbolic (the other parameters become numbers). The
        dimensionless modal integrals are named constants (``c_i_k``, ``cx_i_k``,
        ``d_i_k_l``, ``kappa_i_k_l``, ``e_i_k``, ``s_i_k``, see gibbsimpact.symbolic.parametric).
        ``eqs.constants`` lists every value; numeric() and to_python() substitute them.
    progress : None, True (a line on stderr that counts links / equations), or a
        callable(stage: str, done: int, total: int)

    Returns
    -------
    Equations
        ``coordinates``, ``speeds`` (N,) symbols, ``mass_matrix`` (N, N),
        ``forcing`` (N, 1), ``derivation_seconds``; ``operation_count()``,
        ``to_latex(path)``, ``to_python(path)``, ``numeric()``.
    """
    if not isinstance(method, str) or method not in METHODS:
        raise ValueError(f"derive_equations method={method!r} is not supported; choose one of "
                         + ", ".join(repr(m) for m in METHODS))
    from ..model.model import Model

    if not isinstance(model, Model):
        raise ValueError(f"derive_equations model={model!r} must be a gibbsimpact.Model")
    if model.chain.base == "planar" or any(k.prismatic for k in model.joint_specs):
        # The symbolic recursion builds revolute and welded joints behind a spatial free or a fixed base only.
        raise NotImplementedError(
            "derive_equations: prismatic joints and the planar floating base are not derived symbolically yet "
            f"(this model has joints {'-'.join(model.joint_kinds)}, base {model.chain.base!r}); the numeric "
            "kernel simulates them, and tests/reference/planar_oracle.py is an independent derivation")
    if symbols and any(a is not None for a in model.chain.attach):
        # An attachment abscissa x_a is a number: it would not follow a symbolic length l_i.
        raise NotImplementedError(
            "derive_equations symbols=...: a tree with joints along a parent (Chain attach=...) has numeric "
            "attachment sections; derive it with symbols=False (numbers), or attach the children at the tips")
    stiff = [i + 1 for i, lk in enumerate(model.chain.links) if lk.stiffened]
    if stiff:
        # u_f = -1/2 delta^T H(x) delta makes the body moments quartic in delta (formulation §15).
        raise NotImplementedError(
            f"derive_equations: link(s) {', '.join(map(str, stiff))} foreshorten (geometric_stiffening=True, the "
            "default), whose terms are not derived symbolically yet; build those links with "
            "geometric_stiffening=False for the linear beam's equations, or use the numeric kernel")
    import sympy as sp
    from sympy.core.parameters import distribute

    t0 = time.perf_counter()
    names = model.coordinate_names
    q = [sp.Symbol(nm, real=True) for nm in names]
    qd = [sp.Symbol(nm + "_dot", real=True) for nm in names]
    alg = Algebra(sp, rational, _progress_line if progress is True else (progress or None))
    constants: dict = {}
    source = ParametricModel(sp, model, constants) if symbols else model
    with distribute(False):  # keep c*(a + b) unexpanded: shared subexpressions stay shared
        M, forcing = ROUTES[method](source, alg, q, qd)
    M, forcing = sp.ImmutableMatrix(M), sp.ImmutableMatrix(forcing)
    if symbols and symbols is not True:
        fixed = fix_parameters(sp, symbols, constants)
        M, forcing = M.xreplace(fixed), forcing.xreplace(fixed)
    return Equations(model, method, tuple(q), tuple(qd), M, forcing, time.perf_counter() - t0, constants)
