"""The compiled kernel against itself run as plain Python, its compile contract, and two self-checks.

``gibbsimpact.kernel.kernel`` is the package's only implementation of the
dynamics (M, h, dV/dq, qddot, energies, momentum, joint points and Jacobians,
frames); correctness is anchored by the independent sympy oracle in
``tests/reference`` (test_sympy_crosscheck.py, test_symbolic.py). This file
checks that what numba compiles is that same source:

1. compiled == uncompiled: a subprocess with ``NUMBA_DISABLE_JIT=1`` runs the
   kernel source as plain Python on nine chains (planar and spatial, rigid,
   modal and finite-element, free, planar and fixed base, 1 to 16 links, R, Pa
   and Pb joints, a carriage on a sliding link; two random states each, built
   from one seed) and saves every public quantity (657 arrays, the resting-contact
   terms, their solves and the event layer's gaps and skip rule included); this process
   computes them compiled. Each must agree to 1e-13 relative,
   max|a - b| / max|a| per quantity. Measured (numba 0.68, x86-64) on the
   first seven chains: all 301 arrays bit-identical, qddot of the modal 8-link
   chain (cond M ~ 3e7) included: numba does not contract or reorder floating-point operations
   without fastmath, and calls the same libm.
2. no recompiles: after varied use the entry point has exactly one
   signature, and other argument types raise TypeError instead of compiling.
3. a read-only install with no usable cache directory still works (numba
   compiles without caching; ``kernel.compile._jit_helpers`` catches "cannot cache").
4. two kernel paths against each other / finite differences: the joint
   Jacobians (twist form) against central differences of the joint points,
   and 1/2 qdot^T M qdot (JOB_M) against the kinetic energy (JOB_ENERGY).
   Measured: Jacobians within 1.5e-10 of the differences (tolerance 1e-8),
   energies within 1.4e-15 relative (tolerance 1e-13).

Test 3 compiles the kernel from scratch (~20-30 s of CPU); the rest takes ~5 s.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import gibbsimpact as gi
from gibbsimpact.dynamics import gibbs_appell as dy
from gibbsimpact import kernel as _k
from gibbsimpact.kernel import compile as _kc
from gibbsimpact.kernel.layout import _CI, _H, _LI
from gibbsimpact.model.packing import pack
from gibbsimpact.dynamics import kinematics as kin

from conftest import random_state, two_link_circle_model, two_link_circle_state

SEED = 20261122
N_STATES = 2
RTOL = 1e-13
TINY = np.finfo(float).tiny
TESTS_DIR = Path(__file__).resolve().parent
TESTS_ROOT = TESTS_DIR.parent  # conftest.py, reference/
JIT_DISABLED = _k.jit_disabled()
needs_jit = pytest.mark.skipif(JIT_DISABLED, reason="NUMBA_DISABLE_JIT is set: nothing is compiled")


# -- the chains -----------------------------------------------------------------------

def _rod():
    """A rigid free rod with rotary inertia (N = 6)."""
    return gi.Model(gi.Chain([gi.Link(1.0, 2.0, 1.0, rotary_inertia=(1e-3, 2e-3, 3e-3))]))


def _spatial_two_link():
    """Clamped-free y and z modes: the link ends rotate in 3D (Rodrigues path, END_GENERAL), N = 11."""
    a = gi.Link(1.0, 1.2, (15.0, 25.0), modes=[gi.Mode("clamped-free", "y"), gi.Mode("clamped-free", "z")],
                rotary_inertia=(2e-4, 1e-4, 1e-4), geometric_stiffening=False)
    b = gi.Link(0.7, 0.8, (10.0, 12.0), modes=[gi.Mode("clamped-free", "y"), gi.Mode("clamped-free", "z", 2)],
                rotary_inertia=(1e-4, 2e-4, 5e-5), geometric_stiffening=False)
    return gi.Model(gi.Chain([a, b]), gravity=(0.3, -9.81, 0.5))


def _fe_fixed_arm():
    """Fixed-base arm of two 3-element Hermite links (N = 14)."""
    links = [gi.Link(1.0, 1.0, 10.0, elements=3, rotary_inertia=(0.0, 0.0, 1e-4), geometric_stiffening=False), gi.Link(0.6, 0.5, 4.0, elements=3, geometric_stiffening=False)]
    return gi.Model(gi.Chain(links, base=gi.FixedBase(position=(0.1, 0.2), angle=0.3)), gravity=(0.0, -9.81, 0.0))


def _fe_free_spatial():
    """A free link with 3 elements in y and z (N = 18)."""
    link = gi.Link(1.0, 1.0, (8.0, 12.0), elements=3, element_directions=("y", "z"),
                   rotary_inertia=(1e-3, 5e-4, 5e-4), geometric_stiffening=False)
    return gi.Model(gi.Chain([link]))


def _rigid_sixteen():
    """Sixteen rigid links of varying length (N = 21)."""
    links = [gi.Link(0.3 + 0.02 * i, 1.0 + 0.1 * (i % 3), 1.0) for i in range(16)]
    return gi.Model(gi.Chain(links))


def _modal_eight():
    """Eight links with two clamped-free y modes each (N = 29)."""
    modes = [gi.Mode("clamped-free", "y", 1), gi.Mode("clamped-free", "y", 2)]
    return gi.Model(gi.Chain([gi.Link(0.5, 1.0, 5.0, modes=modes, geometric_stiffening=False)] * 8))


def _prismatic_planar():
    """R, Pa, Pb on a planar floating base, two elements per link (N = 17): carriage twists,
    a sliding link's own moments, the host tips as extra contact points."""
    links = [gi.Link(1.0, 1.0, 10.0, elements=2, geometric_stiffening=False), gi.Link(0.7, 0.5, 4.0, elements=2, geometric_stiffening=False), gi.Link(0.5, 0.4, 3.0, elements=2, geometric_stiffening=False)]
    joints = [gi.Revolute(), gi.SlidingPrismatic(angle=0.4, half_length=0.05, range=(0.1, 0.9)),
              gi.FixedPrismatic(angle=-0.3, range=(0.15, 0.5))]
    return gi.Model(gi.Chain(links, joints=joints, base="planar"), gravity=(0.0, -9.81, 0.0))


def _carriage_on_sliding_link():
    """A Pa carriage on a flexible Pb link, fixed base (N = 10): the second twist."""
    links = [gi.Link(1.0, 1.0, 10.0, elements=2, geometric_stiffening=False), gi.Link(0.5, 0.5, 4.0, elements=2, geometric_stiffening=False)]
    joints = [gi.FixedPrismatic(angle=0.5, range=(0.6, 1.0)), gi.SlidingPrismatic(angle=0.3, half_length=0.05,
                                                                                   range=(0.1, 0.9))]
    return gi.Model(gi.Chain(links, joints=joints, base=gi.FixedBase((0.1, 0.2), 0.3)), gravity=(0.0, -9.81, 0.0))


CHAINS = {
    "rigid_rod": _rod,
    "planar_two_link": two_link_circle_model,  # the published chain: one clamped-clamped y mode per link
    "spatial_two_link": _spatial_two_link,
    "fe_fixed_arm": _fe_fixed_arm,
    "fe_free_spatial": _fe_free_spatial,
    "rigid_16": _rigid_sixteen,
    "modal_8x2": _modal_eight,
    "prismatic_planar": _prismatic_planar,
    "carriage_on_sliding_link": _carriage_on_sliding_link,
}

ALL_OBSERVABLES = _k.JOB_ENERGY | _k.JOB_MOMENTUM | _k.JOB_POINTS | _k.JOB_JACOBIANS | _k.JOB_FRAMES


def _state(model, rng):
    """A random (q, qdot) with the prismatic variables inside their ranges."""
    q, qd = random_state(model, rng)
    for i, jt in enumerate(model.chain.joints):
        if jt.kind != "R":
            lo, hi = jt.range
            q[model.theta_index[i]] = lo + (hi - lo) * rng.uniform(0.4, 0.6)
    return q, qd


def _states(model, rng):
    """N_STATES random (q, qdot) and applied forces Q."""
    out = []
    for _ in range(N_STATES):
        q, qd = _state(model, rng)
        out.append((q, qd, rng.normal(size=model.n_dof)))
    return out


def quantities(model, q, qd, Q):
    """Every public output of the kernel at one state (name -> float array)."""
    E = dy.energy(model, q, qd)
    L, H0, c = dy.momentum(model, q, qd)
    O, J = kin.joint_positions_and_jacobians(model, q)
    F = kin.frames(model, q, qd)
    return {
        "M": dy.mass_matrix(model, q),
        "qddot": dy.forward_dynamics(model, q, qd).copy(),
        "qddot_Q": dy.forward_dynamics(model, q, qd, Q).copy(),
        "h": dy.bias_forces(model, q, qd),
        "dV": dy.potential_forces(model, q),
        "E_kinetic": np.array(E.kinetic),
        "E_gravity": np.array(E.gravity),
        "E_strain": np.array(E.strain),
        "L": L,
        "H0": H0,
        "c": c,
        "com": dy.center_of_mass(model, q),
        "O": kin.joint_positions(model, q).copy(),
        "O_with_J": O.copy(),
        "J": J.copy(),
        "T": F.T,
        "Td": F.Td,
        "Tdd0": F.Tdd0,
        **contact_quantities(model, q, qd, Q),
    }


#: Walls of the contact terms (kernel.contact_terms): one of each kind.
CONTACT_WALLS = (gi.Circle(1.7, (0.1, -0.2)), gi.Sphere(2.1, (0.2, -0.1, 0.3)), gi.Plane((0.0, -1.5, 0.1), (0.2, 1.0, -0.3)))


def contact_quantities(model, q, qd, Q):
    """kernel.contact_terms (through resting.constraint_data) for every frame origin on every wall
    of CONTACT_WALLS, and the compiled symmetric solve on its G (k up to 51: singular)."""
    from gibbsimpact.simulation.contacts import Contacts
    from gibbsimpact.contact.resting import _solve_sym, constraint_data

    pairs = [(w, j) for w in range(len(CONTACT_WALLS)) for j in range(model.n_links + 1)]
    ct = Contacts(model, CONTACT_WALLS)  # kernel.event_gaps: joint gaps and the link skip rule
    d = constraint_data(model, CONTACT_WALLS, q, qd, Q, pairs)
    p = constraint_data(model, CONTACT_WALLS, q, None, None, pairs, velocities=False)
    return {"contact_W": d.W, "contact_MinvW": d.MinvW, "contact_G": d.G, "contact_c": d.c, "contact_g": d.g,
            "contact_v": d.v, "contact_n": d.n, "contact_pd": d.pd, "contact_a0": d.a0,
            "contact_G_positions": p.G, "contact_lambda": _solve_sym(d.G, -(d.W.T @ d.qdd_free + d.c)),
            "contact_lambda_compiled": d.lam, "contact_qdd": d.qdd, "contact_friction": _friction(d),
            "event_gaps": ct.gaps(q),
            "event_skipped": ct.skipped(q).astype(float)}


def _friction(d):
    """kernel.friction_solve on constraint data d: every pair on a wall with mu = 0.3, sticking and
    slipping alternately (k up to 51: singular C^T M^-1 B)."""
    k = d.W.shape[1]
    stick = (np.arange(k) % 2).astype(np.int64)
    sdir = np.tile([0.3, -0.5, 0.8], (k, 1))
    return _k.lazy("friction_solve")(d.M, d.W, d.J, d.n, d.pd, d.a0, d.c, d.qdd_free, np.full(k, 0.3), stick, sdir,
                                     1e-6)


def compute_all(seed=SEED):
    """{"chain/state/quantity": array} for every chain at N_STATES states drawn from ``seed``."""
    rng = np.random.default_rng(seed)
    out = {}
    for name, build in CHAINS.items():
        model = build()
        states = _states(model, rng)
        for k, (q, qd, Q) in enumerate(states):
            out[f"{name}/{k}/q"], out[f"{name}/{k}/qdot"] = q, qd
            for key, val in quantities(model, q, qd, Q).items():
                out[f"{name}/{k}/{key}"] = np.asarray(val, dtype=float)
        # The batched paths (K states in one kernel call).
        qs = np.array([s[0] for s in states])
        qds = np.array([s[1] for s in states])
        Eb = dy.energies(model, qs, qds)
        out[f"{name}/batch/energies"] = np.array([Eb.kinetic, Eb.gravity, Eb.strain])
        out[f"{name}/batch/joint_positions"] = kin.joint_positions_batch(model, qs)
        # The raw kernel with every observable bit at once, over both states.
        out[f"{name}/batch/all_observables"] = kin.run_kernel(model, kin.states(qs, qds), ALL_OBSERVABLES).copy()
    return out


def _save_uncompiled(path):
    """Entry point of the NUMBA_DISABLE_JIT=1 subprocess."""
    _k.ensure_compiled()
    assert _k.jit_disabled() and not hasattr(_k.kernel, "signatures"), "the kernel was compiled"
    np.savez(path, **compute_all())


def _rel(a, b):
    return float(np.max(np.abs(a - b), initial=0.0) / max(float(np.max(np.abs(a), initial=0.0)), TINY))


# -- 1. compiled == uncompiled --------------------------------------------------------

@pytest.fixture(scope="module")
def uncompiled(tmp_path_factory):
    path = tmp_path_factory.mktemp("kernel") / "uncompiled.npz"
    env = dict(os.environ, NUMBA_DISABLE_JIT="1")
    code = (f"import sys; sys.path[:0] = [{str(TESTS_DIR)!r}, {str(TESTS_ROOT)!r}]; import test_kernel; "
            f"test_kernel._save_uncompiled({str(path)!r})")
    run = subprocess.run([sys.executable, "-c", code], check=False, env=env, cwd=TESTS_DIR, capture_output=True,
                         text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    with np.load(path) as data:
        return dict(data)


@pytest.fixture(scope="module")
def compiled():
    return compute_all()


def test_chains_cover_the_kernel_paths():
    kinds = set()
    for build in CHAINS.values():
        model = build()
        idat = pack(model)[1]
        n, N = int(idat[0]), int(idat[1])
        li = idat[_H + _CI * N:_H + _CI * N + n * _LI].reshape(n, _LI)
        kinds |= set(li[:, 4].tolist())
    # Rigid ends and moving (Rodrigues) ends.
    assert {_k.END_RIGID, _k.END_GENERAL} <= kinds
    spatial = pack(_spatial_two_link())[1]
    N = int(spatial[1])
    assert np.all(spatial[_H + _CI * N:_H + _CI * N + 2 * _LI].reshape(2, _LI)[:, 4] == _k.END_GENERAL)


@needs_jit
@pytest.mark.parametrize("chain", CHAINS)
def test_compiled_equals_uncompiled(chain, compiled, uncompiled):
    assert hasattr(_k.kernel, "signatures"), "this process should run the compiled kernel"
    keys = [key for key in compiled if key.startswith(chain + "/")]
    assert keys and set(keys) == {key for key in uncompiled if key.startswith(chain + "/")}
    for key in keys:
        if key.endswith(("/q", "/qdot")):
            np.testing.assert_array_equal(compiled[key], uncompiled[key])  # the same states
    worst = {}
    for key in keys:
        a, b = uncompiled[key], compiled[key]
        assert a.shape == b.shape, key
        assert np.all(np.isfinite(b)), key
        r = _rel(a, b)
        name = key.split("/", 1)[1]
        worst[name] = r
    bad = {k: f"{v:.2e}" for k, v in worst.items() if v > RTOL}
    assert not bad, f"{chain}: compiled vs uncompiled beyond {RTOL:g} relative: {bad}"


@needs_jit
@pytest.mark.parametrize("chain", [c for c in CHAINS if CHAINS[c]().kernel_data[3] != _k.PRISMATIC])
def test_pruned_variants_equal_the_full_one(chain, compiled):
    # Chains without prismatic joints run a kernel variant compiled without the prismatic
    # branches (pris = None), and without the moving-end path when every link end is rigid
    # (ends = None); the full variant (1, 1) must give the same numbers on them.
    model = CHAINS[chain]()
    fdat, idat, zeros, v = model.kernel_data
    assert v in (_k.RIGID_ENDS, _k.REVOLUTE) and _k.variant(idat) == v
    rng = np.random.default_rng(11)
    qs, qds, Qs = (np.concatenate(a) for a in zip(*_states(model, rng)))
    job = ALL_OBSERVABLES | _k.JOB_SOLVE | _k.JOB_M | _k.JOB_H
    a = _k.run(v, fdat, idat, qs, qds, Qs[:model.n_dof].copy(), job)
    b = _k.run(_k.PRISMATIC, fdat, idat, qs, qds, Qs[:model.n_dof].copy(), job)
    assert a.shape == b.shape
    assert _rel(b, a) <= RTOL


def test_models_select_their_variant():
    seen = set()
    for name, build in CHAINS.items():
        model = build()
        kinds = {jt.kind for jt in model.chain.joints}
        rigid_ends = all(ld.end_is_rigid for ld in model.link_data)
        want = _k.PRISMATIC if kinds - {"R"} else (_k.RIGID_ENDS if rigid_ends else _k.REVOLUTE)
        assert model.kernel_data[3] == want, name
        seen.add(want)
    assert seen == {_k.RIGID_ENDS, _k.REVOLUTE, _k.PRISMATIC}  # the chains cover every variant


# -- 2. no recompiles -----------------------------------------------------------------

@needs_jit
def test_one_signature_and_no_recompiles(compiled):
    # ``compiled`` has used every wrapper on every chain; now feed the wrappers odd input types.
    model = two_link_circle_model()
    N = model.n_dof
    q, qd = random_state(model, np.random.default_rng(1))
    dy.forward_dynamics(model, q.astype(np.float32), qd.astype(np.float32), np.ones(2 * N)[::2])
    dy.forward_dynamics(model, list(q), list(qd), [0.0] * N)
    dy.mass_matrix(model, np.zeros(N, dtype=int))
    dy.energy(model, np.vstack([q, q]).T[:, 0], qd)  # a non-contiguous column
    dy.energies(model, np.asfortranarray(np.vstack([q, q])), np.vstack([qd, qd]))
    kin.joint_positions(model, q[::-1][::-1])
    kin.frames(model, np.repeat(q, 2)[::2], qd)

    # One signature per kernel variant (``compiled`` used all three).
    kernel = _k.kernel
    assert hasattr(kernel, "signatures") and len(kernel.signatures) == 3, kernel.signatures
    fdat, idat, zeros, v = model.kernel_data
    assert v == _k.RIGID_ENDS
    qs, qds = kin.states(q, qd)
    out = _k.output(idat, 1, _k.JOB_SOLVE)
    assert kernel(fdat, idat, qs, qds, zeros, _k.JOB_SOLVE, *v, out) == 0.0 and np.all(np.isfinite(out))
    # Read-only states and forces are taken as they are (same numbers, no new signature).
    ro = [a.copy() for a in (qs, qds, zeros)]
    for a in ro:
        a.setflags(write=False)
    out_ro = _k.output(idat, 1, _k.JOB_SOLVE)
    assert kernel(fdat, idat, *ro, _k.JOB_SOLVE, *v, out_ro) == 0.0
    np.testing.assert_array_equal(out_ro, out)
    np.testing.assert_array_equal(dy.forward_dynamics(model, ro[0], ro[1]), out[3 + N:3 + 2 * N])
    # An output of the wrong size is refused before anything is written (status -1).
    short = np.full(out.size - 1, 7.0)
    assert kernel(fdat, idat, qs, qds, zeros, _k.JOB_SOLVE, *v, short) == -1.0 and np.all(short == 7.0)
    m_out = _k.output(idat, 1, _k.JOB_M)
    bad_calls = {
        "float32 states": (fdat, idat, qs.astype(np.float32), qds, zeros, _k.JOB_SOLVE, *v, out),
        "non-contiguous states": (fdat, idat, np.repeat(qs, 2)[::2], qds, zeros, _k.JOB_SOLVE, *v, out),
        "non-contiguous fdat": (np.repeat(fdat, 2)[::2], idat, qs, qds, zeros, _k.JOB_M, *v, m_out),
        "int32 idat": (fdat, idat.astype(np.int32), qs, qds, zeros, _k.JOB_M, *v, m_out),
        "2-d states": (fdat, idat, qs.reshape(1, -1), qds, zeros, _k.JOB_M, *v, m_out),
        "non-contiguous output": (fdat, idat, qs, qds, zeros, _k.JOB_M, *v, np.repeat(m_out, 2)[::2]),
    }
    for what, args in bad_calls.items():
        try:
            kernel(*args)
        except TypeError as exc:
            assert "No matching definition" in str(exc), (what, exc)
        else:
            pytest.fail(f"the kernel accepted {what} (compiled a new signature or converted)")
    assert len(kernel.signatures) == 3, kernel.signatures
    # The resting-contact entry points (compiled on first use, by ``compiled``): one signature each.
    for name in _kc._LAZY:
        assert len(getattr(_k, name).signatures) == 1, (name, getattr(_k, name).signatures)


def test_qddot_job_is_the_solve_jobs_qddot():
    # JOB_QDDOT alone writes q̈ (N,) and nothing else and returns the status; with other bits
    # the status section comes back. Checked against JOB_SOLVE's (qdot, q̈) section, and on a
    # singular M (theta_0 = pi/2: gimbal lock) against its status and NaNs.
    model = two_link_circle_model()
    fdat, idat, zeros, v = model.kernel_data
    N = model.n_dof
    q, qd = random_state(model, np.random.default_rng(5))
    Q = np.linspace(-1.0, 1.0, N)
    assert _k.output(idat, 1, _k.JOB_QDDOT).size == N
    assert _k.output(idat, 1, _k.JOB_QDDOT | _k.JOB_M).size == 3 + N + N * N
    for state, want_status in ((q, 0.0), (np.where(np.arange(N) == 4, np.pi / 2, q), 1.0)):
        solve = _k.run(v, fdat, idat, state, qd, Q, _k.JOB_SOLVE)
        out = _k.output(idat, 1, _k.JOB_QDDOT)
        assert _k.compiled(v)(fdat, idat, state, qd, Q, _k.JOB_QDDOT, *v, out) == want_status == solve[0]
        np.testing.assert_array_equal(out, solve[3 + N:3 + 2 * N])
        both = _k.run(v, fdat, idat, state, qd, Q, _k.JOB_QDDOT | _k.JOB_M)
        np.testing.assert_array_equal(both[:3], solve[:3])
        np.testing.assert_array_equal(both[3:3 + N], out)
    assert np.all(np.isnan(out))  # the singular state


@needs_jit
def test_read_only_applied_forces_and_wrong_sizes():
    # The kernel takes read-only states and forces as they are (its signature types them
    # read-only) and does not check bounds: the wrappers refuse arrays of the wrong size (a short
    # Q once read past its end).
    model = two_link_circle_model()
    q, qd = random_state(model, np.random.default_rng(2))
    Q = np.ones(model.n_dof)
    ref = dy.forward_dynamics(model, q, qd, Q.copy())
    Q.setflags(write=False)
    np.testing.assert_array_equal(dy.forward_dynamics(model, q, qd, Q), ref)
    with pytest.raises(ValueError, match="Q has shape"):
        dy.forward_dynamics(model, q, qd, np.ones(1))
    with pytest.raises(ValueError, match="shapes"):
        dy.forward_dynamics(model, q[:-1], qd[:-1])
    with pytest.raises(ValueError, match="states of shapes"):
        dy.mass_matrix(model, q[:-2])


def test_the_entry_point_checks_sizes_and_with_job_finite_the_entries():
    # The kernel refuses (-1.0, nothing written) states whose sizes disagree with each other or
    # with N, and a Q of another size with a solve job; with JOB_FINITE, a non-finite entry of qs
    # or qds (-2.0, nothing written); JOB_FINITE adds no output section. Before, a qds shorter
    # than qs was read past its end.
    model = two_link_circle_model()
    fdat, idat, zeros, v = model.kernel_data
    f, N = _k.compiled(v), model.n_dof
    q, qd = random_state(model, np.random.default_rng(7))
    assert _k.output(idat, 1, _k.JOB_QDDOT | _k.JOB_FINITE).size == N
    assert _k.output(idat, 2, _k.JOB_ENERGY | _k.JOB_FINITE).size == _k.output(idat, 2, _k.JOB_ENERGY).size
    for job in (_k.JOB_ENERGY, _k.JOB_QDDOT, _k.JOB_M | _k.JOB_POINTS):
        for bad in ((q, qd[:-1], zeros), (q[:-1], qd[:-1], zeros), (np.tile(q, 2), qd, zeros)):
            out = np.full(_k.output(idat, 1, job).size, 7.0)
            assert f(fdat, idat, *bad, job, *v, out) == -1.0 and np.all(out == 7.0)
    out = np.full(N, 7.0)
    assert f(fdat, idat, q, qd, np.ones(N - 1), _k.JOB_QDDOT, *v, out) == -1.0 and np.all(out == 7.0)
    for k in (0, N - 1):
        for value in (np.nan, np.inf):
            for pair in ((np.where(np.arange(N) == k, value, q), qd), (q, np.where(np.arange(N) == k, value, qd))):
                job = _k.JOB_ENERGY | _k.JOB_FINITE
                out = np.full(_k.output(idat, 1, job).size, 7.0)
                assert f(fdat, idat, *pair, zeros, job, *v, out) == -2.0 and np.all(out == 7.0)
                out = _k.output(idat, 1, _k.JOB_ENERGY)  # without the bit: computed, NaN or inf energies
                assert f(fdat, idat, *pair, zeros, _k.JOB_ENERGY, *v, out) == 0.0
                assert not np.all(np.isfinite(out[3:]))
    # the bit changes nothing else: the same energies and accelerations
    for job in (_k.JOB_ENERGY, _k.JOB_QDDOT, _k.JOB_M | _k.JOB_H | _k.JOB_POINTS):
        a, b = _k.output(idat, 1, job), _k.output(idat, 1, job | _k.JOB_FINITE)
        assert f(fdat, idat, q, qd, zeros, job, *v, a) == f(fdat, idat, q, qd, zeros, job | _k.JOB_FINITE, *v, b)
        np.testing.assert_array_equal(a, b)


def test_unchecked_forward_dynamics_passes_a_non_finite_state_through():
    # A solver's trial state may be non-finite: forward_dynamics returns NaN accelerations (the solver
    # then shrinks its step) and raises only with check=True (Model.forward_dynamics).
    model = two_link_circle_model()
    q, qd = random_state(model, np.random.default_rng(8))
    q[2] = np.nan
    assert np.all(np.isnan(dy.forward_dynamics(model, q, qd)))
    with pytest.raises(ValueError, match=f"q has non-finite entries: {model.coordinate_names[2]}$"):
        dy.forward_dynamics(model, q, qd, check=True)


@needs_jit
def test_no_compile_notice_when_the_cache_is_warm(compiled):
    # ``compiled`` compiled (or loaded) every variant; with a cache location they are on disk,
    # so a new process loads them silently (the notice is for a real compile only).
    if not _kc._state["cached"]:
        pytest.skip("numba has no cache location here")
    assert all(_kc._cache_is_warm(v) is True for v in (_k.RIGID_ENDS, _k.REVOLUTE, _k.PRISMATIC))
    code = ("import sys; sys.path[:0] = [%r, %r]; import numpy as np, test_kernel as tk; "
            "from gibbsimpact.dynamics import gibbs_appell as dy; "
            "[dy.forward_dynamics(m, *tk.random_state(m, np.random.default_rng(0))) "
            "for m in (tk.two_link_circle_model(), tk.CHAINS['spatial_two_link'](), "
            "tk.CHAINS['prismatic_planar']())]" % (str(TESTS_DIR), str(TESTS_ROOT)))
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_DISABLE_JIT"}
    run = subprocess.run([sys.executable, "-c", code], check=False, env=env, cwd=TESTS_DIR, capture_output=True,
                         text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    assert "compiling" not in run.stderr, run.stderr


# -- 3. a read-only install -----------------------------------------------------------

_RO_SCRIPT = r"""
import json, sys
import numpy as np
import gibbsimpact as gi
from gibbsimpact import kernel as k
from gibbsimpact.kernel.compile import _state
from gibbsimpact.dynamics.gibbs_appell import forward_dynamics
link = gi.Link(1.0, 1.0, 20.0, modes=[gi.Mode("clamped-clamped", "y")], geometric_stiffening=False)
model = gi.Model(gi.Chain([link, link]), gravity=(0.0, -9.81, 0.0))
q, qd = (np.array([float.fromhex(x) for x in v]) for v in json.loads(sys.argv[1]))
a = forward_dynamics(model, q, qd)
print(json.dumps({"file": gi.__file__, "cached": _state["cached"], "signatures": len(k.kernel.signatures),
                  "qddot": [float(x).hex() for x in a]}))
"""


def _tree(path):
    return sorted(str(p.relative_to(path)) for p in path.rglob("*"))


@needs_jit
def test_read_only_install_without_cache_directory(tmp_path):
    pkg_src = Path(gi.__file__).resolve().parent
    site = tmp_path / "site"
    pkg = site / "gibbsimpact"
    shutil.copytree(pkg_src, pkg, ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
    # root ignores file modes, so chmod alone leaves every cache location writable for root.
    # Make each of numba's locations impossible to create instead: NUMBA_CACHE_DIR and the
    # user-wide cache (XDG_CACHE_HOME) under a regular file, and, for root, a regular file where
    # the in-tree cache directory (the package's __pycache__) would go.
    blocker = tmp_path / "afile"
    blocker.write_text("a regular file: nothing can be created under it\n")
    root = os.geteuid() == 0
    if root:  # every package folder's (the kernel's cache would go to kernel/__pycache__)
        for d in [pkg] + [d for d in pkg.rglob("*") if d.is_dir()]:
            (d / "__pycache__").write_text("not a directory\n")
    home = tmp_path / "home"
    home.mkdir()
    before = {"pkg": _tree(pkg), "home": _tree(home)}
    dirs = [site, pkg, home] + [p for p in pkg.rglob("*") if p.is_dir()]
    files = [p for p in pkg.rglob("*") if p.is_file()]
    for p in files:
        p.chmod(0o444)
    for p in dirs:
        p.chmod(0o555)
    model = two_link_circle_model()
    q, _ = two_link_circle_state(model)
    qd = np.random.default_rng(3).normal(size=model.n_dof)
    env = {k: v for k, v in os.environ.items() if not k.startswith(("NUMBA_", "PYTHON"))}
    env.update(PYTHONPATH=str(site), NUMBA_CACHE_DIR=str(blocker / "cache"), HOME=str(home),
               XDG_CACHE_HOME=str(blocker / "xdg"))
    arg = json.dumps([[float(x).hex() for x in q], [float(x).hex() for x in qd]])
    try:
        run = subprocess.run([sys.executable, "-c", _RO_SCRIPT, arg], check=False, env=env, cwd=home,
                             capture_output=True, text=True, timeout=300)
    finally:
        for p in dirs:
            p.chmod(0o755)
        for p in files:
            p.chmod(0o644)
    assert run.returncode == 0, run.stderr
    out = json.loads(run.stdout)
    assert Path(out["file"]).resolve() == (pkg / "__init__.py").resolve()
    assert out["cached"] is False  # numba found no cache location and compiled without one
    assert out["signatures"] == 1
    # Nothing on stderr but the package's own notice (compiling ..., ready ... not cached ...).
    lines = [ln for ln in run.stderr.splitlines() if ln.strip()]
    assert all(ln.startswith("gibbsimpact: ") for ln in lines), run.stderr
    if lines:
        assert "not cached" in lines[-1], run.stderr
    assert {"pkg": _tree(pkg), "home": _tree(home)} == before  # nothing was written
    a = np.array([float.fromhex(x) for x in out["qddot"]])
    b = dy.forward_dynamics(model, q, qd)
    assert _rel(b, a) <= RTOL


# -- 4. two kernel paths, and finite differences ---------------------------------------

@pytest.mark.parametrize("chain", ["spatial_two_link", "fe_fixed_arm", "fe_free_spatial"])
def test_joint_jacobians_match_finite_differences(chain):
    model = CHAINS[chain]()
    rng = np.random.default_rng(7)
    step = 1e-6
    for _ in range(N_STATES):
        q, _ = random_state(model, rng, delta=0.1)
        O, J = kin.joint_positions_and_jacobians(model, q)
        np.testing.assert_array_equal(O, kin.joint_positions(model, q))
        fd = np.empty_like(J)
        for c in range(model.n_dof):
            e = np.zeros(model.n_dof)
            e[c] = step
            fd[:, :, c] = (kin.joint_positions(model, q + e) - kin.joint_positions(model, q - e)) / (2 * step)
        assert np.max(np.abs(J - fd)) <= 1e-8 * max(1.0, np.abs(J).max())


@pytest.mark.parametrize("chain", CHAINS)
def test_mass_matrix_gives_the_kinetic_energy(chain):
    model = CHAINS[chain]()
    rng = np.random.default_rng(11)
    for _ in range(N_STATES):
        q, qd = _state(model, rng)
        T_M = 0.5 * qd @ dy.mass_matrix(model, q) @ qd
        T_E = dy.energy(model, q, qd).kinetic
        assert abs(T_M - T_E) <= RTOL * abs(T_E), (T_M, T_E)
