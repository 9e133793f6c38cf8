"""Writing and reading results: CSV tables, a JSON summary, and a lossless NPZ archive.

Files (docs/case-format.md, "Output files"):

* ``timeseries.csv``: one row per sample: t, phase, every coordinate and
  velocity by name with its unit, the joint positions (and, for a spatial free base, its
  chart-free orientation base_qw .. base_qz: Result.base_orientation), the energies.
* ``impacts.csv``: one row per contact (an impact with k simultaneous
  contacts gives k rows sharing its ``impact`` number).
* ``episodes.csv``: one row per collision episode (Result.episodes): its times, walls,
  contact points, impacts, impulse, energy lost, effective restitution, maximum force and
  penetration (io.episode_files).
* ``contact_forces.csv`` (when some pair rested or pressed on a compliant wall): one row per sample:
  t, phase, and the normal force [N] of every (wall, contact point) pair in resting contact (0
  elsewhere), then (with friction on a wall) the friction force of each pair, world components,
  then (with compliant walls) the compliant normal force Fc_w<wall>_<point>_N of every (wall,
  contact column) pair: the joints, then the closest point of each flexible link ("link<i>"),
  and where that closest point is in contact, Xc_w<wall>_link<i>_X<a>_m (NaN out of contact).
* ``summary.json``: versions, settings, impacts, energies, status.
* ``result.npz``: everything in a :class:`~gibbsimpact.results.Result`
  (trajectory, every field of every impact, status, settings, counters, the
  model and the walls), so that :func:`load_result` gives back an equal Result.

Links, joints, walls and impacts are numbered from 1 in the files; in the
Python API ``ImpactRecord.wall`` is the 0-based index into ``Result.walls``.
An end-stop impact of a prismatic joint (``simulate(..., joint_limit="impact")``)
has ``wall == -1`` in the API, wall 0 in the files ("end stop of joint i").
Numbers are written with the shortest decimal text that reads back to the
same double.

Every file is written atomically (:func:`atomic_path`): into a temporary file
beside it, then renamed over it with ``os.replace``. A reader, a crash or an
interrupt never sees a half-written file: the old one or the whole new one.
"""

from __future__ import annotations

import csv
import json
import math
import os
import platform
import secrets
import sys
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from ..dynamics.gibbs_appell import Energy
from ..simulation.compliant import CompliantContact
from ..simulation.results import ImpactRecord, Result
from ..contact.walls import describe
from .contact_force_files import (_force_point_names, compliant_force_columns, contact_force_columns,
                                  has_contact_forces, stop_force_columns)
from .chart_files import base_summary, chart_arrays, charts_from
from .episode_files import EPISODE_COLUMNS, episode_rows, episode_cell
from .plain_data import model_from_dict, model_to_dict, wall_from_dict, wall_to_dict

__all__ = [
    "FORMAT_VERSION", "atomic_path", "check_directory", "load_result", "model_from_dict", "model_to_dict",
    "read_csv", "sample_rows", "save_figure", "save_result", "summary", "to_csv", "versions", "wall_from_dict",
    "wall_to_dict",
    "write_episodes_csv", "write_impacts_csv", "write_summary_json", "write_timeseries_csv",
]

#: Version of the NPZ layout written by save_result.
FORMAT_VERSION = 1


# --------------------------------------------------------------------------
# Atomic files and the output folder

#: Marks the temporary files of atomic_path: ``.<stem>.<random>.gibbsimpact-tmp<suffix>``.
TEMP_MARK = ".gibbsimpact-tmp"


def temporary_name(path) -> Path:
    """A fresh name beside ``path`` for its temporary file; it keeps the suffix (savefig and numpy look at it)."""
    path = Path(path)
    return path.with_name(f".{path.stem}.{secrets.token_hex(4)}{TEMP_MARK}{path.suffix}")


@contextmanager
def atomic_path(path):
    """Write ``path`` atomically: yields a temporary path beside it to write to.

    When the block ends normally the temporary file is flushed to disk and renamed
    over ``path`` (``os.replace``, atomic on one file system); when it raises
    (an error, a KeyboardInterrupt) the temporary file is removed and ``path``
    is left as it was. Usage: ``with atomic_path(p) as tmp: tmp.write_text(text)``.
    """
    path = Path(path)
    tmp = temporary_name(path)
    try:
        yield tmp
        with open(tmp, "rb+") as fh:
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


def check_directory(directory) -> Path:
    """Create ``directory`` (and its parents) if needed and check that files can be written into it.

    Creates and removes a temporary file there. Raises OSError (e.g.
    NotADirectoryError, PermissionError, FileExistsError for a path that is a
    file) when it cannot; returns the directory as a Path.
    """
    d = Path(directory)
    if d.exists() and not d.is_dir():
        raise FileExistsError(17, "it is a file, not a folder", str(d))
    d.mkdir(parents=True, exist_ok=True)
    probe = temporary_name(d / "write-test.tmp")
    with open(probe, "x"):
        pass
    probe.unlink()
    return d


def save_figure(fig, path, dpi: int = 120) -> Path:
    """Save a matplotlib Figure as the PNG file ``path`` atomically, with plotting.save_figures'
    settings (dpi, tight bounding box); closes it in pyplot when pyplot holds it. Returns the Path."""
    from ..plotting.figures import save_figures

    path = Path(path)
    with atomic_path(path) as tmp:
        save_figures({tmp.stem: fig}, tmp.parent, dpi=dpi)  # writes <stem>.png, i.e. tmp
    return path


# --------------------------------------------------------------------------
# Names and units of the columns

def coordinate_columns(model) -> list[str]:
    """Column names of q: ``X1_m ... theta_-1_rad ... delta_1_1_m`` (an FE node slope: ``delta_1_2_rad``)."""
    return [f"{c}_{u}" for c, u in zip(model.coordinate_names, model.coordinate_units)]


def velocity_columns(model) -> list[str]:
    """Column names of qdot: ``X1_dot_m_per_s ... theta_1_dot_rad_per_s ...``."""
    return [f"{c}_dot_{u}_per_s" for c, u in zip(model.coordinate_names, model.coordinate_units)]


def effort_columns(result) -> list[str]:
    """Column names of the actuators' efforts (Result.effort): ``effort_theta_1_N_m``, ``effort_d_2_N``."""
    units = dict(zip(result.model.coordinate_names, result.model.coordinate_units))
    return [f"effort_{c}_{'N_m' if units[c] == 'rad' else 'N'}" for c in result.prescribed]


def _fmt(x) -> str:
    """Shortest text that reads back to the same double (Python's repr)."""
    return repr(float(x))


# --------------------------------------------------------------------------
# CSV

def sample_rows(n_samples: int, every: int = 1) -> np.ndarray:
    """Rows written to the per-sample CSV files: 0, K, 2K, ... and the last row n_samples - 1, for
    K = ``every`` (an integer >= 1; 1 writes every sample)."""
    if isinstance(every, bool) or not isinstance(every, (int, np.integer)) or every < 1:
        raise ValueError(f"every={every!r} must be an integer >= 1 (write every K-th sample; 1 writes them all)")
    rows = np.arange(0, n_samples, int(every))
    return rows if n_samples == 0 or rows[-1] == n_samples - 1 else np.append(rows, n_samples - 1)


def write_timeseries_csv(result: Result, path, every: int = 1) -> Path:
    """Write t, phase, q, qdot, joint positions and energies, one row per sample (K rows), or with
    ``every`` > 1 one row per sample of sample_rows (the rows of the full file at those samples)."""
    path = Path(path)
    model = result.model
    r = sample_rows(len(result.t), every)
    E = result.energy()
    P = result.joint_positions()[r]  # (K', n+1, 3)
    header = ["t_s", "phase"] + coordinate_columns(model) + velocity_columns(model)
    header += [f"O{j + 1}_X{a + 1}_m" for j in range(P.shape[1]) for a in range(3)]
    Q = result.base_orientation  # (K, 4) of a spatial free base: chart-free (q's angles are its current chart's)
    header += ["base_qw", "base_qx", "base_qy", "base_qz"] if Q is not None else []
    header += ["kinetic_J", "gravity_J", "strain_J", "total_J"]
    if result.work is not None:
        header += ["work_inputs_J", "work_damping_J"] + (["work_actuators_J"] if result.work.shape[1] > 2 else [])
    header += effort_columns(result)
    K = len(r)
    cols = [result.q[r], result.qdot[r], P.reshape(K, 3 * P.shape[1])] + ([Q[r]] if Q is not None else [])
    cols.append(np.column_stack((E.kinetic, E.gravity, E.strain, E.total))[r])
    if result.work is not None:
        cols.append(result.work[r])
    if result.effort is not None:
        cols.append(result.effort[r])
    # One (K, C) table of Python floats, formatted by _fmt row by row (case 1's 1014 rows: 55 ms
    # against 68 ms when indexing numpy scalars one by one; repr of the floats is most of it).
    rows = np.column_stack(cols).tolist()
    phases = [str(int(p)) for p in result.phase[r]]
    times = result.t[r].tolist()
    with atomic_path(path) as tmp, tmp.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(header)
        w.writerows([_fmt(t), ph, *map(_fmt, row)] for t, ph, row in zip(times, phases, rows))
    return path


IMPACT_COLUMNS = [
    "impact", "time_s", "n_contacts", "joint", "wall", "wall_description",
    "normal_X1", "normal_X2", "normal_X3", "impulse_N_s", "v_before_m_per_s", "v_after_m_per_s", "restitution",
    "kinetic_before_J", "gravity_before_J", "strain_before_J", "total_before_J",
    "kinetic_after_J", "gravity_after_J", "strain_after_J", "total_after_J",
    "point_X1_m", "point_X2_m", "point_X3_m",
    "friction_impulse_X1_N_s", "friction_impulse_X2_N_s", "friction_impulse_X3_N_s",
    "slip_before_X1_m_per_s", "slip_before_X2_m_per_s", "slip_before_X3_m_per_s",
    "slip_after_X1_m_per_s", "slip_after_X2_m_per_s", "slip_after_X3_m_per_s",
]


def _friction_columns(rec, c) -> np.ndarray:
    """Friction impulse, slip before, slip after of contact c (9,), zeros for a frictionless impact."""
    if rec.friction_impulses is None:
        return np.zeros(9)
    return np.concatenate([np.asarray(a)[c] for a in (rec.friction_impulses, rec.slip_before, rec.slip_after)])


def write_impacts_csv(result: Result, path) -> Path:
    """One row per contact: impact number, time, joint, wall, normal, impulse, normal velocities, energies."""
    path = Path(path)
    # With prescribed coordinates each impact's actuator impulses (Lambda_p), repeated on its contacts' rows.
    held = [c.replace("effort_", "actuator_impulse_", 1) + "_s" for c in effort_columns(result)]
    with atomic_path(path) as tmp, tmp.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(IMPACT_COLUMNS + held)
        for i, rec in enumerate(result.impacts, start=1):
            for c, (joint, wall) in enumerate(zip(rec.joints, rec.wall)):
                w.writerow(
                    [str(i), _fmt(rec.time), str(len(rec.joints)), str(int(joint)), str(int(wall) + 1),
                     describe(result.walls[int(wall)]) if wall >= 0 else f"end stop of joint {int(joint)}"]
                    + [_fmt(v) for v in np.asarray(rec.normals)[c]]
                    + [_fmt(rec.impulses[c]), _fmt(rec.v_before[c]), _fmt(rec.v_after[c]), _fmt(rec.restitution[c])]
                    + [_fmt(v) for v in rec.energy_before]
                    + [_fmt(v) for v in rec.energy_after]
                    + [_fmt(v) for v in (np.asarray(rec.points)[c] if rec.points is not None else [math.nan] * 3)]
                    + [_fmt(v) for v in _friction_columns(rec, c)]
                    + ([_fmt(v) for v in rec.actuator_impulses] if held else [])
                )
    return path


def write_contact_forces_csv(result: Result, path, every: int = 1) -> Path:
    """Write t, phase and the resting-contact force of every (wall, contact point) pair, one row per sample
    (with ``every`` > 1 those of sample_rows); with friction on a wall also the friction force
    Ft_w<wall>_<point>_X<a>_N (world components); where a span point rested, its abscissa along the link
    x_w<wall>_link<i>.<c>_m [m] (NaN while it does not rest); with compliant walls their normal forces Fc_w<wall>_<column>_N;
    with prismatic joints the end-stop forces Fstop_<coordinate>_<min|max|carriage>_N [N] (Result.stop_forces)."""
    path = Path(path)
    r = sample_rows(len(result.t), every)
    K = len(result.t)
    F = result.contact_forces
    F = np.zeros((K, len(result.walls) * result.model.n_joints)) if F is None else np.asarray(F).reshape(K, -1)
    # (K, W C): the joint points, then the span points (contact_force_columns)
    header = ["t_s", "phase"] + contact_force_columns(result)
    if result.friction_forces is not None:
        F = np.hstack((F, np.asarray(result.friction_forces).reshape(K, -1)))
        header += [c.replace("F_", "Ft_", 1)[:-2] + f"_X{a + 1}_N" for c in contact_force_columns(result) for a in range(3)]
    if result.contact_abscissae is not None:  # where on its link each resting span point acts (NaN: not resting)
        P, names = result.model.n_joints, contact_force_columns(result)
        X = np.asarray(result.contact_abscissae)
        F = np.hstack((F, X[:, :, P:].reshape(K, -1)))
        header += [names[w * X.shape[2] + c].replace("F_", "x_", 1)[:-2] + "_m"
                   for w in range(X.shape[1]) for c in range(P, X.shape[2])]
    if result.compliant_forces is not None:
        F = np.hstack((F, np.asarray(result.compliant_forces).reshape(K, -1)))
        header += compliant_force_columns(result)
        # Where a link's closest point touches (a joint's position is in timeseries.csv): NaN out of contact.
        P = result.model.n_joints
        X = np.asarray(result.compliant_points)[:, :, P:]
        if X.size:  # (K, W, C - P, 3): the link and body columns of every wall
            F = np.hstack((F, X.reshape(K, -1)))
            names, C = compliant_force_columns(result), X.shape[2] + P
            header += [names[w * C + c].replace("Fc_", "Xc_", 1)[:-2] + f"_X{a + 1}_m"
                       for w in range(len(result.walls)) for c in range(P, C) for a in range(3)]
    if result.stop_forces is not None:
        F = np.hstack((F, np.asarray(result.stop_forces).reshape(K, -1)))
        header += stop_force_columns(result)
    with atomic_path(path) as tmp, tmp.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(header)
        for k in r:
            w.writerow([_fmt(result.t[k]), str(int(result.phase[k]))] + [_fmt(v) for v in F[k]])
    return path


def write_episodes_csv(result: Result, path) -> Path:
    """Write one row per collision episode (io.episode_files.EPISODE_COLUMNS; a header only without any)."""
    path = Path(path)
    with atomic_path(path) as tmp, tmp.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(EPISODE_COLUMNS)
        w.writerows([episode_cell(row[c]) for c in EPISODE_COLUMNS] for row in episode_rows(result) or [])
    return path


def to_csv(result: Result, directory, every: int = 1) -> dict:
    """Write ``timeseries.csv``, ``impacts.csv``, ``episodes.csv`` and (when some pair rested)
    ``contact_forces.csv`` into ``directory`` (created if needed).

    every : K >= 1, the per-sample files (timeseries, contact forces) get the samples 0, K, 2K, ...
    and the last (sample_rows), each row equal to that sample's row of the full file; impacts.csv
    is always whole, and result.npz (save_result) keeps every sample.

    Returns {"timeseries": Path, "impacts": Path, "episodes": Path[, "contact_forces": Path]}.
    """
    sample_rows(0, every)  # checks every before any file is written
    d = Path(directory)
    d.mkdir(parents=True, exist_ok=True)
    out = {
        "timeseries": write_timeseries_csv(result, d / "timeseries.csv", every),
        "impacts": write_impacts_csv(result, d / "impacts.csv"),
        "episodes": write_episodes_csv(result, d / "episodes.csv"),
    }
    if has_contact_forces(result):
        out["contact_forces"] = write_contact_forces_csv(result, d / "contact_forces.csv", every)
    return out


def read_csv(path) -> dict:
    """Read a CSV written here into {column: array}; numeric columns become float or int arrays."""
    with Path(path).open(newline="") as fh:
        rows = list(csv.reader(fh))
    header, body = rows[0], rows[1:]
    out = {}
    for c, name in enumerate(header):
        col = [r[c] for r in body]
        try:
            out[name] = np.array([int(v) for v in col], dtype=int)
        except ValueError:
            try:
                out[name] = np.array([float(v) for v in col], dtype=float)
            except ValueError:
                out[name] = np.array(col, dtype=str)
    return out


# --------------------------------------------------------------------------
# JSON summary

def versions() -> dict:
    """Versions of the package, Python, numpy, scipy (and matplotlib if imported)."""
    import scipy

    from .. import __version__

    v = {"gibbsimpact": __version__, "python": platform.python_version(), "numpy": np.__version__,
         "scipy": scipy.__version__}
    if "matplotlib" in sys.modules:
        v["matplotlib"] = sys.modules["matplotlib"].__version__
    return v


def _json_safe(x):
    """Plain JSON values: tuples -> lists, numpy -> Python, non-finite floats -> "inf"/"-inf"/null."""
    if isinstance(x, dict):
        return {str(k): _json_safe(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_json_safe(v) for v in x]
    if isinstance(x, np.ndarray):
        return _json_safe(x.tolist())
    if isinstance(x, (bool, np.bool_)):
        return bool(x)
    if isinstance(x, (int, np.integer)):
        return int(x)
    if isinstance(x, (float, np.floating)):
        x = float(x)
        if math.isnan(x):
            return None
        if math.isinf(x):
            return "inf" if x > 0 else "-inf"
        return x
    if x is None or isinstance(x, str):
        return x
    return repr(x)


def _energy_dict(E) -> dict:
    return {"kinetic": float(E.kinetic), "gravity": float(E.gravity), "strain": float(E.strain),
            "total": float(E.total)}


def summary(result: Result, case=None) -> dict:
    """The run in one JSON-ready dict (what summary.json holds).

    Energies in J, times in s. The energy balance error twice (Result.energy_error_whole_run and
    Result.energy_error_per_phase): ``relative_energy_error_whole_run`` (from t0 to the end, impacts
    with e = 1 included; the drift of the run), ``energy_error_whole_run_J`` (signed) and
    ``energy_scale_J`` (what it is relative to), then ``relative_energy_error_max_per_phase`` (max
    over the flight phases, each from its own start); ``max_relative_energy_error`` is the per-phase
    value under its old name, kept for existing readers. ``episodes``: the rows of episodes.csv
    (io.episode_files.episode_rows; null, and ``n_episodes`` null, for a Result built by hand).
    """
    model = result.model
    E = result.energy()
    d = {}
    if case is not None:
        d["case"] = case.name
        d["case_file"] = str(case.path) if case.path is not None else None
        d["description"] = case.description
    d["versions"] = versions()
    d["model"] = {
        "n_links": model.n_links, "n_coordinates": model.n_dof, "n_odes": 2 * model.n_dof,
        "coordinate_names": list(model.coordinate_names), "total_mass_kg": float(model.total_mass),
        "gravity_m_per_s2": [float(g) for g in model.gravity],
    }
    e_global = result.settings.get("restitution")
    d["walls"] = [describe(w) + (f", restitution {w.restitution:g}" if w.restitution is not None else
                                 f", restitution {e_global:g} (global)" if e_global is not None else "")
                  for w in result.walls]
    d["settings"] = _json_safe(result.settings)
    d["status"] = result.status
    d["message"] = result.message
    d["t_start_s"] = float(result.t[0])
    d["t_final_s"] = float(result.t[-1])
    d["n_impacts"] = len(result.impacts)
    d["impact_times_s"] = [float(r.time) for r in result.impacts]
    d["impact_joints"] = [[int(j) for j in r.joints] for r in result.impacts]
    d["impacts"] = [
        {"time_s": float(r.time), "joints": [int(j) for j in r.joints], "walls": [int(w) + 1 for w in r.wall],
         "impulses_N_s": [float(v) for v in r.impulses],
         "energy_before_J": float(r.energy_before.total), "energy_after_J": float(r.energy_after.total)}
        for r in result.impacts
    ]
    rows = episode_rows(result)  # None for a Result built by hand
    d["n_episodes"] = None if rows is None else len(rows)
    d["episodes"] = rows
    d["energy_initial_J"] = {k: float(getattr(E, k)[0]) for k in Energy._fields}
    d["energy_final_J"] = {k: float(getattr(E, k)[-1]) for k in Energy._fields}
    d["relative_energy_error_whole_run"] = _json_safe(result.energy_error_whole_run)
    d["energy_error_whole_run_J"] = _json_safe(result.energy_error_whole_run_J)
    d["energy_scale_J"] = _json_safe(result.energy_scale)
    d["relative_energy_error_max_per_phase"] = _json_safe(result.energy_error)
    d["energy_audit_J"] = {k: _json_safe(v) for k, v in result.energy_audit().items()}
    # Per phase, under its first name (kept for existing readers).
    d["max_relative_energy_error"] = _json_safe(result.energy_error)
    d["resting_time_s"] = float(result.resting_time)
    F = result.contact_forces
    if F is not None and F.size and np.any(F[-1]):
        names = _force_point_names(result)
        d["final_contact_forces_N"] = {f"{names[j]} on wall {w + 1}": float(F[-1, w, j])
                                       for w, j in np.argwhere(F[-1] != 0.0)}
        if result.friction_forces is not None:
            Ft = np.asarray(result.friction_forces)[-1]
            d["final_friction_forces_N"] = {f"{names[j]} on wall {w + 1}": [float(v) for v in Ft[w, j]]
                                            for w, j in np.argwhere(F[-1] != 0.0)}
    d["wall_time_s"] = float(result.wall_time)
    d["nfev"] = int(result.nfev)
    d["n_steps"] = int(result.n_steps)
    d["n_steps_examined_for_dips"] = int(result.n_examined)
    if result.work is not None:
        d["work_final_J"] = {"inputs": float(result.work[-1, 0]), "damping": float(result.work[-1, 1])}
        if result.work.shape[1] > 2:
            d["work_final_J"]["actuators"] = float(result.work[-1, 2])
    if result.prescribed:
        d["prescribed_coordinates"] = list(result.prescribed)
        d["effort_final"] = dict(zip(effort_columns(result), (float(v) for v in result.effort[-1])))
    d.update(base_summary(result))
    d["n_samples"] = int(len(result.t))
    return _json_safe(d)


def write_summary_json(result: Result, path, case=None, output_files: dict | None = None) -> Path:
    """Write :func:`summary` as indented JSON (strict: no NaN or Infinity literals).

    output_files : if given, stored under that key (the command line's account of the files it wrote).
    """
    path = Path(path)
    d = summary(result, case)
    if output_files is not None:
        d["output_files"] = _json_safe(output_files)
    text = json.dumps(d, indent=2, allow_nan=False) + "\n"
    with atomic_path(path) as tmp:
        tmp.write_text(text)
    return path


# --------------------------------------------------------------------------
# Lossless NPZ

def _tag(x):
    """JSON with types kept: tuples, numpy arrays and scalars, non-finite floats."""
    if isinstance(x, tuple):
        return {"__tuple__": [_tag(v) for v in x]}
    if isinstance(x, list):
        return [_tag(v) for v in x]
    if isinstance(x, dict):
        if all(isinstance(k, str) for k in x):
            return {"__dict__": {k: _tag(v) for k, v in x.items()}}
        return {"__items__": [[_tag(k), _tag(v)] for k, v in x.items()]}
    if isinstance(x, np.ndarray):
        return {"__ndarray__": _tag(x.tolist()), "dtype": x.dtype.str, "shape": list(x.shape)}
    if isinstance(x, np.generic):
        return {"__npscalar__": _tag(x.item()), "dtype": x.dtype.str}
    if isinstance(x, float):
        if math.isfinite(x):
            return x
        return {"__float__": repr(x)}
    if x is None or isinstance(x, (bool, int, str)):
        return x
    return {"__repr__": repr(x)}


def _untag(x):
    if isinstance(x, list):
        return [_untag(v) for v in x]
    if isinstance(x, dict):
        if "__tuple__" in x:
            return tuple(_untag(v) for v in x["__tuple__"])
        if "__dict__" in x:
            return {k: _untag(v) for k, v in x["__dict__"].items()}
        if "__items__" in x:
            return {_untag(k): _untag(v) for k, v in x["__items__"]}
        if "__ndarray__" in x:
            return np.array(_untag(x["__ndarray__"]), dtype=np.dtype(x["dtype"])).reshape(x["shape"])
        if "__npscalar__" in x:
            return np.dtype(x["dtype"]).type(_untag(x["__npscalar__"]))
        if "__float__" in x:
            return float(x["__float__"])
        if "__repr__" in x:
            return x["__repr__"]
    return x


def save_result(result: Result, path, metadata: dict | None = None) -> Path:
    """Store a Result in a compressed NPZ archive that :func:`load_result` reads back exactly.

    Parameters
    ----------
    result : Result
    path : str or Path; ".npz" is appended when missing
    metadata : optional dict of extra JSON-able information (e.g. the case name and source);
        returned by ``load_result(path, with_metadata=True)``.
    """
    path = Path(path)
    if path.suffix != ".npz":
        path = path.with_name(path.name + ".npz")
    path.parent.mkdir(parents=True, exist_ok=True)
    imps = result.impacts
    N = result.model.n_dof
    n_contacts = np.array([len(r.joints) for r in imps], dtype=np.int64)
    cat = lambda f, shape: (np.concatenate([np.asarray(getattr(r, f), dtype=float).reshape(shape) for r in imps])  # noqa: E731
                            if imps else np.zeros((0,) + shape[1:]))
    arrays = {
        "t": np.asarray(result.t), "q": np.asarray(result.q), "qdot": np.asarray(result.qdot),
        "phase": np.asarray(result.phase),
        "impact_time": np.array([float(r.time) for r in imps], dtype=float),
        "impact_n_contacts": n_contacts,
        "contact_joint": np.array([int(j) for r in imps for j in r.joints], dtype=np.int64),
        "contact_wall": np.array([int(w) for r in imps for w in r.wall], dtype=np.int64),
        "contact_normal": cat("normals", (-1, 3)),
        "contact_impulse": cat("impulses", (-1,)),
        "contact_v_before": cat("v_before", (-1,)),
        "contact_v_after": cat("v_after", (-1,)),
        "contact_restitution": cat("restitution", (-1,)),
        "impact_qdot_before": np.array([r.qdot_before for r in imps], dtype=float).reshape(len(imps), N),
        "impact_qdot_after": np.array([r.qdot_after for r in imps], dtype=float).reshape(len(imps), N),
        "impact_energy_before": np.array([tuple(r.energy_before) for r in imps], dtype=float).reshape(len(imps), 4),
        "impact_energy_after": np.array([tuple(r.energy_after) for r in imps], dtype=float).reshape(len(imps), 4),
        "impact_rounds": np.array([int(r.rounds) for r in imps], dtype=np.int64),
        "contact_point": np.array([np.asarray(r.points)[c] if r.points is not None else [np.nan] * 3
                                   for r in imps for c in range(len(r.joints))], dtype=float).reshape(-1, 3),
        "impact_frictional": np.array([r.friction_impulses is not None for r in imps], dtype=bool),
        "contact_friction": np.array([_friction_columns(r, c) for r in imps for c in range(len(r.joints))],
                                     dtype=float).reshape(-1, 9),
    }
    if result.work is not None:
        arrays["work"] = np.asarray(result.work, dtype=float)
    if result.effort is not None:
        arrays["effort"] = np.asarray(result.effort, dtype=float)
        arrays["impact_actuator_impulses"] = np.array([r.actuator_impulses for r in imps], dtype=float).reshape(
            len(imps), len(result.prescribed))
    if result.contact_forces is not None:
        arrays["contact_forces"] = np.asarray(result.contact_forces, dtype=float)
    if result.friction_forces is not None:
        arrays["friction_forces"] = np.asarray(result.friction_forces, dtype=float)
    if result.contact_abscissae is not None:
        arrays["contact_abscissae"] = np.asarray(result.contact_abscissae, dtype=float)
    if result.stop_forces is not None:
        arrays["stop_forces"] = np.asarray(result.stop_forces, dtype=float)
    arrays.update(chart_arrays(result))
    arrays.update(_compliant_arrays(result))
    meta = {
        "format": "gibbsimpact.Result",
        "format_version": FORMAT_VERSION,
        "versions": versions(),
        "model": model_to_dict(result.model),
        "walls": [wall_to_dict(w) for w in result.walls],
        "status": result.status,
        "message": result.message,
        "settings": _tag(result.settings),
        "nfev": int(result.nfev),
        "n_steps": int(result.n_steps),
        "n_examined": int(result.n_examined),
        "wall_time": _tag(float(result.wall_time)),
        "energy_error": _tag(float(result.energy_error)),
        "energy_error_whole_run_J": _tag(float(result.energy_error_whole_run_J)),
        "resting_time": _tag(float(result.resting_time)),
        "prescribed": list(result.prescribed),
        "metadata": _tag(metadata or {}),
    }
    arrays["meta"] = np.array(json.dumps(meta))
    with atomic_path(path) as tmp:
        np.savez_compressed(tmp, **arrays)
    return path


def _compliant_arrays(result) -> dict:
    """The compliant contacts' forces, points, integrals and contacts of a Result as NPZ arrays ({} without)."""
    if result.compliant_forces is None:
        return {}
    return {"compliant_forces": np.asarray(result.compliant_forces, dtype=float),
            "compliant_points": np.asarray(result.compliant_points, dtype=float),
            "compliant_integrals": np.asarray(result.compliant_integrals, dtype=float),
            "compliant_contacts": np.array(result.compliant_contacts, dtype=float).reshape(-1, 5)}


def load_result(path, with_metadata: bool = False):
    """Read a Result written by :func:`save_result` (or ``Result.save``), rebuilding its Model and walls.

    Returns the Result, or (Result, metadata dict) with ``with_metadata=True``.
    """
    path = Path(path)
    with np.load(path, allow_pickle=False) as z:
        a = {k: z[k] for k in z.files}
    try:
        meta = json.loads(str(a.pop("meta")))
    except KeyError:
        raise ValueError(f"{path} is not a gibbsimpact result (no 'meta' entry)") from None
    if meta.get("format") != "gibbsimpact.Result":
        raise ValueError(f"{path} is not a gibbsimpact result")
    if meta.get("format_version", 0) > FORMAT_VERSION:
        raise ValueError(f"{path} was written by a newer gibbsimpact (format {meta['format_version']}); upgrade to read it")
    model = model_from_dict(meta["model"])
    walls = tuple(wall_from_dict(w) for w in meta["walls"])
    impacts = []
    start = 0
    for i, k in enumerate(a["impact_n_contacts"]):
        s = slice(start, start + int(k))
        start += int(k)
        impacts.append(ImpactRecord(
            time=float(a["impact_time"][i]),
            joints=tuple(int(j) for j in a["contact_joint"][s]),
            wall=tuple(int(w) for w in a["contact_wall"][s]),
            normals=a["contact_normal"][s],
            impulses=a["contact_impulse"][s],
            v_before=a["contact_v_before"][s],
            v_after=a["contact_v_after"][s],
            restitution=a["contact_restitution"][s],
            qdot_before=a["impact_qdot_before"][i],
            qdot_after=a["impact_qdot_after"][i],
            energy_before=Energy(*(float(v) for v in a["impact_energy_before"][i])),
            energy_after=Energy(*(float(v) for v in a["impact_energy_after"][i])),
            rounds=int(a["impact_rounds"][i]) if "impact_rounds" in a else 1,
            points=(a["contact_point"][s] if "contact_point" in a and not np.isnan(a["contact_point"][s]).all()
                    else None),
            **({"friction_impulses": a["contact_friction"][s, 0:3], "slip_before": a["contact_friction"][s, 3:6],
                "slip_after": a["contact_friction"][s, 6:9]}
               if "impact_frictional" in a and a["impact_frictional"][i] else {}),
            **({"actuator_impulses": a["impact_actuator_impulses"][i]} if "impact_actuator_impulses" in a else {}),
        ))
    res = Result(
        model=model, walls=walls, t=a["t"], q=a["q"], qdot=a["qdot"], phase=a["phase"], impacts=impacts,
        status=meta["status"], message=meta["message"], settings=_untag(meta["settings"]),
        nfev=int(meta["nfev"]), n_steps=int(meta["n_steps"]), n_examined=int(meta.get("n_examined", 0)),
        wall_time=float(_untag(meta["wall_time"])), energy_error=float(_untag(meta["energy_error"])),
        energy_error_whole_run_J=float(_untag(meta.get("energy_error_whole_run_J", float("nan")))),
        work=a.get("work"), contact_forces=a.get("contact_forces"), friction_forces=a.get("friction_forces"),
        contact_abscissae=a.get("contact_abscissae"), resting_time=float(_untag(meta.get("resting_time", 0.0))), stop_forces=a.get("stop_forces"),
        prescribed=tuple(meta.get("prescribed", ())), effort=a.get("effort"),
        compliant_forces=a.get("compliant_forces"), compliant_points=a.get("compliant_points"),
        compliant_integrals=a.get("compliant_integrals"),
        compliant_contacts=[CompliantContact(int(r[0]), int(r[1]), *map(float, r[2:]))
                            for r in a.get("compliant_contacts", np.zeros((0, 5)))],
        **charts_from(a),
    )
    if with_metadata:
        return res, _untag(meta.get("metadata", {}))
    return res
