"""What a run did, in lines of text: ``gibbsimpact run`` prints them after each run, and ``gibbsimpact show``
prints them for a saved run (an output folder of ``run``, or any ``result.npz`` that Result.save or a sweep
wrote), read back with gibbsimpact.load_result, followed on stderr by the validity warnings the run issued
(recomputed from the Result: simulation.validity.check_run).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..plotting.labels import _point_name
from ..simulation.auto import RIGID_ROUNDOFF
from ..simulation.charts import recharts_text
from ..simulation.stability import free_vibration_frequencies

#: Impacts listed one per line; the others are counted (impacts.csv has them all).
SHOWN_IMPACTS = 20
#: The file of a run's output folder that ``show FOLDER`` reads.
RESULT_FILE = "result.npz"


def run_report_lines(result) -> list[str]:
    """The report of a Result: status, method, the first SHOWN_IMPACTS impacts, recharts, energy and audit, cost.

    Energies in J (E = kinetic + gravitational + strain, docs/theory.md §5); the energy drift is
    E(t_end) - E(t0) (with inputs or damping the power-balance error E - W, §9), relative to
    Result.energy_scale; the audit splits E(t_end) - E(t0) into inputs, damping and friction,
    actuators, impacts and the numerical rest (Result.energy_audit). The last line is the cost:
    right-hand-side evaluations and wall time [s].
    """
    E = result.energy()
    lines = [f"status: {result.status} ({result.message})", _method_line(result.settings)]
    if isinstance(result.settings.get("cutoff_frequency"), (int, float)):
        lines.append(cutoff_line(result.model_at(0), result.q[0], result.settings["cutoff_frequency"]))
    for k, rec in enumerate(result.impacts[:SHOWN_IMPACTS], start=1):
        joints = "+".join(f"end stop of joint {j}" if w < 0 else _point_name(result.model, j, result.walls)
                          for j, w in zip(rec.joints, rec.wall))
        lines.append(f"  impact {k}: t = {rec.time:.6f} s  {joints}")
    if len(result.impacts) > SHOWN_IMPACTS:
        lines.append(f"  ... {len(result.impacts)} impacts in all (a run folder's impacts.csv; Result.impacts)")
    if result.charts:
        lines.append(recharts_text(result.charts) + ": theta_-1, theta_0, theta_1 jump there, the orientation does "
                     "not (base_qw ... base_qz in timeseries.csv; docs/theory.md §2.1)")
    what = "power-balance error E - W" if result.work is not None else "energy drift"
    lines.append(f"energy: {E.total[0]:.9g} J -> {E.total[-1]:.9g} J; {what} over the whole run "
                 f"{result.energy_error_whole_run_J:.3g} J (relative {result.energy_error_whole_run:.2e} of the scale "
                 f"{result.energy_scale:.4g} J); max per flight phase {result.energy_error_per_phase:.2e} (relative)")
    audit = result.energy_audit()
    actuators = f"actuators {audit['actuators']:.4g}, " if result.prescribed else ""
    cutoff = result.settings.get("cutoff_frequency")
    # With a cutoff the numerical part is mostly the energy of the modes Radau stepped over, not an error.
    stepped = (f", cutoff {cutoff:.3g} rad/s: mostly the energy of the modes above it (given by impacts, inputs "
               f"or the initial state), stepped over and damped; docs/theory.md §14.1"
               if isinstance(cutoff, (int, float)) else "")
    if result.settings.get("stepped_phases"):
        lines.append(f"contact phases stepped (docs/theory.md §15.5): {result.settings['stepped_phases']}, "
                     f"{result.settings['contact_steps']} steps of at most {result.settings.get('contact_step'):g} s")
        actuators += f"stepped contacts {audit['stepped_contacts']:.4g}, "
    lines.append(f"energy audit [J]: inputs {audit['inputs']:.4g}, damping and friction "
                 f"{audit['damping_and_friction']:.4g}, {actuators}impacts {audit['impacts']:.4g}, numerical "
                 f"{audit['numerical']:.3g} ({result.settings.get('method')}{stepped})")
    lines.append(f"{result.nfev} right-hand-side evaluations, {result.wall_time:.2f} s")
    return lines


def _method_line(settings: dict) -> str:
    """One line: the solver and its tolerances, and why method="auto" chose it (Result.settings)."""
    tol = ", ".join(f"{k} {settings[k]:g}" for k in ("rtol", "atol") if isinstance(settings.get(k), (int, float)))
    line = f"method: {settings.get('method')}" + (f", {tol}" if tol else "")
    if settings.get("method_choice"):  # "auto: <method>, <why>" (simulation.auto.choose_method)
        line += f"; {settings['method_choice']}"
    return line


def cutoff_line(model, q0, cutoff: float) -> str:
    """One line: which of the model's free-vibration modes at q0 (N,) [m, rad] lie above the cutoff frequency
    [rad/s] (how many, and the lowest of them in rad/s and Hz), i.e. which modes the run's Radau left out of its
    error estimate and stepped over (simulation.stability.free_vibration_frequencies; docs/theory.md §14.1).
    Frequencies below RIGID_ROUNDOFF of the highest are rigid motions, not counted as modes."""
    omega = free_vibration_frequencies(model, q0)
    omega = omega[omega > RIGID_ROUNDOFF * omega.max(initial=0.0)]
    above = omega[omega > cutoff]
    head = f"cutoff {cutoff:.3g} rad/s ({cutoff / (2 * np.pi):.3g} Hz): "
    if above.size == 0:
        top = f" (the highest {omega[-1]:.4g} rad/s)" if omega.size else ""
        return head + (f"none of the model's {omega.size} free-vibration modes at t0 lies above it{top}: none is "
                       "stepped over")
    verb = "lies" if above.size == 1 else "lie"
    return head + (f"{above.size} of the model's {omega.size} free-vibration modes at t0 {verb} above it, the lowest "
                   f"at {above[0]:.4g} rad/s ({above[0] / (2 * np.pi):.4g} Hz): Radau leaves them out of its error "
                   "estimate and steps over them (their motion is not followed)")


def saved_result_path(argument) -> Path | None:
    """The result file a ``show`` argument names (a ``.npz`` file, or a folder holding RESULT_FILE), else None:
    the argument is then a case file."""
    p = Path(argument)
    if p.suffix == ".npz":
        return p
    if p.is_dir() and (p / RESULT_FILE).is_file():
        return p / RESULT_FILE
    return None


def show_argument_error(argument) -> str | None:
    """The error line for a ``show`` argument that is neither a case file nor a saved run, where the case-file
    error would mislead (a folder without RESULT_FILE, a run's summary.json, a missing path that is no .toml);
    None otherwise (a .toml is left to the case loader's errors)."""
    p = Path(argument)
    give = f"give a case .toml, the output folder of a run (holding {RESULT_FILE}) or a result .npz"
    if p.is_dir():
        return f"CASE.toml: {str(argument)!r} is a directory, not a case file, and holds no {RESULT_FILE}; {give}"
    if p.suffix == ".json" and p.is_file():
        return (f"CASE.toml|RESULT: {str(argument)!r} is a JSON file, not a case or a saved run; give the folder "
                f"holding it ({str(p.parent)!r}) or its {RESULT_FILE}")
    if p.suffix != ".toml" and not p.exists():
        return f"CASE.toml|RESULT: {str(argument)!r}: no such file or folder; {give}"
    return None


def describe_saved_result(path: Path) -> str:
    """A saved run in words (what ``gibbsimpact show FOLDER|result.npz`` prints on stdout): saved_result_text of
    the result at ``path``. Raises ValueError or OSError when ``path`` is no readable result."""
    from ..io.result_files import load_result

    result, meta = load_result(path, with_metadata=True)
    return saved_result_text(result, meta, path)


def saved_result_text(result, meta: dict, path: Path) -> str:
    """A saved Result in words: where it came from (meta's case name, ``path``), its model and span, then
    run_report_lines."""
    m = result.model
    case = f" of case {meta['case']}" if meta.get("case") else ""
    t_end = result.settings.get("t_span", [None, None])[1]
    asked = f" (asked for {t_end:g} s)" if isinstance(t_end, (int, float)) and t_end != result.t[-1] else ""
    lines = [f"saved run{case} ({path})",
             f"  {m.n_links} link(s), N = {m.n_dof} coordinates, {len(result.walls)} wall(s); "
             f"t = {result.t[0]:g} -> {result.t[-1]:g} s{asked}, {len(result.t)} samples, "
             f"{len(result.impacts)} impact(s)"]
    return "\n".join(lines + run_report_lines(result))
