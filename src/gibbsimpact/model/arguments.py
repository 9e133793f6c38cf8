"""The one reader of a "one item or a list of items" argument (Link modes and bodies, Chain links)."""

from __future__ import annotations


def items_of(value, cls, name: str, fix: str) -> tuple:
    """``value``, one ``cls`` or an iterable of them, as a tuple of ``cls``; a ValueError names the
    argument ``name`` (e.g. "Link modes"), the entry at fault and ``fix`` (how to build one)."""
    if isinstance(value, cls):
        return (value,)
    try:
        items = tuple(value)
    except TypeError:
        raise ValueError(f"{name}={value!r} must be a list of gibbsimpact.{cls.__name__}") from None
    for k, item in enumerate(items):
        if not isinstance(item, cls):
            raise ValueError(f"{name}[{k}]={item!r} is not a gibbsimpact.{cls.__name__}{fix}")
    return items
