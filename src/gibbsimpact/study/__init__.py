"""Parameter studies: sweeps over case-file keys."""
