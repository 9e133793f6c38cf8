"""Case files (TOML): schema, reader, builders."""

# The public names of gibbsimpact.case as it was one module (documented paths keep working).
from .reader import (
    Range, RANGES, MAX_SAMPLES, MAX_MODE_FREQUENCY, SOLVER_KEYS, OVERRIDE_KEYS, OUTPUT_DEFAULTS,
    CaseError, Case, load_case, case_from_dict,
)

__all__ = [
    "Range", "RANGES", "MAX_SAMPLES", "MAX_MODE_FREQUENCY", "SOLVER_KEYS", "OVERRIDE_KEYS",
    "OUTPUT_DEFAULTS", "CaseError", "Case", "load_case", "case_from_dict",
]
