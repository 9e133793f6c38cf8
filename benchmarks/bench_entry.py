"""What the documented entry points cost against the bare compiled kernel call of the same job.

For each chain and each entry point (``Model.forward_dynamics``, ``Model.mass_matrix``, ...,
and the functions of gibbsimpact.dynamics they call), the time of one call against the bare
kernel call that computes the same thing (``kernel.compiled(v)(fdat, idat, q, qdot, Q, JOB, v0, v1,
out)`` into a preallocated output), measured in the same run, interleaved, as the minimum over
repeats of the mean of many calls (the machine is shared and noisy: the minimum is the least
disturbed estimate). The target (issue 22 item 7): every entry point within 1.5x its kernel call.

    python benchmarks/bench_entry.py [--repeat 7] [--number 20000]
"""

from __future__ import annotations

import argparse
import timeit

import numpy as np

import gibbsimpact as gi
from gibbsimpact import kernel as K
from gibbsimpact.dynamics import gibbs_appell as ga
from gibbsimpact.dynamics import kinematics as kin


def chains():
    rigid = gi.Link(1.0, 1.0, 20.0)
    modal = gi.Link(1.0, 1.0, 20.0, modes=[gi.Mode("clamped-clamped", "y")])
    fe = gi.Link(1.0, 1.0, 20.0, elements=4)
    return {
        "rigid 4-link chain": gi.Model(gi.Chain([rigid] * 4), gravity=(0.0, -9.81, 0.0)),
        "case 1 (2 links, 1 mode each)": gi.Model(gi.Chain([modal] * 2), gravity=(0.0, -9.81, 0.0)),
        "FE arm (2 links, 4 elements)": gi.Model(gi.Chain([fe, fe], base=gi.FixedBase((0.0, 0.5))),
                                                 gravity=(0.0, -9.81, 0.0)),
    }


def entries(model, q, qd):
    """(name, the entry point's call, the kernel job that computes the same thing)."""
    return [
        ("Model.forward_dynamics", lambda: model.forward_dynamics(q, qd), K.JOB_QDDOT),
        ("dynamics.forward_dynamics", lambda: ga.forward_dynamics(model, q, qd), K.JOB_QDDOT),
        ("Model.mass_matrix", lambda: model.mass_matrix(q), K.JOB_M),
        ("dynamics.mass_matrix", lambda: ga.mass_matrix(model, q), K.JOB_M),
        ("Model.bias_forces", lambda: model.bias_forces(q, qd), K.JOB_H),
        ("Model.energy", lambda: model.energy(q, qd), K.JOB_ENERGY),
        ("dynamics.energy", lambda: ga.energy(model, q, qd), K.JOB_ENERGY),
        ("Model.linear_momentum", lambda: model.linear_momentum(q, qd), K.JOB_MOMENTUM),
        ("Model.center_of_mass", lambda: model.center_of_mass(q), K.JOB_MOMENTUM),
        ("Model.potential_forces", lambda: model.potential_forces(q), K.JOB_H),
        ("Model.joint_positions", lambda: model.joint_positions(q), K.JOB_POINTS),
        ("kinematics.joint_positions", lambda: kin.joint_positions(model, q), K.JOB_POINTS),
        ("Model.joint_jacobians", lambda: model.joint_jacobians(q), K.JOB_POINTS | K.JOB_JACOBIANS),
    ]


def bare(model, q, qd, job):
    """The bare kernel call of ``job`` into a preallocated output."""
    fdat, idat, zeros, v = model.kernel_data
    f = K.compiled(v)
    out = K.output(idat, 1, job)
    return lambda: f(fdat, idat, q, qd, zeros, job, v[0], v[1], out)


def _nothing(model):
    """A compiled function of the kernel's nine arguments and types (model's variant) that does nothing."""
    import numba

    v = model.kernel_data[3]
    sig = K.compile._ENTRY_SIG.format(*K.compile._signature_args(v))
    return numba.njit(sig)(lambda fdat, idat, qs, qds, Q, job, pris, ends, out: 0.0)


def floors(model, q, qd):
    """The floors of every entry point: (the call from Python of ``_nothing``: numba's dispatch, unboxing
    nine arguments and boxing a float; a Python function that allocates the output of JOB_POINTS, makes
    that call and returns a reshaped view of it: joint_positions' steps around a kernel that costs nothing)."""
    fdat, idat, zeros, v = model.kernel_data
    nothing, job = _nothing(model), K.JOB_POINTS
    size, P = K.output(idat, 1, job).size, model.n_joints
    out0 = np.empty(size)

    def entry(q, qd):
        out = np.empty(size)
        nothing(fdat, idat, q, qd, zeros, job, v[0], v[1], out)
        return out[3:].reshape(P, 3)

    return lambda: nothing(fdat, idat, q, qd, zeros, job, v[0], v[1], out0), lambda: entry(q, qd)


def best(fn, number, repeat):
    return min(timeit.repeat(fn, number=number, repeat=repeat)) / number * 1e6


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeat", type=int, default=7)
    ap.add_argument("--number", type=int, default=20000)
    args = ap.parse_args()
    rng = np.random.default_rng(0)
    worst = 0.0
    for name, model in chains().items():
        q = rng.uniform(-0.5, 0.5, model.n_dof)
        qd = rng.normal(size=model.n_dof)
        print(f"\n{name} (N = {model.n_dof})")
        print(f"  {'entry point':28s} {'us/call':>9s} {'kernel us':>10s} {'ratio':>6s}")
        call, entry = floors(model, q, qd)
        call(), entry()
        print(f"  {'(floor: an empty call)':28s} {best(call, args.number, args.repeat):9.2f}")
        print(f"  {'(floor: an empty entry)':28s} {best(entry, args.number, args.repeat):9.2f}")
        for label, call, job in entries(model, q, qd):
            call()
            k = bare(model, q, qd, job)
            k()
            # Interleaved: kernel, entry, kernel, entry ... so both see the same machine state.
            tk, te = [], []
            for _ in range(args.repeat):
                tk.append(best(k, args.number, 1))
                te.append(best(call, args.number, 1))
            ratio = min(te) / min(tk)
            worst = max(worst, ratio)
            print(f"  {label:28s} {min(te):9.2f} {min(tk):10.2f} {ratio:6.2f}")
    print(f"\nlargest ratio: {worst:.2f} (target <= 1.5)")


if __name__ == "__main__":
    main()
