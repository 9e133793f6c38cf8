"""Command line: ``gibbsimpact run CASE.toml`` and ``gibbsimpact show CASE.toml``.

Exit codes: 0 success; 2 bad input (invalid case file, bad option, unreadable
file); 3 the simulation stopped early (status zeno, max_impacts, penetration
or failed; the partial results are still written); 1 an unexpected error.
Errors are reported on stderr as ``gibbsimpact: error: <reason>``; warnings
raised during a run are summed up in one line after it.
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from pathlib import Path

EXIT_OK, EXIT_INTERNAL, EXIT_BAD_INPUT, EXIT_STOPPED = 0, 1, 2, 3


class _Progress:
    """One self-overwriting status line on stderr, shown once a run has lasted ``delay`` seconds.

    Silent when stderr is not a terminal (pipes, CI logs) or when disabled.
    """

    def __init__(self, t_span, enabled: bool, delay: float = 2.0, stream=None):
        self.stream = stream or sys.stderr
        self.enabled = enabled and hasattr(self.stream, "isatty") and self.stream.isatty()
        self.t0, self.t1 = t_span
        self.delay = delay
        self.started = time.monotonic()
        self.shown = False

    def __call__(self, t: float, n_impacts: int):
        if not self.enabled:
            return
        elapsed = time.monotonic() - self.started
        if elapsed < self.delay:
            return
        frac = (t - self.t0) / (self.t1 - self.t0) if self.t1 > self.t0 else 1.0
        width = 24
        bar = "#" * int(round(width * min(max(frac, 0.0), 1.0)))
        self.stream.write(
            f"\r  [{bar:<{width}}] t = {t:.4f} / {self.t1:g} s  impacts: {n_impacts}  elapsed {elapsed:5.1f} s "
        )
        self.stream.flush()
        self.shown = True

    def close(self):
        if self.shown:
            self.stream.write("\n")
            self.stream.flush()


def _error(msg: str, code: int) -> int:
    print(f"gibbsimpact: error: {msg}", file=sys.stderr)
    return code


def _float(text: str) -> float:
    # Only the syntax here; ranges are the case file's (case.RANGES), checked once the case is loaded.
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None


def build_parser() -> argparse.ArgumentParser:
    from . import __version__

    p = argparse.ArgumentParser(
        prog="gibbsimpact",
        description="Free-flying flexible multi-link chains colliding with curved walls.",
        epilog="Case-file format: docs/case-format.md. Exit codes: 0 ok, 2 bad input, 3 simulation stopped early.",
    )
    p.add_argument("--version", action="version", version=f"gibbsimpact {__version__}")
    sub = p.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True

    r = sub.add_parser("run", help="run a case and write CSV, JSON, NPZ and figures",
                       description="Run CASE and write timeseries.csv, impacts.csv, summary.json, result.npz "
                                   "and PNG figures into the output directory.")
    r.add_argument("case", metavar="CASE.toml", help="case file")
    r.add_argument("--out", metavar="DIR", help="output directory (default: [output] directory, else out/<case name>)")
    r.add_argument("--t-end", type=_float, metavar="T", help="end time in s (overrides [time] t_end_s)")
    r.add_argument("--rtol", type=_float, help="relative tolerance (overrides [solver] rtol)")
    r.add_argument("--atol", type=_float, help="absolute tolerance (overrides [solver] atol)")
    r.add_argument("--output-dt", type=_float, metavar="DT",
                   help="uniform output interval in s (overrides [solver] output_dt_s)")
    r.add_argument("--no-plots", action="store_true", help="do not draw figures")
    r.add_argument("--animate", action="store_true", help="also write animation.gif")
    r.add_argument("--quiet", "-q", action="store_true", help="no progress line and no report on stdout")

    s = sub.add_parser("show", help="describe a case: coordinates, frequencies, walls, initial energy and gaps",
                       description="Describe the model of CASE in words without running it.")
    s.add_argument("case", metavar="CASE.toml", help="case file")

    e = sub.add_parser("equations", help="derive the symbolic equations of motion of a case's chain",
                       description="Derive M(q) qddot = forcing(q, qdot) of CASE symbolically (gi.derive_equations), "
                                   "print the operation counts after common-subexpression elimination, and "
                                   "optionally write them as LaTeX and as a standalone numpy module.")
    e.add_argument("case", metavar="CASE.toml", help="case file")
    e.add_argument("--method", choices=("gibbs-appell", "lagrange"), default="gibbs-appell",
                   help="derivation route (default gibbs-appell; lagrange is the comparison route)")
    e.add_argument("--latex", metavar="FILE", help="write the equations as a LaTeX document")
    e.add_argument("--python", metavar="FILE", help="write a standalone module computing M and the forcing")
    return p


_GIVE_A_CASE = "give the path of a case file (e.g. cases/circle_two_link.toml)"


def _load(path: str):
    """(case, None), or (None, exit code) after one error line naming the CASE.toml argument."""
    from .case import CaseError, load_case

    p = Path(path)
    if not path:
        return None, _error(f"CASE.toml: '' is not a file; {_GIVE_A_CASE}", EXIT_BAD_INPUT)
    if p.is_dir():
        return None, _error(f"CASE.toml: {path!r} is a directory, not a case file; {_GIVE_A_CASE}", EXIT_BAD_INPUT)
    if not p.exists():
        return None, _error(f"CASE.toml: {path!r}: no such file; {_GIVE_A_CASE}", EXIT_BAD_INPUT)
    if not p.is_file():
        return None, _error(f"CASE.toml: {path!r} is not a regular file; {_GIVE_A_CASE}", EXIT_BAD_INPUT)
    try:
        return load_case(p), None
    except CaseError as exc:
        return None, _error(str(exc), EXIT_BAD_INPUT)
    except OSError as exc:
        return None, _error(f"CASE.toml: {path!r}: cannot read ({exc.strerror or exc})", EXIT_BAD_INPUT)


# --------------------------------------------------------------------------
# show

def describe_case(case) -> str:
    """The model of a case in words (what ``gibbsimpact show`` prints)."""
    import numpy as np

    from .inputs import describe_input, is_angle_coordinate
    from .modes import natural_frequency
    from .walls import describe

    m = case.model
    lines = [f"case {case.name}" + (f" ({case.path})" if case.path else "")]
    if case.description:
        lines.append(f"  {case.description}")
    lines.append("")
    lines.append(f"chain: {m.n_links} link(s), N = {m.n_dof} generalised coordinates, {2 * m.n_dof} first-order ODEs, "
                 f"total mass {m.total_mass:g} kg")
    lines.append(_describe_base(m))
    lines.append("coordinates, in order (initial value, initial rate):")
    for k, name in enumerate(m.coordinate_names):
        unit = "rad" if is_angle_coordinate(m, k) else "m"
        extra = f" = {np.degrees(case.q0[k]):.6g} deg" if unit == "rad" and case.q0[k] != 0 else ""
        lines.append(f"  {k + 1:2d}  {name:<12s} {case.q0[k]:>13.6g} {unit:<3s}{extra:<18s}"
                     f" {case.qdot0[k]:>11.6g} {unit}/s")
    lines.append("")
    lines.append("links:")
    for i, lk in enumerate(m.chain.links, start=1):
        ei_y, ei_z = lk.EI
        lines.append(f"  link {i}: l = {lk.length:g} m, mu = {lk.mass_per_length:g} kg/m, "
                     f"EI_y = {ei_y:g} N m^2, EI_z = {ei_z:g} N m^2, rotary inertia (j_x, j_y, j_z) = "
                     f"({', '.join(f'{j:g}' for j in lk.rotary_inertia)}) kg m")
        if not lk.modes and not lk.elements:
            lines.append("    rigid (no modes)")
        for k, md in zip(m.delta_index[i - 1], lk.modes):
            # A y-mode (deflection v) bends against EI_z, a z-mode (w) against EI_y.
            ei = ei_z if md.direction == "y" else ei_y
            w = natural_frequency(md, lk.length, lk.mass_per_length, ei)
            lines.append(f"    {m.coordinate_names[k]}: {md.kind} mode {md.number} in {md.direction}, "
                         f"beta l = {md.beta_l:.6f}, omega = {w:.6g} rad/s (f = {w / (2 * np.pi):.6g} Hz, "
                         f"period {2 * np.pi / w:.4g} s)")
        if lk.elements:
            lines += _describe_elements(m, i)
        if lk.damping:
            lines.append(_describe_damping(m, i))
    lines.append("")
    lines.append(f"gravity: ({', '.join(f'{g:g}' for g in m.gravity)}) m/s^2")
    lines.append(f"restitution (global): {case.restitution:g}")
    if case.walls:
        lines.append("walls:")
        for k, w in enumerate(case.walls, start=1):
            e = f"restitution {w.restitution:g}" if w.restitution is not None else "global restitution"
            lines.append(f"  walls[{k}]: {describe(w)}, {e}")
    else:
        lines.append("walls: none (free flight)")
    if case.inputs:
        lines.append("inputs (applied generalised forces, added up per coordinate):")
        for k, spec in enumerate(case.inputs, start=1):
            angle = is_angle_coordinate(m, m.coordinate_names.index(spec.coordinate))
            lines.append(f"  inputs[{k}] on {spec.coordinate}: {describe_input(spec, angle)}")
    else:
        lines.append("inputs: none")
    E = case.initial_energy()
    lines.append(f"initial energy: kinetic {E.kinetic:.9g} J, gravitational {E.gravity:.9g} J, "
                 f"strain {E.strain:.9g} J, total {E.total:.9g} J")
    if case.walls:
        lines.append("initial gaps g (distance inside the wall, m):")
        G = case.initial_gaps()
        P = m.joint_positions(case.q0)
        header = "  joint   position [m]                      " + "".join(f"  walls[{k + 1}]" for k in range(len(case.walls)))
        lines.append(header)
        for j in range(G.shape[1]):
            pos = "(" + ", ".join(f"{c:+.5f}" for c in P[j]) + ")"
            lines.append(f"  O{j + 1:<5d} {pos:<34s}" + "".join(f"  {G[k, j]:9.6g}" for k in range(len(case.walls))))
    lines.append("")
    t0, t1 = case.t_span
    solver = ", ".join(f"{k} = {v:g}" if isinstance(v, float) else f"{k} = {v}" for k, v in case.solver.items())
    lines.append(f"time: {t0:g} -> {t1:g} s; solver: {solver or 'defaults of gibbsimpact.simulate'}")
    return "\n".join(lines)


def _describe_base(m) -> str:
    """One line: the base of the chain."""
    import numpy as np

    if m.free_base:
        return "base: free-flying (O1 at X1, X2, X3; rotations theta_-1, theta_0, theta_1)"
    base = m.chain.base
    pos = ", ".join(f"{c:g}" for c in base.position)
    return (f"base: fixed at ({pos}) m, angle {np.degrees(base.angle):g} deg about X3; "
            "joint 1 turns link 1 by theta_1 about z there")


def _element_frequencies(ld, direction: str):
    """omega [rad/s] of one link's element model in one bending direction, ascending.

    The square roots of the generalised eigenvalues of (K, M_dd) on that direction's
    coordinates: the link clamped at its frame and free at its tip.
    """
    import numpy as np
    import scipy.linalg as sl

    b = [k for k, d in enumerate(ld.directions) if d == direction]
    w2 = sl.eigh(ld.K[np.ix_(b, b)], ld.M_dd[np.ix_(b, b)], eigvals_only=True)
    return np.sqrt(np.maximum(w2, 0.0))


def _describe_elements(m, i: int) -> list:
    """Lines on the finite elements of link i (1-based): coordinates and lowest clamped-free frequencies."""
    import numpy as np

    from .modes import Mode, natural_frequency

    lk, ld, idx = m.chain.links[i - 1], m.link_data[i - 1], m.delta_index[i - 1]
    names = m.coordinate_names
    lines = []
    per = 2 * lk.elements
    for j, d in enumerate(lk.element_directions):
        first, last = names[idx[j * per]], names[idx[(j + 1) * per - 1]]
        what = "v (in-plane)" if d == "y" else "w (out-of-plane)"
        lines.append(f"    {lk.elements} Hermite cubic element(s) in {d}, bending {what}: {first} ... {last} = "
                     f"(deflection m, slope rad) at nodes 1 ... {lk.elements}")
        ei = lk.EI_z if d == "y" else lk.EI_y
        w = _element_frequencies(ld, d)
        shown = []
        for n, omega in enumerate(w[:3], start=1):
            exact = natural_frequency(Mode("clamped-free", d, n), lk.length, lk.mass_per_length, ei) \
                if not callable(ei) and not callable(lk.mass_per_length) else None
            beam = f" (beam {exact:.6g})" if exact is not None else ""
            shown.append(f"{omega:.6g}{beam}")
        lines.append(f"      clamped-free omega = {', '.join(shown)} rad/s; highest {w[-1]:.4g} rad/s "
                     f"(period {2 * np.pi / w[-1]:.3g} s)")
    return lines


def _describe_damping(m, i: int) -> str:
    """The damping of link i (1-based): ratio, beta = 2 zeta / omega_1 and the highest mode's ratio."""
    import numpy as np
    import scipy.linalg as sl

    lk, ld = m.chain.links[i - 1], m.link_data[i - 1]
    w = np.sqrt(np.maximum(sl.eigh(ld.K, ld.M_dd, eigvals_only=True), 0.0))
    beta = 2.0 * lk.damping / w[0]
    return (f"    damping ratio {lk.damping:g} in the first elastic mode (omega_1 = {w[0]:.6g} rad/s): "
            f"Q = -beta K delta_dot, beta = {beta:.4g} s; the highest mode ({w[-1]:.4g} rad/s) has ratio "
            f"{lk.damping * w[-1] / w[0]:.3g}")


def cmd_show(args) -> int:
    case, code = _load(args.case)
    if case is None:
        return code
    print(describe_case(case))
    return EXIT_OK


def cmd_equations(args) -> int:
    case, code = _load(args.case)
    if case is None:
        return code
    from .symbolic import derive_equations

    for option in ("latex", "python"):
        target = getattr(args, option)
        if target is not None and not Path(target).parent.is_dir():
            return _error(f"--{option} {target}: the folder {Path(target).parent} does not exist; create it first",
                          EXIT_BAD_INPUT)
    m = case.model
    print(f"{case.name}: N = {m.n_dof} coordinates ({', '.join(m.coordinate_names)})")
    eqs = derive_equations(m, method=args.method, progress=True if sys.stderr.isatty() else None)
    ops = eqs.operation_count()
    print(f"method {args.method}: derived in {eqs.derivation_seconds:.2f} s, common subexpressions in "
          f"{eqs.cse_seconds:.2f} s")
    print(f"operations after CSE: {ops.adds} adds, {ops.muls} multiplications, {ops.functions} function calls "
          f"({ops.total} in all)")
    if args.latex:
        print(f"wrote {eqs.to_latex(args.latex)}")
    if args.python:
        print(f"wrote {eqs.to_python(args.python)}")
    return EXIT_OK


# --------------------------------------------------------------------------
# run

def write_outputs(result, case, out: Path, plots: bool, animate: bool, log=None) -> dict:
    """Write every output file of a run into ``out``; returns {name: Path}."""
    from .io import save_result, to_csv, write_summary_json

    log = log or (lambda s: None)
    out.mkdir(parents=True, exist_ok=True)
    paths = dict(to_csv(result, out))
    source = case.path.read_text() if case.path is not None and case.path.exists() else None
    paths["result"] = save_result(result, out / "result.npz", metadata={"case": case.name, "case_toml": source})
    if plots:
        log("drawing figures ...")
        from .plotting import plot_result, save_figures

        figs = plot_result(result, case_name=case.name, n_points=case.output["points_per_link"])
        paths.update(save_figures(figs, out, dpi=case.output["dpi"]))
    if animate:
        log("writing animation.gif ...")
        from .plotting import animate as make_animation

        paths["animation"] = make_animation(
            result, out / "animation.gif", fps=case.output["animation_fps"], speed=case.output["animation_speed"],
            n_points=case.output["points_per_link"], case_name=case.name,
        )
    # Last, so that it records the matplotlib version when figures were drawn.
    paths["summary"] = write_summary_json(result, out / "summary.json", case)
    return paths


def cmd_run(args) -> int:
    case, code = _load(args.case)
    if case is None:
        return code
    from .case import CaseError

    # Options override case-file keys and are held to the same ranges (case.RANGES).
    options = {"t_end": "--t-end", "rtol": "--rtol", "atol": "--atol", "output_dt": "--output-dt"}
    overrides = {kw: getattr(args, kw) for kw in options if getattr(args, kw) is not None}
    problems = case.override_problems(names=options, **overrides)
    if problems:
        return _error(str(CaseError("options", problems)), EXIT_BAD_INPUT)
    t0, t1 = case.t_span[0], overrides.get("t_end", case.t_span[1])
    out = Path(args.out) if args.out else case.output_directory
    say = (lambda s: None) if args.quiet else (lambda s: print(s, flush=True))

    progress = _Progress((t0, t1), enabled=not args.quiet)
    say(f"gibbsimpact: running {case.name}: t = {t0:g} -> {t1:g} s, N = {case.model.n_dof}, "
        f"{len(case.walls)} wall(s)")
    # Warnings of the run (numpy overflow, ...) are held back and summed up in one
    # line after the status or error line instead of interleaving with it.
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("default")  # each kind once, not once per step
        code = _simulate_and_write(case, args, overrides, out, progress, say)
    if caught:
        first = caught[0]
        print(f"gibbsimpact: warning: {len(caught)} kind(s) of warning during the run, the first: "
              f"{first.category.__name__}: {first.message} ({Path(first.filename).name}:{first.lineno}); "
              "check the results", file=sys.stderr)
    return code


def _simulate_and_write(case, args, overrides, out, progress, say) -> int:
    from .dynamics import SingularMassMatrixError

    try:
        result = case.simulate(progress=progress, **overrides)
    except (SingularMassMatrixError, ValueError) as exc:
        progress.close()
        return _error(f"{args.case}: {exc}", EXIT_BAD_INPUT)
    except KeyboardInterrupt:
        progress.close()
        return _error("interrupted", 130)
    progress.close()

    plots = case.output["plots"] and not args.no_plots
    animate = case.output["animate"] or args.animate
    try:
        paths = write_outputs(result, case, out, plots, animate, log=say)
    except OSError as exc:
        return _error(f"cannot write results to {out}: {exc.strerror or exc}", EXIT_BAD_INPUT)

    E = result.energy()
    say(f"status: {result.status} ({result.message})")
    for k, rec in enumerate(result.impacts[:20], start=1):
        joints = "+".join(f"O{j}" for j in rec.joints)
        say(f"  impact {k}: t = {rec.time:.6f} s  {joints}")
    if len(result.impacts) > 20:
        say(f"  ... {len(result.impacts)} impacts in all (impacts.csv)")
    say(f"energy: {E.total[0]:.9g} J -> {E.total[-1]:.9g} J; max relative drift in flight {result.energy_error:.2e}")
    say(f"{result.nfev} right-hand-side evaluations, {result.wall_time:.2f} s; {len(paths)} files in {out}")
    if result.status != "finished":
        return _error(f"simulation stopped early ({result.status}): {result.message}; "
                      f"partial results written to {out}", EXIT_STOPPED)
    return EXIT_OK


def main(argv=None) -> int:
    """Entry point of the ``gibbsimpact`` console script and ``python -m gibbsimpact``."""
    parser = build_parser()
    args = parser.parse_args(argv)
    handler = {"run": cmd_run, "show": cmd_show, "equations": cmd_equations}[args.command]
    try:
        return handler(args)
    except BrokenPipeError:
        return EXIT_OK
    except Exception as exc:  # noqa: BLE001 - one line instead of a traceback
        return _error(f"unexpected {type(exc).__name__}: {exc} (please report this)", EXIT_INTERNAL)


if __name__ == "__main__":
    sys.exit(main())
