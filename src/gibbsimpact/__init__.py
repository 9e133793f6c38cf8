"""gibbsimpact: free-flying flexible multi-link chains colliding with curved walls.

Flight phase: recursive 4x4 Gibbs-Appell dynamics with assumed modes.
Impact phase: Newton's restitution law as an impulse problem.
See docs/ and the README for the symbols and conventions.
"""

from .dynamics import Energy, SingularMassMatrixError
from .model import Chain, Link, Model
from .modes import Mode, natural_frequency

__version__ = "0.1.0"

__all__ = ["Chain", "Energy", "Link", "Mode", "Model", "SingularMassMatrixError", "natural_frequency", "__version__"]
