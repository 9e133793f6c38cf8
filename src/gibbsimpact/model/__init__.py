"""What is simulated: links, modes, finite elements, the chain and the immutable Model."""

# The public names of gibbsimpact.model as it was one module (documented paths keep working).
from .bodies import RigidBody
from .chain import Chain, Link
from .joints import JOINT_TYPES, FixedBase, FixedPrismatic, Revolute, SlidingPrismatic, Weld
from .model import Model
from .shapes import (DEFAULT_QUADRATURE, LinkData, gauss_legendre, link_deflection, link_foreshortening, link_integrals,
                     shape_functions)

__all__ = [
    "DEFAULT_QUADRATURE", "Link", "RigidBody", "Revolute", "FixedBase", "SlidingPrismatic", "FixedPrismatic", "Weld",
    "JOINT_TYPES", "Chain", "gauss_legendre", "LinkData", "shape_functions", "link_deflection", "link_foreshortening",
    "link_integrals", "Model",
]
