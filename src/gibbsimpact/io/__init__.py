"""Result files: CSV, JSON summary, NPZ archive, atomic writes."""

# The public names of gibbsimpact.io as it was one module (documented paths keep working).
from .result_files import (
    FORMAT_VERSION, TEMP_MARK, temporary_name, atomic_path, check_directory, save_figure, coordinate_columns,
    velocity_columns, write_timeseries_csv, IMPACT_COLUMNS, write_impacts_csv, write_episodes_csv,
    write_contact_forces_csv, to_csv, read_csv, versions, summary,
    write_summary_json, model_to_dict, model_from_dict, wall_to_dict, wall_from_dict, save_result,
    load_result,
)
from .contact_force_files import contact_force_columns

__all__ = [
    "FORMAT_VERSION", "TEMP_MARK", "temporary_name", "atomic_path", "check_directory", "save_figure",
    "coordinate_columns", "velocity_columns", "write_timeseries_csv", "IMPACT_COLUMNS",
    "write_impacts_csv", "write_episodes_csv", "contact_force_columns", "write_contact_forces_csv", "to_csv",
    "read_csv",
    "versions", "summary", "write_summary_json", "model_to_dict", "model_from_dict",
    "wall_to_dict", "wall_from_dict", "save_result", "load_result",
]
