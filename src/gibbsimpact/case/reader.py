"""Reading a parsed case table and collecting its problems: :class:`_Reader` and :class:`CaseError`.

Every check reads a value through one ``_Reader``, which records ``(key path, message)`` for each
problem and hands back ``_BAD`` instead of the value, so that the reading goes on and one
:class:`CaseError` lists every problem of the file. A value computed from a ``_BAD`` one is
``_BAD`` too and is not checked again: a problem is reported once, at the key to change
(docs/case-format.md, "Validation collects every problem").
"""

from __future__ import annotations

import difflib
import math
import re
from numbers import Integral, Real

from .keypaths import join
from .schema import Range, range_of
from .text import fmt, type_name

__all__ = ["CaseError"]

#: A key the table does not set (distinct from None, a value some keys default to).
_MISSING = object()
#: In place of a value that has a problem (already reported).
_BAD = object()


class CaseError(ValueError):
    """A case file is invalid. ``problems`` lists (key path, message) for every problem found."""

    def __init__(self, source: str, problems: list[tuple[str, str]]):
        self.source = source
        self.problems = list(problems)
        if len(self.problems) == 1:
            path, msg = self.problems[0]
            text = f"{source}: {path}: {msg}" if path else f"{source}: {msg}"
        else:
            lines = [f"{source}: {len(self.problems)} problems:"]
            lines += [f"  {p}: {m}" if p else f"  {m}" for p, m in self.problems]
            text = "\n".join(lines)
        super().__init__(text)


def _is_number(v) -> bool:
    return isinstance(v, Real) and not isinstance(v, bool)


def _too_large(x) -> bool:
    """An integer beyond the double range (TOML integers are unbounded)."""
    try:
        float(x)
    except OverflowError:
        return True
    return False


class _Reader:
    """Collects problems while reading nested TOML tables."""

    def __init__(self):
        self.problems: list[tuple[str, str]] = []

    def add(self, path: str, message: str):
        self.problems.append((path, message))

    def table(self, value, path: str, allowed: dict, what: str = "a table") -> dict | None:
        """Check that value is a table and report its unknown keys."""
        if not isinstance(value, dict):
            self.add(path, f"expected {what}, got {type_name(value)}")
            return None
        for key in value:
            if key not in allowed:
                close = difflib.get_close_matches(key, list(allowed), n=1, cutoff=0.6)
                hint = f"did you mean {close[0]!r}?" if close else f"allowed keys: {', '.join(allowed)}"
                self.add(join(path, key), f"unknown key ({hint})")
        return value

    def get(self, tbl: dict, path: str, key: str, kind: str, *, required=False, default=None, what=""):
        """Read tbl[key] as ``kind``; return default when absent, _BAD on a problem."""
        p = join(path, key)
        if key not in tbl:
            if required:
                self.add(p, f"missing ({what})" if what else "missing")
                return _BAD
            return default
        return self.value(tbl[key], p, kind)

    def value(self, v, p: str, kind: str, rng: Range | None = None):
        """v read as ``kind`` ("str", "bool", "number", "vector<n>"); numbers and
        vectors are checked against ``rng``, by default RANGES of the key path p."""
        def bad(expected):
            self.add(p, f"expected {expected}, got {type_name(v)}")
            return _BAD

        if kind == "str":
            return v if isinstance(v, str) else bad("a string")
        if kind == "bool":
            return v if isinstance(v, bool) else bad("true or false")
        rng = rng or range_of(p)  # every numeric key has a range: a KeyError here is a bug
        if kind == "number":
            if rng.integer and not (isinstance(v, Integral) and not isinstance(v, bool)):
                return bad("an integer")
            if not _is_number(v):
                return bad("a number")
            if not self.in_range(p, v, rng):
                return _BAD
            return int(v) if rng.integer else float(v)
        m = re.fullmatch(r"vector(\d)", kind)
        if m:
            n = int(m.group(1))
            if not isinstance(v, list) or len(v) != n or not all(_is_number(x) for x in v):
                return bad(f"an array of {n} numbers")
            return [float(x) for x in v] if self.in_range(p, v, rng) else _BAD
        raise AssertionError(kind)

    def in_range(self, p: str, v, rng: Range) -> bool:
        """Check a number (or each component, or the length of a direction) against rng; add the problem."""
        values = v if isinstance(v, list) else [v]
        shown = f"[{', '.join(fmt(x) for x in v)}]" if isinstance(v, list) else fmt(v)
        why = f" ({rng.why})" if rng.why else ""
        if any(_too_large(x) for x in values):
            self.add(p, f"too large for a number: must be in {rng}{why}, got {shown}")
            return False
        xs = [float(x) for x in values]
        if rng.direction:
            if not any(xs):
                self.add(p, "is the zero vector; give a direction")
                return False
            length = math.hypot(*xs) if all(math.isfinite(x) for x in xs) else math.nan
            if not rng.low <= length <= rng.high:
                self.add(p, f"must have a length in {rng}{why}, got {shown}")
                return False
            return True
        ok = all((rng.low <= x <= rng.high) or (rng.inf_ok and x == math.inf) for x in xs)
        if not ok:
            every = "every component " if isinstance(v, list) else ""
            self.add(p, f"{every}must be in {rng}{why}, got {shown}")
        return ok


def _build_each(tables, build):
    """[build(k, table) ...], or _BAD if any entry is bad (every entry is still checked)."""
    out = [build(k, t) for k, t in enumerate(tables)]
    return _BAD if any(x is _BAD for x in out) else out
