"""Benchmark of the published case studies (free-flying and fixed-base prismatic).

For each case: wall time, accepted steps, right-hand-side evaluations, impacts
and the energy error, plus ratios against references measured in this same
run, so the numbers can be compared across machines:

* ``rhs/solve``: one dynamics evaluation (forward_dynamics) against one
  numpy linear solve of the same size N (a machine-speed yardstick);
* ``loop overhead``: simulate's wall time against nfev x (time of one RHS),
  i.e. what events, impulses and bookkeeping add on top of the dynamics (and,
  for cases with [[inputs]], evaluating the inputs in Python and integrating
  their work);
* ``rhs/sympy``: one dynamics evaluation against one evaluation of the
  equations of motion generated symbolically for the same chain by the test
  oracle (tests/reference/sympy_chain.py: sympy.physics.mechanics Kane
  equations, lambdified with common-subexpression elimination) -- the usual
  alternative to a recursive formulation. That oracle only knows free-flying
  chains with revolute joints: "n/a" for the fixed-base prismatic cases;
* ``rhs/planar``: the same ratio against the second independent derivation,
  tests/reference/planar_oracle.py (planar chains with R, Pa and Pb joints on a
  fixed base: position map, forward-mode jets, Gauss quadrature, pure numpy).
  It only knows fixed-base planar chains of uniform, rigid or in-plane
  finite-element links without rotary inertia: "n/a" for the free-flying modal
  cases. It is a slow reference implementation (nothing was done to make it
  fast), so this ratio measures the kernel against a vectorised-numpy
  derivation, not against another fast code.

Each reference is checked to be the same system as the model: the line under
the table gives max|qddot_ref - qddot| / max|qddot| at q0 with small random
deflections and random velocities.

Cases and settings: circle_two_link and sphere_single_link with DOP853,
rtol 1e-10, atol 1e-12 (as before); fixed_base_R_Pb_arm and
fixed_base_R_Pa_arm with their files' own settings but DOP853, rtol 1e-8,
atol 1e-10 (the files run method auto at rtol 1e-2 since 2026-11-27; output every 1 ms, their motor/actuator/servo inputs; ~0.1 M
RHS and ~10 s each), the settings whose reference numbers the case files quote.
For the driven cases both energy columns are the audit E(t) - E(0) - W(t)
(W the work of the inputs) relative to |E(0)|; with no impact they coincide.

Timing: ``wall`` is the minimum of ``--repeat`` runs; each per-call time
(rhs, solve, sympy, planar) is the minimum over ``--repeat`` (at least 3)
timing loops, so that a busy shared machine disturbs it least.

Usage: python benchmarks/bench_cases.py [--repeat R] [--t-end T] [--cases NAME ...]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import sys

import numpy as np

import gibbsimpact as gi
from gibbsimpact.dynamics.gibbs_appell import forward_dynamics

ROOT = Path(__file__).resolve().parent.parent
CASES = ROOT / "cases"
sys.path.insert(0, str(ROOT / "tests"))

FREE_CASES = ("circle_two_link", "sphere_single_link")
PRISMATIC_CASES = ("fixed_base_R_Pb_arm", "fixed_base_R_Pa_arm")
#: The prismatic arms' reference run (their files' settings before method auto).
TIGHT_DOP853 = {"method": "DOP853", "rtol": 1e-8, "atol": 1e-10}
ALL_CASES = FREE_CASES + PRISMATIC_CASES


class NotApplicable(Exception):
    """A reference derivation does not cover this chain (the message says why)."""


def symbolic_rhs(model):
    """forward_dynamics of the sympy oracle for the same chain (uniform links only)."""
    if not model.chain.free_base:
        raise NotApplicable("sympy oracle: free-flying chains only")
    if any(getattr(j, "kind", "R") != "R" for j in model.chain.joints):
        raise NotApplicable("sympy oracle: revolute joints only")
    from reference.sympy_chain import RefLink, RefMode, reference_model

    links = tuple(
        RefLink(lk.length, lk.mass_per_length, lk.EI_y, lk.EI_z,
                tuple(RefMode(m.kind, m.direction, m.number) for m in lk.modes), lk.rotary_inertia)
        for lk in model.chain.links
    )
    return reference_model(links, tuple(model.gravity)).forward_dynamics


def planar_rhs(model):
    """forward_dynamics of the planar oracle (tests/reference/planar_oracle.py) for the same chain."""
    chain = model.chain
    if chain.free_base:
        raise NotApplicable("planar oracle: fixed base only")
    from reference.planar_oracle import PlanarChain, link

    b1, b2, b3 = chain.base.position
    g = tuple(float(v) for v in model.gravity)
    if b3 != 0.0 or g[2] != 0.0:
        raise NotApplicable("planar oracle: planar chains only (base and gravity in the X1-X2 plane)")
    links = []
    for lk, jt in zip(chain.links, chain.joints):
        ei = lk.EI if isinstance(lk.EI, tuple) else (lk.EI, lk.EI)
        if lk.modes or tuple(lk.element_directions) != ("y",) and lk.elements:
            raise NotApplicable("planar oracle: rigid or in-plane finite-element links only")
        if any(callable(v) for v in (lk.mass_per_length, *ei)) or any(lk.rotary_inertia):
            raise NotApplicable("planar oracle: uniform links without rotary inertia only")
        kind = getattr(jt, "kind", "R")
        links.append(link(kind, lk.length, lk.mass_per_length, ei[1], lk.elements,  # EI_z bends in-plane
                          gamma=getattr(jt, "angle", 0.0), c=getattr(jt, "half_length", 0.0)))
    orc = PlanarChain(links, base=(b1, b2, chain.base.angle), gravity=g[:2])
    if orc.coordinate_names != tuple(model.coordinate_names):
        raise NotApplicable(f"planar oracle: coordinates {orc.coordinate_names} != {model.coordinate_names}")
    return orc.forward_dynamics


def best_of(fn, repeat):
    best = np.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def per_call(fn, n=400, repeat=3):
    """Minimum over ``repeat`` loops of ``n`` calls of the time per call [s]."""
    fn()
    best = np.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        for _ in range(n):
            fn()
        best = min(best, (time.perf_counter() - t0) / n)
    return best


def simulate_kwargs(name, case, t_end):
    """simulate's arguments: the free-flying cases as before, the prismatic ones with their own settings but
    DOP853 at rtol 1e-8, atol 1e-10 (TIGHT_DOP853: the run their reference numbers quote; the files themselves
    run method auto at rtol 1e-2 since 2026-11-27, docs/benchmarks.md "Stiff chains")."""
    if name in FREE_CASES:
        t_span = (case.t_span[0], t_end if t_end else case.t_span[1])
        return {"model": case.model, "q0": case.q0, "qdot0": case.qdot0, "t_span": t_span, "walls": case.walls,
                "restitution": case.restitution, "rtol": 1e-10, "atol": 1e-12, "method": "DOP853"}
    return case.simulate_kwargs(**TIGHT_DOP853, **({"t_end": t_end} if t_end else {}))


def energy_errors(res):
    """(flight-phase error as simulate reports it, max |E - E0 - (W - W0)| / |E0| over the run)."""
    E = res.energy().total
    dE = E - E[0]
    if res.work is not None:
        W = np.asarray(res.work).sum(axis=1)
        dE = dE - (W - W[0])
    return res.energy_error, float(np.max(np.abs(dE)) / abs(E[0]))


def reference_ratio(make, model, q0, qd0, t_rhs, repeat, n_calls, rng):
    """(t_rhs / t_ref, agreement of qddot at a perturbed state, reason when not applicable)."""
    try:
        ref = make(model)
    except NotApplicable as exc:
        return None, None, str(exc)
    q = q0 + np.array([0.01 * rng.uniform(-1, 1) if nm.startswith("delta") else 0.0
                       for nm in model.coordinate_names])
    qd = qd0 + rng.normal(size=qd0.size)
    a_gi, a_ref = forward_dynamics(model, q, qd), np.asarray(ref(q, qd))
    err = float(np.abs(a_ref - a_gi).max() / np.abs(a_gi).max())
    t_ref = per_call(lambda: ref(q0, qd0), n_calls, repeat)
    return t_rhs / t_ref, err, None


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3, help="runs per measurement; the best is reported")
    ap.add_argument("--t-end", type=float, default=None, help="override the cases' end time [s]")
    ap.add_argument("--cases", nargs="+", choices=ALL_CASES, default=list(ALL_CASES), metavar="NAME",
                    help=f"cases to run (default: all of {', '.join(ALL_CASES)})")
    args = ap.parse_args(argv)
    rows, notes = [], []
    rng = np.random.default_rng(0)
    loops = max(3, args.repeat)
    for name in args.cases:
        case = gi.load_case(CASES / f"{name}.toml")
        kw = simulate_kwargs(name, case, args.t_end)
        # Writeable copies: Case.q0/qdot0 are read-only, and forward_dynamics given a read-only array
        # takes its slow fallback path (a refused kernel dispatch, then a copy): ~40x the cost of a call.
        model, q0, qd0 = case.model, case.q0.copy(), case.qdot0.copy()
        gi.simulate(**{**kw, "t_span": (kw["t_span"][0], kw["t_span"][0] + 1e-3)})  # warm: kernel, inputs
        wall, res = best_of(lambda: gi.simulate(**kw), args.repeat)
        N = model.n_dof
        t_rhs = per_call(lambda: forward_dynamics(model, q0, qd0), 400, loops)
        A = model.mass_matrix(q0)
        b = np.ones(N)
        t_solve = per_call(lambda: np.linalg.solve(A, b), 2000, loops)
        sym, sym_err, sym_why = reference_ratio(symbolic_rhs, model, q0, qd0, t_rhs, loops, 400, rng)
        pl, pl_err, pl_why = reference_ratio(planar_rhs, model, q0, qd0, t_rhs, loops, 40, rng)
        flight, total = energy_errors(res)
        rows.append(dict(
            case=name, N=N, wall_s=wall, steps=res.n_steps, nfev=res.nfev, impacts=len(res.impacts),
            energy_error_flight=flight, energy_error_total=total,
            rhs_us=t_rhs * 1e6, rhs_per_solve=t_rhs / t_solve, loop_overhead=wall / (res.nfev * t_rhs),
            rhs_per_sympy=sym, rhs_per_planar=pl, status=res.status,
        ))
        checks = [f"{lb} {e:.1e}" for lb, e in (("sympy", sym_err), ("planar", pl_err)) if e is not None]
        why = "; ".join(w for w in (sym_why, pl_why) if w)
        notes.append(f"{name}: rtol {kw.get('rtol', 1e-10):g}, atol {kw.get('atol', 1e-12):g}"
                     f"{', inputs' if kw.get('inputs') else ''}, status {res.status}; qddot vs "
                     f"{', '.join(checks) or '-'}" + (f" (n/a: {why})" if why else ""))
    cols = [("case", "{:<20}"), ("N", "{:>3}"), ("wall_s", "{:>8.3f}"), ("steps", "{:>6}"), ("nfev", "{:>7}"),
            ("impacts", "{:>7}"), ("energy_error_flight", "{:>10.2e}"), ("energy_error_total", "{:>10.2e}"),
            ("rhs_us", "{:>8.1f}"), ("rhs_per_solve", "{:>9.1f}"), ("loop_overhead", "{:>8.3f}"),
            ("rhs_per_sympy", "{:>9.3f}"), ("rhs_per_planar", "{:>10.4f}")]
    heads = ["case", "N", "wall[s]", "steps", "nfev", "impacts", "dE_flight", "dE_total", "rhs[us]",
             "rhs/solve", "loop/rhs", "rhs/sympy", "rhs/planar"]

    def cell(r, c, fmt):
        if r[c] is None:
            width = len(fmt.format(0.0))
            return f"{'n/a':>{width}}"
        return fmt.format(r[c])

    print(" ".join(f"{h:>{len(cell(rows[0], c, fmt))}}" for h, (c, fmt) in zip(heads, cols)))
    for r in rows:
        print(" ".join(cell(r, c, fmt) for c, fmt in cols))
    for line in notes:
        print("  " + line)
    return rows


if __name__ == "__main__":
    main()
