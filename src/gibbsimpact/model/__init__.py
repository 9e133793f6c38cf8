"""What is simulated: links, modes, finite elements, the chain and the immutable Model."""

# The public names of gibbsimpact.model as it was one module (documented paths keep working).
from .model import (
    DEFAULT_QUADRATURE, Link, Revolute, FixedBase, SlidingPrismatic, FixedPrismatic, JOINT_TYPES,
    Chain, gauss_legendre, LinkData, shape_functions, link_deflection, link_integrals, Model,
)

__all__ = [
    "DEFAULT_QUADRATURE", "Link", "Revolute", "FixedBase", "SlidingPrismatic", "FixedPrismatic",
    "JOINT_TYPES", "Chain", "gauss_legendre", "LinkData", "shape_functions", "link_deflection",
    "link_integrals", "Model",
]
