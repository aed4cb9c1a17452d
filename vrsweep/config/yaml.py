"""YAML in and out, through ruamel.yaml: the round-trip reader (YAML 1.2, lines kept in ``.lc``
for messages), plain-Python copies of its tree, and a ``--set`` value read as a scalar. The
canonical text of a resolved config is written by ``config/dump.py``.
"""

from __future__ import annotations

import datetime
import warnings

from ruamel.yaml import YAML
from ruamel.yaml.comments import TaggedScalar
from ruamel.yaml.constructor import RoundTripConstructor
from ruamel.yaml.reader import ReaderError

from vrsweep.config.wording import show
from vrsweep.numbertext import beyond_double, yaml_number_problem


class OutOfDouble:
    """A YAML number that is not the number written, by vrsweep's rule (numbertext): one no double
    holds, ``1e400`` (ruamel reads inf) or ``1e-400`` (read as 0), or one not in decimal notation
    (``0x10``, ``1_000``). Kept as written, with why, so that a field says so: ``rtol: 1e-400`` was
    refused as "got 0.0", and ``gamma: 1e-400`` ran as 0. No field accepts it (it is no number)."""

    def __init__(self, text, problem):
        self.text, self.problem = text, problem

    def __repr__(self):
        return f"{self.text} ({self.problem})"


class _Constructor(RoundTripConstructor):
    def construct_yaml_float(self, node):
        value = super().construct_yaml_float(node)
        problem = _as_written(node)
        if problem:
            return OutOfDouble(node.value, problem)
        if isinstance(value, float):
            problem = beyond_double(str(node.value), value)
            if problem:
                return OutOfDouble(node.value, problem)
        return value

    def construct_yaml_int(self, node):
        value = super().construct_yaml_int(node)
        problem = _as_written(node)
        return OutOfDouble(node.value, problem) if problem else value


def _as_written(node):
    """Why a number YAML resolved, as written, is not a number by vrsweep's rule (numbertext): 0x10,
    1_000, YAML 1.1's 010 or 1:30; None for decimal notation. A quoted or tagged value is not
    resolved, so it is not checked here."""
    return yaml_number_problem(str(node.value)) if node.style is None else None


_Constructor.add_constructor("tag:yaml.org,2002:float", _Constructor.construct_yaml_float)
_Constructor.add_constructor("tag:yaml.org,2002:int", _Constructor.construct_yaml_int)


def _round_trip_yaml():
    """ruamel's round-trip reader, its floats checked against the doubles (OutOfDouble)."""
    yaml = YAML(typ="rt")
    yaml.Constructor = _Constructor
    return yaml


def load_round_trip(text, allow_duplicate_keys=False):
    """ruamel's round-trip tree of ``text`` (CommentedMap ...), or None for an empty document."""
    yaml = _round_trip_yaml()
    yaml.allow_duplicate_keys = allow_duplicate_keys
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # e.g. ReusedAnchorWarning: not the user's concern here
        return yaml.load(text)


def compose(text):
    """The YAML node graph of ``text`` (before keys are merged), for reporting duplicate keys."""
    return YAML(typ="rt").compose(text)


class CyclicAlias(Exception):
    pass


# A config's whole tree, aliases expanded, holds a few hundred values; YAML aliases can make 1 kB
# of text expand to 10^10 (ten levels of ten aliases). plain_data stops past this many values.
MAX_EXPANDED_VALUES = 100_000


class TooManyValues(Exception):
    """The document, its aliases expanded, holds more than MAX_EXPANDED_VALUES values."""


def plain_data(node, _active=None, _budget=None):
    """ruamel's tree as plain dict/list/float/int/str/bool (keys as str), keeping order.

    Raises CyclicAlias for a tree that contains itself, TooManyValues past MAX_EXPANDED_VALUES
    values (aliases counted as many times as they are expanded)."""
    active = set() if _active is None else _active
    budget = [MAX_EXPANDED_VALUES] if _budget is None else _budget
    budget[0] -= 1
    if budget[0] < 0:
        raise TooManyValues
    if isinstance(node, (dict, list)):
        if id(node) in active:
            raise CyclicAlias
        tag = getattr(getattr(node, "tag", None), "value", None)
        if tag:  # a mapping or list under a tag of the user's own (!custom {g: 5}): no field reads
            # tags, and a tagged scalar is refused as the opaque thing it is; the tagged mapping was
            # read as if untagged
            return _Opaque(f"{tag} {'{...}' if isinstance(node, dict) else '[...]'}")
        active.add(id(node))
        try:
            if isinstance(node, dict):
                return {key_text(key): plain_data(value, active, budget) for key, value in node.items()}
            return [plain_data(item, active, budget) for item in node]
        finally:
            active.discard(id(node))
    if isinstance(node, bool):
        return bool(node)
    if isinstance(node, int):
        return int(node)
    if isinstance(node, float):
        return float(node)
    if isinstance(node, str):
        return _join_surrogates(str(node))
    if isinstance(node, TaggedScalar):
        return _Opaque(f"{node.tag} {node.value}")
    if isinstance(node, (datetime.date, datetime.datetime)):
        return _Opaque(node.isoformat())
    return node  # anything else is rejected as a wrong type by the schema


class _Opaque:
    """A YAML value of a kind no field accepts (a date, a !tagged scalar), shown as written."""

    def __init__(self, text):
        self.text = text

    def __repr__(self):
        return self.text


def _join_surrogates(text: str) -> str:
    """ruamel reads the escapes "\\ud83d\\ude00" as two lone surrogates; make them one character."""
    if not any("\ud800" <= char <= "\udfff" for char in text):
        return text
    try:
        return text.encode("utf-16", "surrogatepass").decode("utf-16")
    except UnicodeDecodeError:
        return text  # an unpaired surrogate: rejected where it matters (output)


def key_text(key):
    return key if type(key) is str else str(key)


def parse_scalar(text):
    """A --set VALUE read as a YAML scalar: 5 -> int, 1e-9 -> float, effective -> str."""
    if not text.strip():
        raise ValueError("missing VALUE after '='")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            value = plain_data(_round_trip_yaml().load(text))
    except Exception as error:  # noqa: BLE001 -- any ruamel failure means "not a YAML scalar"
        problem = getattr(error, "problem", None) or str(error).splitlines()[0]
        raise ValueError(f"VALUE is not a YAML scalar ({problem})") from None
    if isinstance(value, (dict, list)) or value is None:
        raise ValueError(f"VALUE must be a single number or word, got {show(value)}")
    return value


def line_and_column(text, index):
    """1-based (line, column) of character ``index``."""
    before = text[:index]
    return before.count("\n") + 1, index - (before.rfind("\n") + 1) + 1


def error_line(error, text) -> int:
    mark = getattr(error, "problem_mark", None) or getattr(error, "context_mark", None)
    if mark is not None:
        return mark.line + 1
    if isinstance(error, ReaderError):
        return line_and_column(text, error.position)[0]
    return 1


class Unrepresentable(Exception):
    """A value of a dict config that YAML cannot hold; ``path`` says where (keys and indices)."""

    def __init__(self, path, value):
        self.path, self.value = tuple(path), value
        super().__init__(f"must be a number, a string, true/false, a list or a mapping, got a "
                         f"{type(value).__qualname__} ({show(value)})")


# A config is at most a few levels deep (model.parameters.NAME.range...); a dict nested deeper
# than this holds no config, and writing it out would recurse until Python's stack is spent.
MAX_NESTING = 64


class NestedTooDeeply(Unrepresentable):
    """A dict config nested deeper than MAX_NESTING, or that contains itself."""

    def __init__(self, path, cycle=False):
        self.path, self.value = tuple(path), None
        Exception.__init__(self, "contains itself (a dict or list that holds itself)" if cycle else
                           f"nested more than {MAX_NESTING} levels deep; a config is a few levels deep")


def yaml_text(data) -> str:
    """A dict nested as a config's YAML, written as YAML text that reads back to the same values.

    Accepts what Python code naturally holds: numpy numbers and arrays (as numbers and lists),
    tuples (as lists), paths (as strings). Floats are written by ruamel as ``repr`` does, so they
    read back bit for bit; key order is kept (it is the order of a sweep's axes). Raises
    :class:`Unrepresentable` for anything else (a set, an object).
    """
    import io

    stream = io.StringIO()
    YAML(typ="rt").dump(_yaml_ready(data, (), set()), stream)
    return stream.getvalue()


def _yaml_ready(value, path, active):
    import os

    import numpy as np

    if isinstance(value, (dict, list, tuple)):
        if len(path) >= MAX_NESTING or id(value) in active:
            raise NestedTooDeeply(path[:4], cycle=id(value) in active)
        active.add(id(value))
        try:
            if isinstance(value, dict):
                return {key_text(key): _yaml_ready(item, path + (key_text(key),), active) for key, item in value.items()}
            return [_yaml_ready(item, path + (index,), active) for index, item in enumerate(value)]
        finally:
            active.discard(id(value))
    if isinstance(value, np.ndarray):
        if value.ndim > MAX_NESTING:
            raise NestedTooDeeply(path)
        value = value.tolist()
        return _yaml_ready(value, path, active) if isinstance(value, list) else value
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, os.PathLike):
        value = os.fspath(value)
    if value is None or isinstance(value, (bool, int, float, str)):
        return value
    raise Unrepresentable(path, value)
