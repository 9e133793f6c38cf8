"""Symbolic equations of motion (sympy): derive_equations."""

# The public names of gibbsimpact.symbolic as it was one module (documented paths keep working).
from .algebra import rodrigues_coefficient
from .derive import METHODS, derive_equations
from .equations import Equations, NumericEquations
from .printer import OperationCount

__all__ = [
    "METHODS", "rodrigues_coefficient", "derive_equations", "OperationCount", "NumericEquations",
    "Equations",
]
