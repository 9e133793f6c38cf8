"""Pure functions f(model, q, qdot) of the flight phase: kinematics, Gibbs-Appell dynamics, applied forces."""

# The public names of gibbsimpact.dynamics as it was one module (documented paths keep working).
from .gibbs_appell import (
    SingularMassMatrixError, Energy, mass_matrix, bias_forces, potential_forces, diagnose_singular,
    forward_dynamics, energy, energies, center_of_mass, momentum,
)

__all__ = [
    "SingularMassMatrixError", "Energy", "mass_matrix", "bias_forces", "potential_forces",
    "diagnose_singular", "forward_dynamics", "energy", "energies", "center_of_mass", "momentum",
]
