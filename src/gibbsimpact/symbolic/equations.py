"""The result of derive_equations: M(q) qddot = forcing(q, qdot) as sympy expressions, and its writers."""

from __future__ import annotations

import time
from pathlib import Path

from .printer import OperationCount, count_operations, latex_document, python_module_source


class NumericEquations:
    """Compiled M(q) and forcing(q, qdot); unpacks as ``mass_matrix, forcing = eqs.numeric()``.

    ``mass_matrix(q)`` (N, N), ``forcing(q, qdot)`` (N,), ``mass_matrix_and_forcing(q, qdot)``
    (both, sharing subexpressions), ``forward_dynamics(q, qdot)`` qddot (N,).
    """

    def __init__(self, namespace):
        self.mass_matrix = namespace["mass_matrix"]
        self.forcing = namespace["forcing"]
        self.mass_matrix_and_forcing = namespace["mass_matrix_and_forcing"]
        self.forward_dynamics = namespace["forward_dynamics"]

    def __iter__(self):
        return iter((self.mass_matrix, self.forcing))


class Equations:
    """M(q) qddot = forcing(q, qdot) as sympy expressions (see derive_equations).

    Attributes
    ----------
    method : str
    coordinates, speeds : tuple of N sympy Symbols (``<name>``, ``<name>_dot``)
    mass_matrix : sympy ImmutableMatrix (N, N) [kg, kg m, kg m^2]
    forcing : sympy ImmutableMatrix (N, 1) [N, N m], Q - h - dV/dq with Q = 0
    derivation_seconds : float, wall time of the derivation
    constants : dict, sympy Symbol -> float, the named constants and parameters of a
        parametric derivation (symbols=...); empty otherwise
    """

    def __init__(self, model, method, coordinates, speeds, mass_matrix, forcing, seconds, constants=None):
        self.coordinate_names = model.coordinate_names
        self.method = method
        self.coordinates = coordinates
        self.speeds = speeds
        self.mass_matrix = mass_matrix
        self.forcing = forcing
        self.derivation_seconds = seconds
        self._cse = None
        self._source = None
        self.cse_seconds = None
        self.constants = constants or {}  # symbol -> value of a parametric derivation (symbols=...)
        self._model = model
        self._evaluated_copy = None

    def evaluated(self) -> "Equations":
        """These equations with every named constant replaced by its value (self when there are none)."""
        if not self.constants:
            return self
        if self._evaluated_copy is None:
            import sympy as sp

            sub = {k: sp.Float(v, 17) for k, v in self.constants.items()}
            self._evaluated_copy = Equations(self._model, self.method, self.coordinates, self.speeds,
                                             self.mass_matrix.xreplace(sub), self.forcing.xreplace(sub),
                                             self.derivation_seconds)
        return self._evaluated_copy

    def __repr__(self):
        return f"Equations(method={self.method!r}, N={len(self.coordinates)})"

    # -- common subexpressions ------------------------------------------------
    def cse(self):
        """(replacements [(x_k, expr)], upper-triangle M entries [((j, k), expr)], forcing entries [expr]).

        Computed once, over M's upper triangle and the forcing together.
        """
        if self._cse is None:
            import sympy as sp

            t0 = time.perf_counter()
            N = len(self.coordinates)
            keys = [(j, k) for j in range(N) for k in range(j, N) if self.mass_matrix[j, k] != 0]
            exprs = [self.mass_matrix[j, k] for j, k in keys] + list(self.forcing)
            # tree_cse: the repeated-subexpression pass of sympy.cse without its opt_cse pre-pass, which
            # is slower here and returned wrong sums on the Lagrange expressions (sympy 1.14).
            from sympy.simplify.cse_main import tree_cse

            repl, red = tree_cse(exprs, sp.numbered_symbols("x"), {}, "none")
            self._cse = (repl, list(zip(keys, red[:len(keys)])), red[len(keys):])
            self.cse_seconds = time.perf_counter() - t0
        return self._cse

    def operation_count(self) -> OperationCount:
        """(adds, muls, functions) to evaluate M and forcing after common-subexpression elimination."""
        import sympy as sp

        if self.constants:
            return self.evaluated().operation_count()
        repl, Mred, fred = self.cse()
        return count_operations([e for _, e in repl] + [e for _, e in Mred] + list(fred), sp)

    # -- writers ----------------------------------------------------------------
    def to_latex(self, path) -> Path:
        """Write a LaTeX document with M(q) qddot = forcing: auxiliary quantities x_k, then M_jk, f_j."""
        path = Path(path)
        path.write_text(latex_document(self))
        return path

    def python_source(self) -> str:
        """Source of a standalone module (math and numpy only) computing M and the forcing."""
        if self.constants:
            return self.evaluated().python_source()
        if self._source is None:
            self._source = python_module_source(self)
        return self._source

    def to_python(self, path) -> Path:
        """Write ``python_source()`` to ``path``: mass_matrix(q), forcing(q, qdot),
        mass_matrix_and_forcing(q, qdot), forward_dynamics(q, qdot)."""
        path = Path(path)
        path.write_text(self.python_source())
        return path

    def numeric(self) -> NumericEquations:
        """Compile the generated module in memory: callables of q (N,), qdot (N,) returning numpy arrays."""
        ns: dict = {"__name__": "gibbsimpact_equations"}
        exec(compile(self.python_source(), "<gibbsimpact.symbolic>", "exec"), ns)
        return NumericEquations(ns)
