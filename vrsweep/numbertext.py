"""Numbers given as text, read by one rule wherever they come from: a command-line option
(``--threads``, ``--dpi``, ``--at g=5``, ``--xlim``, ``--shard``), a config's YAML scalar (``--set``
values included) and a written model's literals.

Python's ``int()`` and ``float()`` read any Unicode decimal digit ("١٢" and the fullwidth "１２"
are 12 to them), underscores ("1_0" is 10) and words ("nan", "infinity"), and ``float()`` rounds
a literal beyond the doubles to inf (1e400) or to 0 (1e-400) without a word: a tolerance of
1e-400 was refused as "got 0.0", and a damping of 1e-400 ran as 0. Here a number is ASCII digits
in decimal notation, and one a double cannot hold is refused, saying why.
"""

from __future__ import annotations

import math
import numbers
import re
import sys

LARGEST_DOUBLE = sys.float_info.max      # 1.8e308
SMALLEST_DOUBLE = math.ulp(0.0)          # 4.9e-324, the smallest subnormal

_INTEGER = re.compile(r"[+-]?[0-9]+")
_DECIMAL = re.compile(r"[+-]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")
_BLANKS = " \t"  # what may surround a number typed in an option; Unicode spaces are not blanks here


class NumberTextError(ValueError):
    """Text that is not a number by this module's rule; the message says why, for one line after
    the value (``--threads ١٢: ...``). ``foreign``: the digits other than 0-9 it holds, if any."""

    foreign = ""


def beyond_double(text: str, value: float) -> str | None:
    """Why the decimal ``text``, which reads as ``value``, is not the number written, or None:
    beyond the largest double (read as inf) or, nonzero, below the smallest (read as 0)."""
    mantissa = re.split(r"[eE]", text, maxsplit=1)[0]
    if math.isinf(value) and any(char.isdigit() for char in mantissa):
        return f"is beyond the largest double ({LARGEST_DOUBLE:.4g})"
    if value == 0.0 and any(char in "123456789" for char in mantissa):
        return f"is below the smallest double ({SMALLEST_DOUBLE:.2g}): it would be read as 0"
    return None


def yaml_number_problem(text: str) -> str | None:
    """Why a YAML number, as written (``text``), is not one by this module's rule, or None.

    YAML reads more than decimal notation as numbers: ``0x10`` (16), ``0o10`` (8), ``0b11`` (3),
    ``1_000`` and ``1__0`` (ruamel's underscores, anywhere), and under ``%YAML 1.1`` ``010`` (8) and
    ``1:30`` (90). A config is read by the rule an option is (``--threads 0x10`` is refused), so
    that one value means one thing wherever it is typed. ``.inf`` and ``.nan`` are left to the field,
    which refuses them as any non-finite number."""
    stripped = text.strip()
    if stripped.lower().lstrip("+-") in (".inf", ".nan"):
        return None
    if _DECIMAL.fullmatch(stripped):
        return None
    body = stripped.lstrip("+-").lower()
    for prefix, base in (("0x", "hexadecimal"), ("0o", "octal"), ("0b", "binary")):
        if body.startswith(prefix):
            return f"written in {base}: write it in decimal"
    if "_" in body:
        return f"written with underscores: write it without them ({stripped.replace('_', '')})"
    if ":" in body:
        return "written in base 60 (YAML 1.1's hours:minutes): write it in decimal"
    return "not a number in decimal notation"


def _not_a_number(text: str, what: str) -> NumberTextError:
    foreign = sorted({char for char in text if char.isdigit() and not char.isascii()})
    if foreign:
        error = NumberTextError(f"is not {what} in ASCII digits: it holds digits other than 0-9 "
                                f"({''.join(foreign)})")
        error.foreign = "".join(foreign)
        return error
    return NumberTextError(f"is not {what}")


def read_float(text) -> float:
    """The finite double that decimal ``text`` writes (``-1.5e-3``, ``.5``, ``7``); NumberTextError
    for anything else: other digits, words (nan, inf), a number a double cannot hold."""
    stripped = str(text).strip(_BLANKS)
    if not _DECIMAL.fullmatch(stripped):
        raise _not_a_number(stripped, "a finite number")
    value = float(stripped)
    problem = beyond_double(stripped, value)
    if problem:
        raise NumberTextError(problem)
    return value


def read_int(text) -> int:
    """The whole number that ``text`` writes in ASCII digits (``12``, ``-3``); NumberTextError for
    anything else (``1e3``, ``1.0``, ``١٢``, ``1_0``)."""
    stripped = str(text).strip(_BLANKS)
    if not _INTEGER.fullmatch(stripped):
        raise _not_a_number(stripped, "a whole number")
    return int(stripped)


def to_float(value) -> float:
    """A number given as text (read by :func:`read_float`) or as a Python or numpy number (a bool
    is none); NumberTextError for anything else. A non-finite number given as a number is returned
    as it is, for the caller's own check; as text it is refused."""
    if isinstance(value, str):
        return read_float(value)
    if isinstance(value, bool) or type(value).__name__ == "bool_" or not isinstance(value, numbers.Real):
        raise NumberTextError("is not a number")
    try:
        return float(value)
    except OverflowError:  # an int of 400 digits
        raise NumberTextError(f"is beyond the largest double ({LARGEST_DOUBLE:.4g})") from None


def to_int(value) -> int:
    """A whole number given as text (read by :func:`read_int`) or as a Python or numpy integer (a
    bool is none); NumberTextError for anything else."""
    if isinstance(value, str):
        return read_int(value)
    if isinstance(value, bool) or type(value).__name__ == "bool_" or not isinstance(value, numbers.Integral):
        raise NumberTextError("is not a whole number")
    return int(value)
