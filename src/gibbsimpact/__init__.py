"""gibbsimpact: flexible multi-link chains (free-flying or on a fixed base) colliding with walls.

Flight phase: recursive 4x4 Gibbs-Appell dynamics with assumed modes or Hermite finite elements.
Impact phase: Newton's restitution law as an impulse problem.
See docs/ and the README for the symbols and conventions.
"""

from .dynamics import Energy, SingularMassMatrixError
from .model import Chain, FixedBase, FixedPrismatic, Link, Model, Revolute, SlidingPrismatic
from .modes import Mode, natural_frequency
from .results import ImpactRecord, Result
from .simulate import simulate
from .sweep import sweep
from .symbolic import derive_equations
from .case import Case, CaseError, load_case
from .io import load_result
from .validity import ValidityWarning
from .walls import Circle, Plane, Sphere

__version__ = "0.1.0"

__all__ = [
    "Case", "CaseError", "Chain", "Circle", "Energy", "FixedBase", "FixedPrismatic", "ImpactRecord", "Link", "Mode", "Model", "Plane",
    "Result", "Revolute", "SingularMassMatrixError", "SlidingPrismatic", "Sphere", "ValidityWarning", "derive_equations", "load_case", "load_result", "natural_frequency", "simulate", "sweep", "__version__",
]
