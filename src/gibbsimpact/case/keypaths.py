"""Key paths: the one grammar that names a value of a case file, for the reader and for sweeps.

A key path is the dotted chain of table keys down to one value, an entry of an array of
tables numbered **from 1** in brackets::

    restitution   time.t_end_s   links[2].EI_N_m2   links[1].modes[2].kind
    walls[1].radius_m   initial.coordinates.theta_1_deg

The shell form writes an entry as a dotted number, ``links.2.EI_N_m2``; it is an entry
only where the case has an array of tables (:func:`resolve`). The reader's messages and
a sweep's columns always use the bracket form (:func:`join`).

Tokens (:func:`split`): a ``str`` is a table key (or a dotted number), an ``int`` an entry
index counted from **0**, so that ``key_path(*split(p)) == p`` for a path in bracket form.
"""

from __future__ import annotations

import re

from .text import type_name

__all__ = ["PathProblem", "join", "key_path", "split", "resolve", "assign", "schema_key", "within"]

_SEGMENT = re.compile(r"([^\[\]]*)((?:\[\d+\])*)")
_EXAMPLES = "links[1].EI_N_m2, walls[1].radius_m, initial.coordinates.theta_1_deg"


class PathProblem(ValueError):
    """A key path that names no value of the case: ``path`` (as far as it holds) and ``message``."""

    def __init__(self, path: str, message: str):
        super().__init__(f"{path}: {message}")
        self.path, self.message = path, message


def join(path: str, token) -> str:
    """One step down: ``links`` + 0 -> ``links[1]``; ``links[1]`` + ``EI_N_m2`` -> ``links[1].EI_N_m2``;
    ``""`` + ``restitution`` -> ``restitution``. An int token is an entry counted from 0."""
    if isinstance(token, int):
        return f"{path}[{token + 1}]"
    return f"{path}.{token}" if path else str(token)


def key_path(*tokens) -> str:
    """The key path of tokens: ``key_path("links", 1, "joint", "type")`` -> ``links[2].joint.type``."""
    path = ""
    for token in tokens:
        path = join(path, token)
    return path


def split(key: str) -> list:
    """Tokens of a key path: ``links[2].EI_N_m2`` -> ['links', 1, 'EI_N_m2'] (a bracketed entry as
    an int counted from 0), ``links.2.EI_N_m2`` -> ['links', '2', 'EI_N_m2'] (a dotted number stays
    a string: an entry only where the case has an array there).

    Raises PathProblem for what is no key path (an empty string, an empty segment, stray brackets).
    """
    if not isinstance(key, str) or not key.strip():
        raise PathProblem(str(key), "a key path is a non-empty string such as links[1].EI_N_m2")
    tokens = []
    for part in key.strip().split("."):
        m = _SEGMENT.fullmatch(part)
        if not m or not (m.group(1) or m.group(2)):
            raise PathProblem(key, f"not a key path (write it as in the case file, e.g. {_EXAMPLES})")
        if m.group(1):
            tokens.append(m.group(1))
        tokens += [int(k) - 1 for k in re.findall(r"\[(\d+)\]", m.group(2))]
    return tokens


def resolve(data: dict, key: str) -> tuple[str, tuple]:
    """(key path in bracket form, tokens with entries counted from 0) of ``key`` in the parsed case ``data``.

    Missing tables on the way are allowed (:func:`assign` creates them); raises PathProblem for
    an entry that does not exist, a key where an array of tables needs an entry number, an entry
    number on a table, or a step below a value that is no table.
    """
    tokens = split(key)
    node, path, out = data, "", []
    for pos, tok in enumerate(tokens):
        if isinstance(node, list):
            if isinstance(tok, str) and not tok.isdigit():
                raise PathProblem(path, f"is an array of {len(node)} tables; give the entry number from 1, "
                                        f"e.g. {path}[1].{tok}")
            number = int(tok) if isinstance(tok, str) else tok + 1
            if not 1 <= number <= len(node):
                raise PathProblem(f"{path}[{number}]", f"no such entry: the case has {len(node)} {path} "
                                                       "(numbered from 1)")
            tok = number - 1
            node = node[tok]
        elif isinstance(node, dict):
            if isinstance(tok, int):
                raise PathProblem(join(path, tok), f"{path or 'the case'} is a table, not an array of tables")
            child = node.get(tok)
            if child is None and pos + 1 < len(tokens) and isinstance(tokens[pos + 1], int):
                raise PathProblem(join(path, tok), "no such array of tables in the case")
            node = child if child is not None else {}
        else:
            raise PathProblem(path, f"is {type_name(node)}, not a table: nothing to set below it")
        out.append(tok)
        path = join(path, tok)
    return path, tuple(out)


def assign(data: dict, tokens: tuple, value) -> None:
    """data[t0][t1]...[tn] = value, creating missing tables on the way (tokens from :func:`resolve`)."""
    node = data
    for tok in tokens[:-1]:
        if isinstance(node, dict) and tok not in node:
            node[tok] = {}
        node = node[tok]
    node[tokens[-1]] = value


def schema_key(path: str) -> str:
    """The key of a path in the schema tables (gibbsimpact.case.schema.RANGES), entries left out:
    ``links[2].modes[1].number`` -> ``links.modes.number``."""
    return re.sub(r"\[\d+\]", "", path)


def within(path: str, key: str) -> bool:
    """Whether ``path`` is ``key`` itself or a value inside it (``links[1].EI_N_m2`` is within ``links[1]``)."""
    return path == key or path.startswith(key + ".") or path.startswith(key + "[")
