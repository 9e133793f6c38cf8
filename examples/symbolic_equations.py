"""Symbolic equations of motion of a two-link flexible arm: both routes, generated code, checks.

Shows: gi.derive_equations by the Gibbs-Appell route and by Lagrange's, their
operation counts after common-subexpression elimination, Equations.to_python
(a standalone numpy-only module, written into the out folder and imported from
there), its mass matrix against model.mass_matrix, and a short integration of
the generated q'' = M^-1 forcing against gi.simulate (no walls) up to t_end.

The chain: two links on a fixed base, one clamped-free mode each (N = 4), so
that both derivations take a few seconds; a free-flying chain works the same
way (README: 2 links, N = 9, about 2 s and 10 s).

Run:   python examples/symbolic_equations.py
Env:   GIBBSIMPACT_EXAMPLE_T_END  caps the integration time [s] (default 0.5 s)
       GIBBSIMPACT_EXAMPLE_OUT    folder for the generated module (default: a new temp dir)
"""

import importlib.util
import os
import tempfile
import time
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp

import gibbsimpact as gi

T_END = min(0.5, float(os.environ.get("GIBBSIMPACT_EXAMPLE_T_END", "inf")))
OUT = Path(os.environ.get("GIBBSIMPACT_EXAMPLE_OUT") or tempfile.mkdtemp(prefix="gibbsimpact_sym_"))

link = gi.Link(length=1.0, mass_per_length=1.0, EI=20.0, modes=[gi.Mode("clamped-free", "y")], geometric_stiffening=False)
model = gi.Model(gi.Chain([link, link], base=gi.FixedBase(position=(0.0, 0.0), angle=0.0)), gravity=(0.0, -9.81, 0.0))
print(f"N = {model.n_dof}:", " ".join(model.coordinate_names))

eqs = {}
print(f"\n{'route':>13} {'derive [s]':>11} {'adds':>7} {'muls':>7} {'functions':>10} {'total':>7}")
for method in ("gibbs-appell", "lagrange"):
    t0 = time.perf_counter()
    eqs[method] = gi.derive_equations(model, method=method)
    seconds = time.perf_counter() - t0
    c = eqs[method].operation_count()
    print(f"{method:>13} {seconds:>11.2f} {c.adds:>7d} {c.muls:>7d} {c.functions:>10d} {c.total:>7d}")
ratio = eqs["lagrange"].operation_count().total / eqs["gibbs-appell"].operation_count().total
print(f"Lagrange / Gibbs-Appell operations: {ratio:.1f}x")

# The generated module: numpy only, importable on its own.
path = eqs["gibbs-appell"].to_python(OUT / "two_link_arm_equations.py")
spec = importlib.util.spec_from_file_location("two_link_arm_equations", path)
generated = importlib.util.module_from_spec(spec)
spec.loader.exec_module(generated)
print(f"\nwrote {path} ({len(path.read_text().splitlines())} lines)")

rng = np.random.default_rng(1)
worst_M = worst_a = 0.0
for _ in range(5):
    q, qd = rng.uniform(-1, 1, model.n_dof) * 0.5, rng.uniform(-1, 1, model.n_dof)
    M_ref = model.mass_matrix(q)
    worst_M = max(worst_M, np.max(np.abs(generated.mass_matrix(q) - M_ref)) / np.max(np.abs(M_ref)))
    a_ref = model.forward_dynamics(q, qd)
    worst_a = max(worst_a, np.max(np.abs(generated.forward_dynamics(q, qd) - a_ref)) / np.max(np.abs(a_ref)))
print(f"generated M vs model.mass_matrix, 5 random states: max relative difference {worst_M:.1e}")
print(f"generated q'' vs model.forward_dynamics:          max relative difference {worst_a:.1e}")
assert worst_M < 1e-12 and worst_a < 1e-10

# Integrate the generated equations and compare with gi.simulate (no walls).
q0, qd0 = model.state(theta_1=-0.3, theta_2=0.6), np.zeros(model.n_dof)
n = model.n_dof
sol = solve_ivp(lambda t, y: np.concatenate([y[n:], generated.forward_dynamics(y[:n], y[n:])]),
                (0.0, T_END), np.concatenate([q0, qd0]), method="DOP853", rtol=1e-10, atol=1e-12)
res = gi.simulate(model, q0, qd0, (0.0, T_END), rtol=1e-10, atol=1e-12)
diff = np.max(np.abs(sol.y[:n, -1] - res.q[-1]))
print(f"\nafter {T_END:g} s: generated-code trajectory vs gi.simulate, max |q difference| {diff:.1e}")
print("q(t_end):", np.array2string(res.q[-1], precision=6))
assert diff < 1e-7
