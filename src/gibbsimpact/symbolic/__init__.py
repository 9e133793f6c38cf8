"""Symbolic equations of motion (sympy): derive_equations."""

# The public names of gibbsimpact.symbolic as it was one module (documented paths keep working).
from .derive import (
    METHODS, rodrigues_coefficient, derive_equations, OperationCount, NumericEquations, Equations,
)

__all__ = [
    "METHODS", "rodrigues_coefficient", "derive_equations", "OperationCount", "NumericEquations",
    "Equations",
]
