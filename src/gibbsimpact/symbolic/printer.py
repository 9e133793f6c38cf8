"""Writers of the derived equations: operation counts, the LaTeX document, the standalone Python module.

Common-subexpression elimination (sympy.cse) gives the straight-line program
behind ``operation_count``, ``to_python`` and ``numeric``.
"""

from __future__ import annotations

import inspect
from typing import NamedTuple

from .algebra import SERIES_TERMS, rodrigues_coefficient


class OperationCount(NamedTuple):
    """Operations of the CSE'd program: an Add of k terms is k-1 adds, a Mul of k factors k-1 muls
    (a factor -1 is free), x**k with integer k is |k|-1 muls (+1 for a division);
    sin, cos, sqrt, rodrigues_* are functions."""

    adds: int
    muls: int
    functions: int

    @property
    def total(self) -> int:
        return self.adds + self.muls + self.functions


def count_operations(exprs, sp) -> OperationCount:
    """Operations of the expression DAG ``exprs`` (each distinct subexpression once), by OperationCount's rules."""
    adds = muls = funcs = 0
    seen = set()
    stack = list(exprs)
    while stack:
        e = stack.pop()
        if e.is_Atom or e in seen:
            continue
        seen.add(e)
        if e.is_Add:
            adds += len(e.args) - 1
        elif e.is_Mul:
            muls += len([a for a in e.args if a is not sp.S.NegativeOne]) - 1
        elif e.is_Pow:
            x = e.exp
            if x.is_Integer:
                muls += max(abs(int(x)) - 1, 0) + (1 if x < 0 else 0)
            else:
                funcs += 1
        else:
            funcs += 1
        stack.extend(e.args)
    return OperationCount(adds, muls, funcs)


def latex_name(name: str, dot: bool = False) -> str:
    """LaTeX of a coordinate name: theta_2 -> \\theta_{2}, delta_1_2 -> \\delta_{1,2}, X1 -> X_{1}; dot: its speed."""
    base, _, rest = name.partition("_")
    if not rest and base[:1] == "X":
        base, rest = "X", base[1:]
    head = {"theta": r"\theta", "delta": r"\delta"}.get(base, base)
    if dot:
        head = rf"\dot{{{head}}}"
    return f"{head}_{{{rest.replace('_', ',')}}}" if rest else head


def latex_document(eqs) -> str:
    """A LaTeX document of M(q) qddot = forcing for Equations ``eqs``: auxiliary quantities x_k of its
    common-subexpression program, then the upper-triangle entries M_jk and the forcing f_j (1-based),
    then the named constants of a parametric derivation."""
    import sympy as sp

    names = {c: latex_name(nm) for c, nm in zip(eqs.coordinates, eqs.coordinate_names)}
    names.update({c: latex_name(nm, dot=True) for c, nm in zip(eqs.speeds, eqs.coordinate_names)})
    repl, Mred, fred = eqs.cse()
    names.update({x: f"x_{{{x.name[1:]}}}" for x, _ in repl})

    def tex(e):
        return sp.latex(e, symbol_names=names)

    N = len(eqs.coordinates)
    lines = [
        r"\documentclass{article}", r"\usepackage{amsmath}", r"\allowdisplaybreaks", r"\begin{document}",
        rf"\section*{{Equations of motion ({eqs.method})}}",
        r"$M(q)\,\ddot q = f(q, \dot q)$ with $q = (" + ", ".join(names[c] for c in eqs.coordinates)
        + rf")$, $N = {N}$. $M$ is symmetric; entries not listed are zero.",
    ]

    def block(title, rows):
        lines.append(rf"\subsection*{{{title}}}")
        if not rows:
            lines.append("None.")
            return
        lines.append(r"\begin{align*}")
        lines.append(" \\\\\n".join(f"{lhs} &= {rhs}" for lhs, rhs in rows))
        lines.append(r"\end{align*}")

    block("Auxiliary quantities", [(names[x], tex(e)) for x, e in repl])
    block("Mass matrix", [(f"M_{{{j + 1},{k + 1}}}", tex(e)) for (j, k), e in Mred])
    block("Forcing", [(f"f_{{{j + 1}}}", tex(e)) for j, e in enumerate(fred)])
    if eqs.constants:
        block("Parameters and named constants", [(tex(k), f"{v:.17g}") for k, v in eqs.constants.items()])
    lines.append(r"\end{document}")
    return "\n".join(lines) + "\n"


# The generated module is standalone: it carries rodrigues_coefficient's own source.
_HELPERS = "\n" + inspect.getsource(rodrigues_coefficient).replace(
    "def rodrigues_coefficient(", "def _rodrigues(").replace("SERIES_TERMS", str(SERIES_TERMS))


class _PythonPrinter:
    """Python source of a CSE'd expression (math for scalars); linear in the expression size."""

    _FUNCS = {"sin": "math.sin", "cos": "math.cos", "tan": "math.tan", "exp": "math.exp", "log": "math.log"}

    def __init__(self, sp, names):
        self.sp, self.names = sp, names

    def __call__(self, e):
        sp = self.sp
        if e.is_Symbol:
            return self.names.get(e, e.name)
        if e.is_Integer:
            return f"{int(e)}.0" if abs(int(e)) < 2**53 else repr(float(e))
        if e.is_Rational:
            return f"({e.p}/{e.q})"
        if e.is_Float:
            return repr(float(e))
        if e.is_Add:
            out = []
            for k, a in enumerate(e.args):
                if a.is_Mul and a.args[0].is_Number and a.args[0] < 0:
                    out.append((" - " if k else "-") + self(-a))
                elif a.is_Number and a < 0:
                    out.append((" - " if k else "-") + self(-a))
                else:
                    out.append((" + " if k else "") + self(a))
            return "(" + "".join(out) + ")"
        if e.is_Mul:
            num, den = [], []
            for a in e.args:
                if a.is_Pow and a.exp.is_Integer and a.exp < 0:
                    den.append(self(a.base) if a.exp == -1 else self(a.base ** -a.exp))
                elif a is sp.S.NegativeOne:
                    num.insert(0, "-1.0")
                else:
                    num.append(self(a))
            text = "*".join(num) if num else "1.0"
            if den:
                text = f"{text}/({'*'.join(den)})"
            return "(" + text + ")"
        if e.is_Pow:
            b, x = self(e.base), e.exp
            if x == 2:
                return f"({b}*{b})"
            if x == -1:
                return f"(1.0/{b})"
            if x == sp.S.Half:
                return f"math.sqrt({b})"
            return f"({b}**{self(x)})"
        if isinstance(e, sp.Function) and len(e.args) == 1:
            name = type(e).__name__
            return f"{self._FUNCS.get(name, name)}({self(e.args[0])})"
        raise NotImplementedError(f"no Python translation for {type(e).__name__}: {e}")


def python_module_source(eqs) -> str:
    """Source of the standalone module (math and numpy only) of Equations ``eqs``, from ``eqs.cse()``:
    mass_matrix(q) (N, N), forcing(q, qdot) (N,), mass_matrix_and_forcing, forward_dynamics."""
    import sympy as sp

    repl, Mred, fred = eqs.cse()
    N = len(eqs.coordinates)
    names = {c: f"q_{k}" for k, c in enumerate(eqs.coordinates)}
    names.update({c: f"qd_{k}" for k, c in enumerate(eqs.speeds)})
    code = _PythonPrinter(sp, names)

    deps = {x: e.free_symbols for x, e in repl}
    funcs = set()
    for _, e in repl:
        funcs |= {type(f).__name__ for f in e.atoms(sp.Function) if type(f).__name__.startswith("rodrigues_")}

    def needed(outputs):
        need = set().union(*[e.free_symbols for e in outputs]) if outputs else set()
        for x, _ in reversed(repl):
            if x in need:
                need |= deps[x]
        return [(x, e) for x, e in repl if x in need]

    def body(outputs, with_qdot):
        out = ["    q = np.asarray(q, dtype=float).tolist()"]
        if N:
            out.append("    " + ", ".join(f"q_{k}" for k in range(N)) + (", = q" if N == 1 else " = q"))
        if with_qdot:
            out.append("    qdot = np.asarray(qdot, dtype=float).tolist()")
            out.append("    " + ", ".join(f"qd_{k}" for k in range(N)) + (", = qdot" if N == 1 else " = qdot"))
        for x, e in needed(outputs):
            out.append(f"    {x} = {code(e)}")
        return out

    def mass_lines():
        out, ent = [], {}
        for (j, k), e in Mred:
            out.append(f"    m_{j}_{k} = {code(e)}")
            ent[(j, k)] = ent[(k, j)] = f"m_{j}_{k}"
        rows = ", ".join("[" + ", ".join(ent.get((j, k), "0.0") for k in range(N)) + "]" for j in range(N))
        out.append(f"    M = np.array([{rows}])")
        return out

    def forcing_lines():
        return [f"    f = np.array([{', '.join(code(e) for e in fred)}], dtype=float)"]

    Mexprs, fexprs = [e for _, e in Mred], list(fred)
    src = [
        '"""M(q) qddot = forcing(q, qdot) of a gibbsimpact chain, generated by gibbsimpact.symbolic',
        f"(method={eqs.method!r}, N = {N}). Needs only math and numpy.",
        "",
        "q = [" + ", ".join(eqs.coordinate_names) + "]  [m, rad, m]; qdot the same order.",
        "mass_matrix(q) (N, N) [kg, kg m, kg m^2]; forcing(q, qdot) (N,) [N, N m] = -h - dV/dq.",
        '"""',
        "",
        "import math",
        "",
        "import numpy as np",
        "",
        f"N = {N}",
        f"COORDINATES = {tuple(eqs.coordinate_names)!r}",
        f"METHOD = {eqs.method!r}",
        _HELPERS,
    ]
    for name in sorted(funcs):
        kind, order = name[len("rodrigues_")], int(name[len("rodrigues_") + 1:])
        src += [f"def {name}(s):", f"    return _rodrigues({kind!r}, {order}, s)", "", ""]
    src += ["def mass_matrix(q):", '    """M(q), shape (N, N)."""'] + body(Mexprs, False) + mass_lines()
    src += ["    return M", "", ""]
    src += ["def forcing(q, qdot):", '    """forcing(q, qdot) = -h - dV/dq, shape (N,)."""']
    src += body(fexprs, True) + forcing_lines() + ["    return f", "", ""]
    src += ["def mass_matrix_and_forcing(q, qdot):", '    """(M (N, N), forcing (N,)) sharing subexpressions."""']
    src += body(Mexprs + fexprs, True) + mass_lines() + forcing_lines() + ["    return M, f", "", ""]
    src += ["def forward_dynamics(q, qdot):", '    """qddot (N,) from M qddot = forcing."""',
            "    M, f = mass_matrix_and_forcing(q, qdot)", "    return np.linalg.solve(M, f)", ""]
    return "\n".join(src)
