"""The test tree's own layout rules.

pytest's default import mode ("prepend") imports every test file as a top-level module named
by its basename, so two files ``tests/a/test_x.py`` and ``tests/b/test_x.py`` cannot both be
collected: the second fails with "import file mismatch" and the whole run errors. A branch that
adds a test file whose name another folder already uses breaks the suite only after it is merged;
this test names the clash on the branch.
"""

from collections import defaultdict
from pathlib import Path

TESTS = Path(__file__).resolve().parents[1]


def test_test_file_basenames_are_unique():
    where = defaultdict(list)
    for path in TESTS.rglob("test_*.py"):
        where[path.name].append(str(path.relative_to(TESTS)))
    clashes = {name: paths for name, paths in where.items() if len(paths) > 1}
    assert not clashes, f"test files share a basename (rename one of each): {clashes}"
