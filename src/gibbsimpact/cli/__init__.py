"""The command line: ``gibbsimpact run | show | equations | sweep``."""

# The public names of gibbsimpact.cli as it was one module (documented paths keep working).
from .commands import (
    EXIT_OK, EXIT_INTERNAL, EXIT_BAD_INPUT, EXIT_STOPPED, EXIT_OUTPUT, EXIT_INTERRUPTED, EXIT_CODES,
    OUTPUT_FILES, build_parser, describe_case, cmd_show, cmd_equations, output_names,
    clear_outputs, write_outputs, cmd_run, main,
)

__all__ = [
    "EXIT_OK", "EXIT_INTERNAL", "EXIT_BAD_INPUT", "EXIT_STOPPED", "EXIT_OUTPUT", "EXIT_INTERRUPTED", "EXIT_CODES",
    "OUTPUT_FILES", "build_parser", "describe_case", "cmd_show", "cmd_equations", "output_names",
    "clear_outputs", "write_outputs", "cmd_run", "main",
]
