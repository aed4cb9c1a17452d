"""The canonical text of a resolved config (:func:`dump_config`), stored in every results file.

Apart from the schema on purpose: ``Config.to_yaml`` calls this module, so it must not import
``schema`` back (tests/test_layout.py refuses import cycles); what it needs of the defaults comes
from the kernel, as the schema's own defaults do.
"""

from __future__ import annotations

import dataclasses
import io

import numpy as np
from ruamel.yaml import YAML
from ruamel.yaml.comments import CommentedMap, CommentedSeq
from ruamel.yaml.scalarstring import DoubleQuotedScalarString

from vrsweep.numerics.settings import DEFAULT_METHOD
from vrsweep.numerics.model import INITIAL_STATE_KEYS, PARAMETER_NAMES


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
    names = getattr(config.model, "parameter_names", PARAMETER_NAMES)
    document["model"] = config.model if isinstance(config.model, str) else _model_node(config.model)
    document["parameters"] = _block({name: float(config.parameters[name]) for name in names},
                                    {name: f"sweep.{name}" for name in names if name in swept})
    document["initial"] = _block({key: float(config.initial[key]) for key in INITIAL_STATE_KEYS.values()},
                                 {key: f"sweep.{axis}" for axis, key in INITIAL_STATE_KEYS.items() if axis in swept})
    document["sweep"] = CommentedMap((axis.name, _axis_node(axis)) for axis in config.axes)
    if not config.axes:
        document["sweep"].fa.set_flow_style()  # "sweep: {}"
    integration = dataclasses.asdict(config.integration)
    if integration["method"] == DEFAULT_METHOD:
        # The default is left out, as in files written before the key existed: the same run
        # keeps the same text.
        del integration["method"]
    if not integration["lyapunov"]:  # the same: named only when on
        del integration["lyapunov"]
    if integration["device"] == "cpu":  # the same: named only when not the default
        del integration["device"]
    document["integration"] = _block(integration, {})
    document["output"] = None if config.output is None else DoubleQuotedScalarString(config.output)
    if config.continuation is not None:  # only when present: configs without it keep their text
        section = dataclasses.asdict(config.continuation)
        block = CommentedMap(parameter=section.pop("parameter"))
        block["from"] = float(section.pop("start"))
        block["to"] = CommentedSeq([float(section.pop("low")), float(section.pop("high"))])
        block["to"].fa.set_flow_style()
        if not section["switch"]:  # named only when on, as integration.lyapunov
            del section["switch"]
        for key, value in section.items():
            block[key] = value
        document["continuation"] = block
    stream = io.StringIO()
    _dumper().dump(document, stream)
    return stream.getvalue()


def _model_node(model):
    """A written model (numerics.written.WrittenModel.as_data), expressions as quoted strings and
    short mappings in flow style."""
    node = CommentedMap()
    for key, value in model.as_data().items():
        if key in ("parameters", "symbols"):
            value = CommentedMap((name, DoubleQuotedScalarString(item) if isinstance(item, str) else float(item))
                                 for name, item in value.items())
            value.fa.set_flow_style()
        elif key == "ranges":
            ranges = CommentedMap()
            for name, bounds in value.items():
                ranges[name] = CommentedSeq(bounds)
                ranges[name].fa.set_flow_style()
            ranges.fa.set_flow_style()
            value = ranges
        elif key == "barriers":
            items = CommentedSeq()
            for barrier in value:
                entry = CommentedMap((k, DoubleQuotedScalarString(v)) for k, v in barrier.items())
                entry.fa.set_flow_style()
                items.append(entry)
            value = items
        elif key == "response":
            value = CommentedMap((k, DoubleQuotedScalarString(v)) for k, v in value.items())
            value.fa.set_flow_style()
        else:
            value = DoubleQuotedScalarString(value)
        node[key] = value
    return node


def _block(values, swept):
    """A block mapping of ``values``; a key in ``swept`` gets the comment ``# swept: see sweep.g``."""
    node = CommentedMap(values)
    for key, where in swept.items():
        # Two spaces after "  key: value", as PEP 8 has it (ruamel would align the comments).
        column = len(f"  {key}: {repr(values[key])}  ")
        node.yaml_add_eol_comment(f"swept: see {where}", key, column=column)
    return node


def _axis_node(axis):
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
