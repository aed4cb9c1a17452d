"""YAML in and out, through ruamel.yaml: the round-trip reader (YAML 1.2, lines kept in ``.lc``
for messages), plain-Python copies of its tree, a ``--set`` value read as a scalar, and the
canonical text of a resolved config (:func:`dump_config`).
"""

from __future__ import annotations

import dataclasses
import datetime
import io
import warnings

import numpy as np
from ruamel.yaml import YAML
from ruamel.yaml.comments import CommentedMap, CommentedSeq, TaggedScalar
from ruamel.yaml.scalarstring import DoubleQuotedScalarString
from ruamel.yaml.reader import ReaderError

from vrsweep.config.schema import INTEGRATION_DEFAULTS, Axis
from vrsweep.config.wording import show
from vrsweep.numerics.model import INITIAL_STATE_KEYS, PARAMETER_NAMES


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


class CyclicAlias(Exception):
    pass


def plain_data(node, _active=None):
    """ruamel's tree as plain dict/list/float/int/str/bool (keys as str), keeping order."""
    active = set() if _active is None else _active
    if isinstance(node, (dict, list)):
        if id(node) in active:
            raise CyclicAlias
        active.add(id(node))
        try:
            if isinstance(node, dict):
                return {key_text(key): plain_data(value, active) for key, value in node.items()}
            return [plain_data(item, active) for item in node]
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
            value = plain_data(YAML(typ="rt").load(text))
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


def dump_config(config) -> str:
    """Canonical YAML of ``config``, fully resolved (defaults filled, overrides applied).

    Canonical: fixed key order, floats as ``repr`` (exact round trip), a linear axis written as
    ``{start, stop, num}`` whenever its values are exactly ``np.linspace`` of those (however
    the user wrote it), so two equal configs give the same text. Stored in results files.

    Written by ruamel.yaml from a tree built here; the text is the one the hand-written emitter
    of earlier versions wrote (same layout, comments and number spellings), so that shard files
    written by two versions still show the same text. Resuming does not depend on it: --resume
    compares configs parsed (vrsweep.config.same_config).
    """
    swept = set(config.axis_names)
    document = CommentedMap()
    document.yaml_set_start_comment("vrsweep config, fully resolved: every default filled in, every --set applied.")
    document["model"] = config.model
    document["parameters"] = _block({name: float(config.parameters[name]) for name in PARAMETER_NAMES},
                                    {name: f"sweep.{name}" for name in PARAMETER_NAMES if name in swept})
    document["initial"] = _block({key: float(config.initial[key]) for key in INITIAL_STATE_KEYS.values()},
                                 {key: f"sweep.{axis}" for axis, key in INITIAL_STATE_KEYS.items() if axis in swept})
    document["sweep"] = CommentedMap((axis.name, _axis_node(axis)) for axis in config.axes)
    if not config.axes:
        document["sweep"].fa.set_flow_style()  # "sweep: {}"
    integration = dataclasses.asdict(config.integration)
    if integration["method"] == INTEGRATION_DEFAULTS["method"]:
        # The default is left out, as in files written before the key existed: the same run
        # keeps the same text.
        del integration["method"]
    if not integration["lyapunov"]:  # the same: named only when on
        del integration["lyapunov"]
    document["integration"] = _block(integration, {})
    document["output"] = None if config.output is None else DoubleQuotedScalarString(config.output)
    stream = io.StringIO()
    _dumper().dump(document, stream)
    return stream.getvalue()


def _block(values, swept):
    """A block mapping of ``values``; a key in ``swept`` gets the comment ``# swept: see sweep.g``."""
    node = CommentedMap(values)
    for key, where in swept.items():
        # Two spaces after "  key: value", as PEP 8 has it (ruamel would align the comments).
        column = len(f"  {key}: {repr(values[key])}  ")
        node.yaml_add_eol_comment(f"swept: see {where}", key, column=column)
    return node


def _axis_node(axis: Axis):
    """``{start, stop, num}`` for exactly np.linspace values, else the list (``{values: [...]}``
    with a continuation), in flow style: one line per axis."""
    values = axis.values
    n = len(values)
    if n >= 3 and values[-1] > values[0] and np.array_equal(values, np.linspace(values[0], values[-1], n)):
        node = CommentedMap([("start", float(values[0])), ("stop", float(values[-1])), ("num", n)])
    else:
        items = CommentedSeq(float(value) for value in values)
        items.fa.set_flow_style()
        if not axis.continuation:
            return items
        node = CommentedMap([("values", items)])
    if axis.continuation:
        node["continuation"] = axis.continuation
    node.fa.set_flow_style()
    return node


def _represent_null(representer, _):
    return representer.represent_scalar("tag:yaml.org,2002:null", "null")  # not ruamel's empty value


def _represent_float(representer, value):
    # repr round-trips exactly, and YAML 1.2 reads 1e-09 as a float (ruamel would write 1.0e-09)
    return representer.represent_scalar("tag:yaml.org,2002:float", repr(float(value)))


def _dumper() -> YAML:
    yaml = YAML(typ="rt")
    yaml.width = 1 << 30  # one axis on one line, however many values it lists
    yaml.representer.add_representer(type(None), _represent_null)
    yaml.representer.add_representer(float, _represent_float)
    return yaml
