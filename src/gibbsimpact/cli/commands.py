"""Command line: the parser of every command, ``gibbsimpact show CASE.toml ...`` and
``gibbsimpact equations CASE.toml``; ``run`` is cli/run.py (writing its files cli/outputs.py),
``sweep`` cli/sweep.py.

Exit codes (EXIT_CODES in cli/common.py, also in ``--help``): 0 success; 2 bad input (invalid
case file, bad option, unreadable file, an output folder that cannot be
written), nothing simulated; 3 the simulation stopped early (status zeno,
max_impacts, penetration, joint_limit, failed, callback_failed or budget_exceeded; the
partial results are still written); 4 the results could not all be written into the output
folder (the essential ones then go to a temporary folder);
130 interrupted by Ctrl-C or SIGTERM (status "interrupted"; the partial
data and summary.json are still written, not the figures); 1 an unexpected error.
With several case files the worst code of the runs counts. Errors are reported on stderr as
``gibbsimpact: error: <reason>``; warnings raised during a run are summed up
in one line after it.
"""

from __future__ import annotations

import argparse
import sys
import textwrap
from pathlib import Path

from .common import (EXIT_BAD_INPUT, EXIT_CODES, EXIT_INTERNAL, EXIT_INTERRUPTED, EXIT_OK,  # noqa: F401
                     EXIT_OUTPUT, EXIT_STOPPED, _error, _float, _load, _positive_int, _worst, add_limit_options,
                     add_method_option, add_rtol_option)
from .outputs import OUTPUT_FILES, clear_outputs, output_names, write_outputs
from .report import saved_result_path, saved_result_text, show_argument_error
from .run import cmd_run

# Public names of gibbsimpact.cli (its __init__ takes them from here), the run's from cli/run.py and outputs.py.
__all__ = ["EXIT_OK", "EXIT_INTERNAL", "EXIT_BAD_INPUT", "EXIT_STOPPED", "EXIT_OUTPUT", "EXIT_INTERRUPTED",
           "EXIT_CODES", "OUTPUT_FILES", "build_parser", "describe_case", "cmd_show", "cmd_equations",
           "output_names", "clear_outputs", "write_outputs", "cmd_run", "main"]


def _run_help(prog) -> argparse.HelpFormatter:
    """The help of ``run``: its column where the options up to ``--method METHOD`` put it (19); the longer
    limits (``--max-rhs-calls N``) start their help on the next line instead of pushing every column right."""
    return argparse.RawDescriptionHelpFormatter(prog, max_help_position=19)


def build_parser() -> argparse.ArgumentParser:
    from .. import __version__

    p = argparse.ArgumentParser(
        prog="gibbsimpact",
        description="Free-flying flexible multi-link chains colliding with curved walls.",
        epilog=f"Case-file format: docs/case-format.md.\n\n{EXIT_CODES}",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--version", action="version", version=f"gibbsimpact {__version__}")
    sub = p.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True

    r = sub.add_parser("run", help="run cases and write CSV, JSON, NPZ and figures", formatter_class=_run_help,
                       description=textwrap.fill(
                           "Run each CASE and write summary.json, result.npz, impacts.csv, timeseries.csv and PNG "
                           "figures into its output folder, in that order (summary.json again at the end, listing "
                           "what was written). The folder is created and checked before the run; files an earlier "
                           "run left there under these names are removed when the results are written (other "
                           "files are kept); every file is written atomically. When a file cannot be written "
                           "(disk full) the others are still tried, summary.json and result.npz go to a "
                           "temporary folder, the figures are skipped, and the exit code is 4. Ctrl-C or SIGTERM "
                           "stops a run with status 'interrupted' and writes its data and summary.json so far, "
                           "without the figures (one while the results are written stops the figures; another "
                           "one aborts the writing).", 79),
                       epilog=EXIT_CODES)
    r.add_argument("case", metavar="CASE.toml", nargs="+", help="case file(s), run one after the other")
    r.add_argument("--out", metavar="DIR",
                   help="output folder (default: the case's [output] directory, else out/<case name>); with "
                        "several case files each writes into DIR/<case file name without .toml>")
    r.add_argument("--t-end", type=_float, metavar="T", help="end time in s (overrides [time] t_end_s)")
    add_rtol_option(r)
    r.add_argument("--atol", type=_float, help="absolute tolerance (overrides [solver] atol)")
    r.add_argument("--output-dt", type=_float, metavar="DT",
                   help="uniform output interval in s (overrides [solver] output_dt_s)")
    add_method_option(r)
    add_limit_options(r)
    r.add_argument("--csv-every", type=_positive_int, default=1, metavar="K",
                   help="write every K-th sample (and the last) into timeseries.csv and contact_forces.csv "
                        "(default 1: every sample; result.npz always keeps them all)")
    r.add_argument("--no-plots", action="store_true", help="do not draw figures")
    r.add_argument("--animate", action="store_true", help="also write animation.gif")
    r.add_argument("--quiet", "-q", action="store_true", help="no progress bar and no report on stdout")

    s = sub.add_parser("show", help="describe cases (model, initial energy and gaps) or saved runs (status, "
                                    "impacts, energy audit, method)",
                       description="Describe the model of each CASE in words without running it; for a saved "
                                   "run (an output folder of 'gibbsimpact run', or a result .npz file) print its "
                                   "report instead: status, method, impacts, energy balance and audit, cost.")
    s.add_argument("case", metavar="CASE.toml|RESULT", nargs="+",
                   help="case file(s), or output folder(s) holding result.npz, or result .npz file(s)")

    e = sub.add_parser("equations", help="derive the symbolic equations of motion of a case's chain",
                       description="Derive M(q) qddot = forcing(q, qdot) of CASE symbolically (gi.derive_equations), "
                                   "print the operation counts after common-subexpression elimination, and "
                                   "optionally write them as LaTeX and as a standalone numpy module.")
    e.add_argument("case", metavar="CASE.toml", help="case file")
    e.add_argument("--method", choices=("gibbs-appell", "lagrange"), default="gibbs-appell",
                   help="derivation route (default gibbs-appell; lagrange is the comparison route)")
    e.add_argument("--latex", metavar="FILE", help="write the equations as a LaTeX document")
    e.add_argument("--python", metavar="FILE", help="write a standalone module computing M and the forcing")
    from .sweep import add_parser as add_sweep_parser

    add_sweep_parser(sub)
    return p


# --------------------------------------------------------------------------
# show

def describe_case(case) -> str:
    """The model of a case in words (what ``gibbsimpact show`` prints)."""
    import numpy as np

    from ..dynamics.inputs import describe_input, is_angle_coordinate
    from ..contact.walls import describe

    m = case.model
    lines = [f"case {case.name}" + (f" ({case.path})" if case.path else "")]
    if case.description:
        lines.append(f"  {case.description}")
    lines.append("")
    lines.append(f"chain: {m.n_links} link(s), N = {m.n_dof} generalised coordinates, {2 * m.n_dof} first-order ODEs, "
                 f"total mass {m.total_mass:g} kg")
    lines.append(_describe_base(m))
    lines += _describe_joints(case)
    lines.append("coordinates, in order (initial value, initial rate):")
    for k, name in enumerate(m.coordinate_names):
        unit = "rad" if is_angle_coordinate(m, k) else "m"
        extra = f" = {np.degrees(case.q0[k]):.6g} deg" if unit == "rad" and case.q0[k] != 0 else ""
        lines.append(f"  {k + 1:2d}  {name:<12s} {case.q0[k]:>13.6g} {unit:<3s}{extra:<18s}"
                     f" {case.qdot0[k]:>11.6g} {unit}/s")
    lines.append("")
    lines.append("links:")
    for i in range(1, m.n_links + 1):
        lines += _describe_link(m, i, case.q0)
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
    if case.contact_filter is not None:
        lines.append(f"contact filter: {case.contact_filter.describe()}")
    if case.prescribed:
        lines.append("prescribed (the coordinate follows its profile; its actuator supplies the effort):")
        for name, prof in case.prescribed:
            angle = is_angle_coordinate(m, m.coordinate_names.index(name))
            lines.append(f"  {name}: {_describe_profile(prof, angle)}")
    E = case.initial_energy()
    lines.append(f"initial energy: kinetic {E.kinetic:.9g} J, gravitational {E.gravity:.9g} J, "
                 f"strain {E.strain:.9g} J, total {E.total:.9g} J")
    if case.walls:
        lines.append("initial gaps g (distance on the free side of the wall, m):")
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
    lines.append(f"cost: {case.estimate_cost().describe()}")
    return "\n".join(lines)


def _describe_profile(prof, angle: bool) -> str:
    """One line: a gibbsimpact.profiles Profile's kind and parameters with their units (rad or m on the coordinate:
    q values in rad | m, rates in rad/s | m/s, times in s; a samples profile by its span and count)."""
    u = "rad" if angle else "m"
    if prof.kind == "samples":
        t = prof.parameters["t"]
        return f"samples: {len(t)} values from t = {t[0]:g} s to {t[-1]:g} s, cubic spline"
    units = {"q_a": u, "q_b": u, "q0": u, "t_a": "s", "t_b": "s", "T_s": "s", "Omega_s": f"{u}/s", "v": f"{u}/s"}
    return f"{prof.kind}: " + ", ".join(f"{k} = {v:g} {units[k]}" for k, v in prof.parameters.items())


def _describe_link(m, i: int, q0) -> list:
    """The lines of link i (1-based): its section, modes or elements, damping and attached bodies."""
    import numpy as np

    from ..model.modes import natural_frequency

    lk = m.chain.links[i - 1]
    ei_y, ei_z = lk.EI
    lines = [f"  link {i}: l = {lk.length:g} m, mu = {lk.mass_per_length:g} kg/m, "
             f"EI_y = {ei_y:g} N m^2, EI_z = {ei_z:g} N m^2, rotary inertia (j_x, j_y, j_z) = "
             f"({', '.join(f'{j:g}' for j in lk.rotary_inertia)}) kg m"]
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
        lines += _describe_elements(m, i, q0)
    if lk.damping:
        lines.append(_describe_damping(m, i))
    return lines + _describe_bodies(m, i)


def _describe_bodies(m, i: int) -> list:
    """One line per rigid body attached to link i (1-based), and the link's omega_1 with them."""
    lk, ld = m.chain.links[i - 1], m.link_data[i - 1]
    lines = []
    for k, b in enumerate(lk.bodies, start=1):
        what = "hub" if b.at == 0.0 else ("payload at the tip" if b.at == lk.length else "body")
        J = ", ".join(f"{b.inertia[a][a]:g}" for a in range(3))
        lines.append(f"    bodies[{k}] ({what}): m = {b.mass:g} kg at x = {b.at:g} m, centre offset "
                     f"({', '.join(f'{c:g}' for c in b.center)}) m, inertia (J_xx, J_yy, J_zz) = ({J}) kg m^2")
    if lk.bodies and ld.K.size:
        lines.append(f"    with its bodies, clamped at its frame: omega_1 = {ld.first_frequency:.6g} rad/s")
    return lines


def _describe_base(m) -> str:
    """One line: the base of the chain."""
    import numpy as np

    if m.chain.base == "planar":
        return "base: free-flying in the X1-X2 plane (O1 at X1, X2; link 1 turned by theta_1 about X3)"
    if m.free_base:
        return "base: free-flying (O1 at X1, X2, X3; rotations theta_-1, theta_0, theta_1)"
    base = m.chain.base
    pos = ", ".join(f"{c:g}" for c in base.position)
    what = {"R": "joint 1 turns link 1 by theta_1 about z there",
            "Pa": "joint 1 is a carriage on a rail along the base x axis",
            "Pb": "joint 1 is a guide at the base origin that link 1 slides through",
            "W": "joint 1 welds link 1 to the base there (no coordinate)"}[m.chain.joints[0].kind]
    return f"base: fixed at ({pos}) m, angle {np.degrees(base.angle):g} deg about X3; {what}"


def _describe_tree_joint(m, i: int, jt) -> str:
    """What joint i (1-based) of a tree or a weld is: 'R (revolute): link 3 turns by theta_3 about z
    on link 1 at x = 0.4 m', 'W (weld): link 2 fixed at -40 deg at the tip of link 1'."""
    import numpy as np

    p, xa = m.chain.parents[i - 1], m.chain.attach[i - 1]
    where = "on the base" if p < 0 else (f"at the tip of link {p + 1}" if xa is None else f"on link {p + 1} at x = {xa:g} m")
    if not jt.spec.has_coordinate:
        return f"W (weld, no coordinate): link {i} fixed at {np.degrees(jt.angle):g} deg {where}"
    return f"R (revolute): link {i} turns by {m.coordinate_names[m.theta_index[i - 1]]} about z {where}"


def _describe_joints(case) -> list:
    """Lines on the joints: type, fixed angle, half-length and range of each prismatic joint."""
    import numpy as np

    m = case.model
    joints = m.chain.joints
    if all(j.spec.turns for j in joints) and m.chain.serial:
        return ["joints: all revolute (theta_i turns link i about z at the tip of link i-1, or at the base)"]
    lines = ["joints:"]
    for i, (jt, k) in enumerate(zip(joints, m.theta_index), start=1):
        host = "the base" if i == 1 else f"link {i - 1}"
        if not m.chain.serial or not jt.spec.has_coordinate:  # a tree (formulation §17): each joint's host and abscissa
            lines.append(f"  joint {i}: {_describe_tree_joint(m, i, jt)}")
            continue
        name = m.coordinate_names[k]
        if jt.spec.turns:
            lines.append(f"  joint {i}: R (revolute): link {i} turns by {name} about z at the "
                         f"{'base' if i == 1 else f'tip of link {i - 1}'}")
            continue
        lo, hi = jt.range
        now = f", {case.q0[k]:g} m at t0"
        angle = f"{np.degrees(jt.angle):g} deg"
        if jt.spec.carriage:
            rail = "a straight rigid rail along the base x axis" if i == 1 else host
            lines.append(f"  joint {i}: Pa (sliding prismatic): a carriage of half-length c = {jt.half_length:g} m runs "
                         f"along {rail}, link {i} fixed to it at {angle}; {name} (the carriage centre's position "
                         f"along {host}) in [{lo:g}, {hi:g}] m{now}")
        else:
            guide = "at the base origin" if i == 1 else f"at the tip of link {i - 1}, turned {angle} from its tangent"
            lines.append(f"  joint {i}: Pb (fixed prismatic): link {i} slides through a guide {guide}"
                         f"{f', at {angle} to the base x axis' if i == 1 else ''}; {name} (the length protruding "
                         f"from the guide) in [{lo:g}, {hi:g}] m{now}")
    return lines


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


def _describe_elements(m, i: int, q0=None) -> list:
    """Lines on the finite elements of link i (1-based): coordinates and lowest clamped-free frequencies.

    A link behind a Pb guide bends over its protruding length d only (stretching elements): its
    frequencies are those of a clamped-free beam of length d, shown at d(q0), and the highest also at
    d_min, where it is largest (omega ~ 1/d^2).
    """
    import numpy as np

    from ..model.modes import Mode, natural_frequency

    lk, ld, idx = m.chain.links[i - 1], m.link_data[i - 1], m.delta_index[i - 1]
    jt = m.chain.joints[i - 1]
    names = m.coordinate_names
    lines = []
    per = 2 * lk.elements
    length, scale, at = lk.length, 1.0, ""
    if jt.spec.guide:
        d0 = float(q0[m.theta_index[i - 1]]) if q0 is not None else jt.range[1]
        length, scale = d0, (lk.length / d0) ** 2
        at = f" at the protruding length {names[m.theta_index[i - 1]]} = {d0:g} m"
    for j, d in enumerate(lk.element_directions):
        first, last = names[idx[j * per]], names[idx[(j + 1) * per - 1]]
        what = "v (in-plane)" if d == "y" else "w (out-of-plane)"
        kind = "stretching Hermite cubic element(s) on the protruding length" if jt.spec.guide \
            else "Hermite cubic element(s)"
        lines.append(f"    {lk.elements} {kind} in {d}, bending {what}: {first} ... {last} = "
                     f"(deflection m, slope rad) at nodes 1 ... {lk.elements}")
        ei = lk.EI_z if d == "y" else lk.EI_y
        w = _element_frequencies(ld, d) * scale
        shown = []
        for n, omega in enumerate(w[:3], start=1):
            exact = natural_frequency(Mode("clamped-free", d, n), length, lk.mass_per_length, ei) \
                if not callable(ei) and not callable(lk.mass_per_length) else None
            beam = f" (beam {exact:.6g})" if exact is not None else ""
            shown.append(f"{omega:.6g}{beam}")
        lines.append(f"      clamped-free omega{at} = {', '.join(shown)} rad/s; highest {w[-1]:.4g} rad/s "
                     f"(period {2 * np.pi / w[-1]:.3g} s)")
        if jt.spec.guide:
            w_min = w[-1] / scale * (lk.length / jt.range[0]) ** 2
            lines.append(f"      omega ~ 1/d^2: the highest is {w_min:.4g} rad/s at d_min = {jt.range[0]:g} m "
                         f"(period {2 * np.pi / w_min:.3g} s)")
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
    """Describe every case or saved run given; the exit code is the worst (2 if any file is bad)."""
    code, shown = EXIT_OK, 0
    for path in args.case:
        saved = saved_result_path(path)
        if saved is not None:
            bad = _show_saved(path, saved, shown)
            code, shown = _worst(code, bad), shown + (bad == EXIT_OK)
            continue
        wrong = show_argument_error(path)
        case, bad = (None, _error(wrong, EXIT_BAD_INPUT)) if wrong else _load(path)
        if case is None:
            code = _worst(code, bad)
            continue
        if shown:
            print()
        print(describe_case(case), flush=True)
        from ..simulation.validity import check_state

        for msg in check_state(case.model, case.q0, case.qdot0, case.walls):
            print(f"gibbsimpact: {path}: validity warning: {msg}", file=sys.stderr)
        shown += 1
    return code


def _show_saved(argument, path: Path, shown: int) -> int:
    """Print the report of the saved run at ``path`` (cli/report.py); 2 after an error line when it is none."""
    import zipfile

    if not path.is_file():
        return _error(f"RESULT: {argument!r}: no such file; give a result .npz or the output folder of a run",
                      EXIT_BAD_INPUT)
    from ..io.result_files import load_result
    from ..simulation.validity import check_run

    try:
        result, meta = load_result(path, with_metadata=True)
        text = saved_result_text(result, meta, path)
    except (ValueError, OSError, KeyError, zipfile.BadZipFile) as exc:
        return _error(f"RESULT: {argument!r}: not a readable gibbsimpact result ({exc}); give the result.npz "
                      "that 'gibbsimpact run', Result.save or a sweep wrote", EXIT_BAD_INPUT)
    print(("\n" if shown else "") + text, flush=True)
    # The warnings the run issued (run prints them on stderr in these words), recomputed from the saved Result.
    for msg in check_run(result):
        print(f"gibbsimpact: {argument}: validity warning: {msg}", file=sys.stderr)
    return EXIT_OK


def cmd_equations(args) -> int:
    case, code = _load(args.case)
    if case is None:
        return code
    from ..symbolic.derive import derive_equations

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


def main(argv=None) -> int:
    """Entry point of the ``gibbsimpact`` console script and ``python -m gibbsimpact``."""
    parser = build_parser()
    args = parser.parse_args(argv)
    from .sweep import main as cmd_sweep

    handler = {"run": cmd_run, "show": cmd_show, "equations": cmd_equations, "sweep": cmd_sweep}[args.command]
    try:
        return handler(args)
    except BrokenPipeError:
        return EXIT_OK
    except KeyboardInterrupt as exc:
        return _error(f"interrupted ({exc or 'SIGINT'})", EXIT_INTERRUPTED)
    except Exception as exc:  # noqa: BLE001 - one line instead of a traceback
        return _error(f"unexpected {type(exc).__name__}: {exc} (please report this)", EXIT_INTERNAL)


if __name__ == "__main__":
    sys.exit(main())
