"""The one event loop (simulate) over named stages, and its records (Result, ImpactRecord)."""
