"""gibbsimpact: flexible multi-link chains (free-flying or on a fixed base) colliding with walls.

Flight phase: recursive 4x4 Gibbs-Appell dynamics with assumed modes or Hermite finite elements.
Impact phase: Newton's restitution law as an impulse problem.
See docs/ and the README for the symbols and conventions.

The package is laid out by stage (docs/architecture.md); data flows one way, each folder
importing only from the folders before it in this list:

    kernel -> model -> dynamics -> symbolic -> contact -> simulation -> plotting -> io
           -> case -> study -> cli
"""

import importlib as _importlib
import sys as _sys

from .dynamics import Energy, SingularMassMatrixError, profiles
from .model import Chain, FixedBase, FixedPrismatic, Link, Model, Revolute, RigidBody, SlidingPrismatic, Weld
from .model.modes import Mode, natural_frequency
from .simulation.results import ImpactRecord, Result
from .simulation.simulate import simulate
from .study.sweep import sweep
from .symbolic import derive_equations
from .case import Case, CaseError, load_case
from .io import load_result
from .simulation.validity import ValidityWarning
from .contact.walls import Circle, Plane, Sphere

__version__ = "0.1.0"

__all__ = [
    "Case", "CaseError", "Chain", "Circle", "Energy", "FixedBase", "FixedPrismatic", "ImpactRecord", "Link", "Mode", "Model", "Plane",
    "Result", "Revolute", "RigidBody", "SingularMassMatrixError", "SlidingPrismatic", "Sphere", "ValidityWarning", "Weld", "derive_equations", "load_case", "load_result", "natural_frequency", "profiles", "simulate", "sweep", "__version__",
]

# The module paths of the flat layout, before the split by stage (gibbsimpact.walls, ...):
# each is the very module object of its new home, so an import, an attribute or a
# monkeypatch through either path reaches the same code. (gibbsimpact.kernel, .model,
# .dynamics, .symbolic, .plotting, .io, .case and .cli are packages of those names that
# carry the public names of the module they replace.)
MOVED_MODULES = {
    "modes": "model.modes", "elements": "model.elements",
    "kinematics": "dynamics.kinematics", "forces": "dynamics.forces", "inputs": "dynamics.inputs",
    "walls": "contact.walls", "impact": "contact.impact", "friction": "contact.friction",
    "resting": "contact.resting", "linkpoints": "contact.candidates",
    "simulate": "simulation.simulate", "flight": "simulation.flight", "contacts": "simulation.contacts",
    "limits": "simulation.joint_limits", "recorder": "simulation.recorder",
    "accumulation": "simulation.accumulation", "progress": "simulation.progress",
    "validity": "simulation.validity", "results": "simulation.results", "sweep": "study.sweep",
}
for _old, _new in MOVED_MODULES.items():
    _module = _importlib.import_module(f"{__name__}.{_new}")
    _sys.modules[f"{__name__}.{_old}"] = _module
    if _old not in globals():  # gibbsimpact.simulate and .sweep stay the functions
        globals()[_old] = _module
del _old, _new, _module
