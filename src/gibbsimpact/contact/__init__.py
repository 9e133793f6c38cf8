"""Walls and what happens at them (gaps, impacts, friction, resting contact); knows nothing of the loop."""
