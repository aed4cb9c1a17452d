"""YAML in and out, through ruamel.yaml: the round-trip reader (YAML 1.2, lines kept in ``.lc``
for messages), plain-Python copies of its tree, a ``--set`` value read as a scalar, and the
canonical text of a resolved config (:func:`dump_config`).
"""

from __future__ import annotations

import dataclasses
import datetime
import warnings

import numpy as np
from ruamel.yaml import YAML
from ruamel.yaml.comments import TaggedScalar
from ruamel.yaml.reader import ReaderError

from vrsweep.config.schema import INTEGRATION_DEFAULTS, Axis
from vrsweep.config.wording import _show
from vrsweep.model import INITIAL_STATE_KEYS, PARAMETER_NAMES


def load_round_trip(text, allow_duplicate_keys=False):
    """ruamel's round-trip tree of ``text`` (CommentedMap ...), or None for an empty document."""
    yaml = YAML(typ="rt")
    yaml.allow_duplicate_keys = allow_duplicate_keys
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # e.g. ReusedAnchorWarning: not the user's concern here
        return yaml.load(text)


def compose(text):
    """The YAML node graph of ``text`` (before keys are merged), for reporting duplicate keys."""
    return YAML(typ="rt").compose(text)


class _CyclicAlias(Exception):
    pass


def _plain(node, _active=None):
    """ruamel's tree as plain dict/list/float/int/str/bool (keys as str), keeping order."""
    active = set() if _active is None else _active
    if isinstance(node, (dict, list)):
        if id(node) in active:
            raise _CyclicAlias
        active.add(id(node))
        try:
            if isinstance(node, dict):
                return {_key(key): _plain(value, active) for key, value in node.items()}
            return [_plain(item, active) for item in node]
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


def _key(key):
    return key if type(key) is str else str(key)


def _parse_scalar(text):
    """A --set VALUE read as a YAML scalar: 5 -> int, 1e-9 -> float, effective -> str."""
    if not text.strip():
        raise ValueError("missing VALUE after '='")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            value = _plain(YAML(typ="rt").load(text))
    except Exception as error:  # noqa: BLE001 -- any ruamel failure means "not a YAML scalar"
        problem = getattr(error, "problem", None) or str(error).splitlines()[0]
        raise ValueError(f"VALUE is not a YAML scalar ({problem})") from None
    if isinstance(value, (dict, list)) or value is None:
        raise ValueError(f"VALUE must be a single number or word, got {_show(value)}")
    return value


def _position(text, index):
    """1-based (line, column) of character ``index``."""
    before = text[:index]
    return before.count("\n") + 1, index - (before.rfind("\n") + 1) + 1


def _error_line(error, text) -> int:
    mark = getattr(error, "problem_mark", None) or getattr(error, "context_mark", None)
    if mark is not None:
        return mark.line + 1
    if isinstance(error, ReaderError):
        return _position(text, error.position)[0]
    return 1


def dump_config(self) -> str:
    """Canonical YAML of this config, fully resolved (defaults filled, overrides applied).

    Canonical: fixed key order, floats as ``repr`` (exact round trip), a linear axis written as
    ``{start, stop, num}`` whenever its values are exactly ``np.linspace`` of those (however
    the user wrote it), so two equal configs give the same text. Stored in results files.
    """
    swept = set(self.axis_names)
    lines = ["# vrsweep config, fully resolved: every default filled in, every --set applied.",
             f"model: {self.model}", "parameters:"]
    for name in PARAMETER_NAMES:
        note = f"  # swept: see sweep.{name}" if name in swept else ""
        lines.append(f"  {name}: {_yaml_float(self.parameters[name])}{note}")
    lines.append("initial:")
    for axis, key in INITIAL_STATE_KEYS.items():
        note = f"  # swept: see sweep.{axis}" if axis in swept else ""
        lines.append(f"  {key}: {_yaml_float(self.initial[key])}{note}")
    lines.append("sweep:" if self.axes else "sweep: {}")
    lines += [f"  {axis.name}: {_yaml_axis(axis)}" for axis in self.axes]
    lines.append("integration:")
    for key, value in dataclasses.asdict(self.integration).items():
        if key == "method":
            # Written only when not the default: files written before the key existed store
            # the same text for the same run, so they still resume (the check compares text).
            if value != INTEGRATION_DEFAULTS["method"]:
                lines.append(f"  method: {value}")
            continue
        lines.append(f"  {key}: {value if isinstance(value, int) else _yaml_float(value)}")
    lines.append(f"output: {'null' if self.output is None else _yaml_string(self.output)}")
    return "\n".join(lines) + "\n"


def _yaml_float(value) -> str:
    return repr(float(value))  # repr round-trips exactly and YAML 1.2 reads 1e-09 as a float


def _yaml_string(value: str) -> str:
    """A YAML double-quoted scalar, escaping anything not printable."""
    out = []
    for char in value:
        if char in '"\\':
            out.append("\\" + char)
        elif char.isprintable():
            out.append(char)
        elif ord(char) <= 0xFF:
            out.append(f"\\x{ord(char):02x}")
        elif ord(char) <= 0xFFFF:
            out.append(f"\\u{ord(char):04x}")
        else:
            out.append(f"\\U{ord(char):08x}")
    return '"' + "".join(out) + '"'


def _yaml_axis(axis: Axis) -> str:
    values = axis.values
    n = len(values)
    if n >= 3 and values[-1] > values[0] and np.array_equal(values, np.linspace(values[0], values[-1], n)):
        text = f"start: {_yaml_float(values[0])}, stop: {_yaml_float(values[-1])}, num: {n}"
    else:
        text = "values: [" + ", ".join(_yaml_float(value) for value in values) + "]"
    if axis.continuation:
        text += f", continuation: {axis.continuation}"
    elif text.startswith("values"):
        return text[len("values: "):]
    return "{" + text + "}"
