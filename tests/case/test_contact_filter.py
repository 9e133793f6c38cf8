"""The [contact_filter] table of a case file (case/contact_filter.py): read into a LeadFilter, every
problem named at its key."""

import pytest

from case_texts import CASES, problems_of

TEXT = (CASES / "compass_gait.toml").read_text()


@pytest.mark.parametrize("old, new, key", [
    ('rule = "lead"', 'rule = "ahead"', "contact_filter.rule"),
    ('points = ["O1", "O3"]', 'points = ["O1", "O9"]', "contact_filter.points"),
    ('points = ["O1", "O3"]', 'points = ["O1", "O1"]', "contact_filter.points"),
    ('points = ["O1", "O3"]', 'points = "O1"', "contact_filter.points"),
    ("clearance_m = 0.05", "clearance_m = -0.05", "contact_filter.clearance_m"),
    ("clearance_m = 0.05", "clearance = 0.05", "contact_filter.clearance"),
    ("direction = [0.9996573249755573, -0.026176948307873153, 0.0]", "direction = [0.0, 0.0, 0.0]",
     "contact_filter.direction"),
])
def test_a_bad_contact_filter_key_is_named(tmp_path, old, new, key):
    assert old in TEXT
    err = problems_of(tmp_path, TEXT.replace(old, new, 1))
    assert key in [p for p, _ in err.problems], err.problems
