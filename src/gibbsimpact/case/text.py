"""How the values of a case file read in messages: short numbers and the TOML type of a value."""

from __future__ import annotations

import math
import re
from decimal import Decimal
from numbers import Real

__all__ = ["fmt", "type_name"]


def fmt(x) -> str:
    """A number as short text: 1e-06 -> '1e-6', 10000.0 -> '1e4', an int of 401 digits -> '1e400'."""
    def short(text):
        return re.sub(r"e\+?(-?)0*(\d)", r"e\1\2", text)

    if isinstance(x, int) and not isinstance(x, bool):
        return short(format(Decimal(x).normalize(), ".6g")) if abs(x) >= 10**16 else str(x)
    plain = short(f"{x:.6g}")
    mantissa, _, exponent = f"{x:.5e}".partition("e")
    sci = short(f"{mantissa.rstrip('0').rstrip('.')}e{exponent}") if math.isfinite(x) else plain
    return sci if len(sci) + 1 < len(plain) else plain


def type_name(v) -> str:
    """What a parsed TOML value is, for 'expected ..., got <type_name>': 'the string 'x'', 'a table', ..."""
    if isinstance(v, bool):
        return f"the boolean {str(v).lower()}"
    if isinstance(v, str):
        return f"the string {v!r}"
    if isinstance(v, dict):
        return "a table"
    if isinstance(v, list):
        return f"an array of {len(v)}"
    if isinstance(v, Real):
        return f"the number {fmt(v)}"
    return type(v).__name__
