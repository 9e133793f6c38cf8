"""The compiled kernel: kinematics, Gibbs-Appell dynamics, energies, momentum, contact terms.

One source, compiled with numba (``njit``, explicit signatures, on-disk
cache). With ``NUMBA_DISABLE_JIT=1`` the same functions run as plain Python
(slow; the tests use it to check the compiled code against itself). The
public wrappers are in ``dynamics/kinematics.py`` and ``dynamics/gibbs_appell.py``.

Derivation: a composite-body recursion in the 4x4 form (O(n^2)), in stages
---------------------------------------------------------------------------

Each module holds one stage and the items of the derivation it implements:

    layout.py       fdat/idat of a packed model, kind codes, JOB bits, output sections
    mat4.py         4x4 helpers on the matrix stack B, skew, Rodrigues
    frames.py       position: frames T_i, Td_i, Tdd0_i and world twists S_c      items 1, 6, 7
    moments.py      moments: body moments P_i, Pv_i, m_r,i, q_l per link         items 5, 6
    assemble.py     assemble: M, h, dV/dq from twists and composites            items 2, 3, 4, 6, 7
    linalg.py       solve: Cholesky; least-squares symmetric and SVD solves
    observables.py  observables: energies, momenta, extra contact points
    entry.py        the one entry point ``kernel``, a dispatcher over the stages
    jacobian.py     d qddot/d q, d qddot/d qdot by compiled central differences (implicit methods)
    contact.py      wall gaps, event gaps, contact terms, friction solve (entry points of their own)
    compile.py      signatures, variants, lazy groups, numba's cache, notices

This package re-exports the names the rest of gibbsimpact uses; private names live in their
modules (``from gibbsimpact.kernel.layout import _H``). The attribute
``gibbsimpact.kernel.layout`` is the function ``layout`` (as before the split into modules),
so ``import gibbsimpact.kernel.layout as m`` gives that function too: import the module's
names with ``from gibbsimpact.kernel.layout import ...``.
"""

from __future__ import annotations

from .compile import (NOTICE_AFTER_S, PRISMATIC, REVOLUTE, RIGID_ENDS, compiled, ensure_compiled, jacobian_entry,
                      jit_disabled, lazy, output, radau_entry, run, variant)
from .contact import contact_terms, event_gaps, friction_solve
from .entry import kernel
from .frames import chain_frames
from .layout import (BASE_FIXED, BASE_FREE, BASE_PLANAR, END_GENERAL, END_RIGID, JOB_ENERGY, JOB_FINITE, JOB_FRAMES,
                     JOB_H, JOB_JACOBIANS, JOB_M, JOB_MOMENTUM, JOB_POINTS, JOB_QDDOT, JOB_SOLVE, JOINT_PA, JOINT_PB,
                     JOINT_R, KIND_MODE, KIND_PA, KIND_PB, KIND_ROTATION, KIND_TRANSLATION, SECTIONS, WALL_CIRCLE, WALL_PLANE,
                     WALL_SPHERE, contact_layout, layout)
from .jacobian import jacobian_size, state_jacobian
from .linalg import _svd_solve, sym_solve
from .mat4 import rodrigues_coefficients, rodrigues_directional

__all__ = [
    "BASE_FIXED", "BASE_FREE", "BASE_PLANAR", "END_GENERAL", "END_RIGID", "JOB_ENERGY", "JOB_FINITE", "JOB_FRAMES", "JOB_H",
    "JOB_JACOBIANS", "JOB_M", "JOB_MOMENTUM", "JOB_POINTS", "JOB_QDDOT", "JOB_SOLVE", "JOINT_PA", "JOINT_PB",
    "JOINT_R", "KIND_MODE", "KIND_PA", "KIND_PB", "KIND_ROTATION", "KIND_TRANSLATION", "NOTICE_AFTER_S",
    "PRISMATIC", "REVOLUTE", "RIGID_ENDS", "SECTIONS", "WALL_CIRCLE", "WALL_PLANE", "WALL_SPHERE", "chain_frames",
    "compiled", "contact_layout", "contact_terms", "ensure_compiled", "event_gaps", "friction_solve",
    "jacobian_entry", "jacobian_size", "jit_disabled", "kernel", "layout", "lazy", "output", "rodrigues_coefficients", "rodrigues_directional", "run",
    "radau_entry", "state_jacobian", "sym_solve", "variant",
    "_svd_solve",  # tests/contact checks it against numpy's lstsq
]
