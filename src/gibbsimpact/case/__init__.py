"""Case files (TOML): everything one run needs, validated in one pass (docs/case-format.md).

The modules, in the order they build on each other:

    text         how values read in messages (short numbers, TOML types)
    keypaths     the key-path grammar (links[2].EI_N_m2), shared with gibbsimpact.study.sweep
    schema       every key, its meaning, unit and range
    reader       reading values and collecting problems (CaseError)
    links        [[links]], [links.joint], [base] -> the Model
    run_options  [time], [solver], [output] and the keywords of Case.simulate that override them
    initial      [initial] -> (q0, qdot0), and the checks at t = 0
    builders     [[walls]], [[inputs]], the Case: load_case, case_from_dict
"""

# The public names of gibbsimpact.case as it was one module (documented paths keep working).
from .builders import Case, case_from_dict, load_case
from .reader import CaseError
from .schema import (
    MAX_MODE_FREQUENCY, MAX_SAMPLES, OUTPUT_DEFAULTS, OVERRIDE_KEYS, RANGES, SOLVER_KEYS, Range,
)

__all__ = [
    "Range", "RANGES", "MAX_SAMPLES", "MAX_MODE_FREQUENCY", "SOLVER_KEYS", "OVERRIDE_KEYS",
    "OUTPUT_DEFAULTS", "CaseError", "Case", "load_case", "case_from_dict",
]
