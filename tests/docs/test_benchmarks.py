"""The benchmark scripts' own logic (benchmarks/): what bench_kernel's baseline section (bench_baseline.py)
gives the old commit."""

from __future__ import annotations

import importlib
import sys
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def baseline():
    """benchmarks/bench_baseline.py as a module (it imports bench_kernel, its neighbour, as the scripts do)."""
    sys.path.insert(0, str(ROOT / "benchmarks"))
    try:
        yield importlib.import_module("bench_baseline")
    finally:
        sys.path.remove(str(ROOT / "benchmarks"))


def _without(node, keys):
    if isinstance(node, dict):
        return {k: _without(v, keys) for k, v in node.items() if k not in keys}
    if isinstance(node, list):
        return [_without(v, keys) for v in node]
    return node


def test_the_baseline_reads_case_1_without_the_keys_its_commit_predates(baseline):
    # 54f2dfd's reader rejects geometric_stiffening; case 1 sets it to false on both links, which is what
    # that commit simulates, so the baseline's case is today's with those lines gone and nothing else changed.
    text = baseline.CASE1.read_text()
    assert text.count("geometric_stiffening = false") == 2
    old = tomllib.loads(baseline.baseline_case_text(text))
    assert old == _without(tomllib.loads(text), set(baseline.BASELINE_UNKNOWN_KEYS))
    assert all("geometric_stiffening" not in link for link in old["links"])


def test_the_baseline_refuses_a_case_its_commit_would_simulate_differently(baseline):
    text = baseline.CASE1.read_text().replace("geometric_stiffening = false", "geometric_stiffening = true", 1)
    with pytest.raises(ValueError, match="geometric_stiffening = True, but commit 54f2dfd only simulates "
                                         "geometric_stiffening = False"):
        baseline.baseline_case_text(text)
