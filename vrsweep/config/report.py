"""How a problem in a config is worded and located: ``FILE:LINE: field.path: message (allowed: ...)``,
or ``--set NAME=VALUE: field.path: ...`` for a problem a command-line override caused.

:class:`Report` collects problems during one validation run (vrsweep.config.validate), finds
each field's line in ruamel's tree, and turns pydantic's errors and ruamel's syntax errors into
this project's words.
"""

from __future__ import annotations

import math

from ruamel.yaml.comments import CommentedMap, CommentedSeq
from ruamel.yaml.error import MarkedYAMLError
from ruamel.yaml.nodes import MappingNode, SequenceNode
from ruamel.yaml.reader import ReaderError

from vrsweep.numerics.model import PARAMETER_NAMES
from vrsweep.config.schema import (
    ALLOWED_KEYS, ANY, AXIS_FORMS, KEY_HOME, LINEAR_KEYS, NUM_DOMAIN, VALUES_KEYS, CONTINUATIONS,
    INITIAL_DOMAINS, INTEGRATION_DOMAINS, METHODS, DEVICES, PARAMETER_DOMAINS,
)
from vrsweep.config.wording import and_list, did_you_mean, dotted, show
from vrsweep.config.yaml import OutOfDouble, key_text, line_and_column, compose
from vrsweep.errors import ConfigError, clip
from vrsweep.numbertext import LARGEST_DOUBLE, beyond_double
from vrsweep.numerics.model import MODELS


class Report:
    """The problems found in one config text (and its overrides), each with its file and line."""

    def __init__(self, text, source_name, overrides, line_numbers=True, override_words=None):
        self.text = text if isinstance(text, str) else str(text)
        self.source = source_name
        self.line_numbers = line_numbers  # False: the text was made from a dict, its lines mean nothing
        self.overrides = overrides
        self.override_words = dict(override_words or {})  # how each override was given, if not --set
        self.root = None          # the ruamel tree (CommentedMap ...), for line numbers
        self.overridden = {}      # path tuple -> the "--set NAME=VALUE" that set it
        self.problems = []        # (order key, text)

    def report(self, path, message, allowed=None):
        """Record one problem at ``path`` (a tuple of keys and list indices)."""
        path = tuple(path)
        text = f"{dotted(path)}: {message}" if path else message
        if allowed:
            text += f" (allowed: {allowed})"
        for length in range(len(path), 0, -1):
            setting = self.overridden.get(path[:length])
            if setting is not None:
                self.problems.append((self.setting_order(setting), f"{self.said(setting)}: {text}"))
                return
        line = self.line_of(path)
        where = f"{self.source}:{line}" if self.line_numbers else self.source
        self.problems.append(((0, line, ""), f"{where}: {text}"))

    def said(self, setting):
        """An override as its user gave it: ``--set g=abc``, or ``keyword argument g='abc'`` in Python,
        whose user never typed --set (execution/api.resolve_config)."""
        return self.override_words.get(setting, f"--set {clip(setting)}")

    def setting_order(self, setting):
        """Problems with --set options come after the file's, in the order the options were given."""
        return (1, self.overrides.index(setting) if setting in self.overrides else 0, "")

    def report_raw(self, order, text):
        self.problems.append((order, text))

    def line_of(self, path) -> int:
        """1-based line of the deepest node of ``path`` present in the YAML (1 if none is)."""
        node, line = self.root, 1
        for key in path:
            try:
                if isinstance(node, CommentedMap):
                    real_key = next(k for k in node if key_text(k) == key)
                    line = node.lc.key(real_key)[0] + 1
                    node = node[real_key]
                elif isinstance(node, CommentedSeq) and isinstance(key, int) and 0 <= key < len(node):
                    line = node.lc.item(key)[0] + 1
                    node = node[key]
                else:
                    break
            except (StopIteration, KeyError, TypeError, AttributeError, IndexError):
                break  # e.g. a key brought in by a YAML merge (<<) has no line of its own here
        return line

    def fail_if_problems(self):
        if self.problems:
            ordered = [text for _, text in sorted(self.problems, key=lambda item: item[0])]
            raise ConfigError(ordered, source=self.source)

    def report_duplicates(self):
        """Report every key given twice in one mapping, with both lines."""
        node = compose(self.text)
        seen_nodes = set()

        def walk(node, path):
            if id(node) in seen_nodes:
                return
            seen_nodes.add(id(node))
            if isinstance(node, MappingNode):
                lines = {}  # key -> lines it appears on, in order
                for key_node, value_node in node.value:
                    key = getattr(key_node, "value", None)
                    if isinstance(key, str) and key != "<<":
                        lines.setdefault(key, []).append(key_node.start_mark.line + 1)
                        walk(value_node, path + (key,))
                for key, where in lines.items():
                    if len(where) > 1:
                        times = "twice" if len(where) == 2 else f"{len(where)} times"
                        if path == ("sweep",):
                            what, hint = "parameter", "; sweep each parameter on one axis only"
                        else:
                            what, hint = "key", ""
                        self.report_raw((0, where[1], ""), f"{self.source}:{where[1]}: {dotted(path + (key,))}: "
                                                           f"{what} given {times} (lines {and_list(where)}){hint}")
            elif isinstance(node, SequenceNode):
                for index, item in enumerate(node.value):
                    walk(item, path + (index,))

        walk(node, ())

    def yaml_error_text(self, error) -> str:
        """``FILE:LINE:COLUMN: YAML syntax error: <the parser's problem>``."""
        if isinstance(error, ReaderError):
            line, column = line_and_column(self.text, error.position)
            character = error.character
            if isinstance(character, int):
                character = f"#x{character:04x}"
            return (f"{self.source}:{line}:{column}: YAML syntax error: "
                    f"unacceptable character {character}: {error.reason}")
        if isinstance(error, MarkedYAMLError):
            mark = error.problem_mark or error.context_mark
            problem = error.problem or error.context or "invalid YAML"
            where = f"{self.source}:{mark.line + 1}:{mark.column + 1}" if mark else self.source
            text = f"{where}: YAML syntax error: {problem}"
            if error.context and error.problem and error.context_mark:
                text += f" ({error.context} started on line {error.context_mark.line + 1})"
            return text
        return f"{self.source}: YAML syntax error: {error}"

    # -- pydantic's errors in this project's words ---------------------------------------

    def report_pydantic(self, item, prefix):
        """Turn one pydantic error into a problem in this project's words."""
        path = prefix + tuple(item["loc"])
        kind, value = item["type"], item.get("input")
        too_large = isinstance(value, int) and not isinstance(value, bool) and kind == "float_type" \
            and abs(value) > LARGEST_DOUBLE  # an integer literal of 400 digits, for a number
        if isinstance(value, OutOfDouble) or too_large:
            problem = value.problem if isinstance(value, OutOfDouble) else beyond_double(str(value), math.inf)
            written = value.text if isinstance(value, OutOfDouble) else value
            self.report(path, f"{clip(written)} {problem}", allowed=self.describe(path))
        elif kind == "extra_forbidden":
            key = path[-1]
            parent = path[:-1]
            allowed = self.allowed_keys(parent)
            self.report(path, f"unknown key{self.key_hint(key, parent, allowed)}", allowed=", ".join(allowed))
        elif kind == "missing":
            self.report(path, "missing", allowed=AXIS_FORMS if path[:1] == ("sweep",) else None)
        elif kind in ("out_of_range", "bad_path"):
            self.report(path, item["msg"])
        elif kind == "literal_error":
            choices = {("model",): MODELS, ("method",): METHODS, ("device",): DEVICES}.get(path[-1:], CONTINUATIONS)
            if tuple(path[:2]) == ("continuation", "parameter"):
                choices = getattr(self, "parameter_names", PARAMETER_NAMES)
            hint = did_you_mean(value, choices) if isinstance(value, str) else ""
            self.report(path, f"must be one of {', '.join(choices)}, got {show(value)}{hint}")
        elif kind in ("model_type", "dict_type"):
            self.report(path, f"must be a mapping, got {show(value)}",
                        allowed=", ".join(self.allowed_keys(path)) or None)
        elif kind == "list_type":
            self.report(path, f"must be a list of numbers, got {show(value)}")
        elif kind == "too_short":
            self.report(path, "must not be empty", allowed="a list of one or more numbers")
        elif kind == "finite_number":
            self.report(path, f"must be a finite number, got {show(value)}", allowed=self.describe(path))
        elif kind in ("float_type", "float_parsing"):
            self.report(path, f"must be a number, got {show(value)}", allowed=self.describe(path))
        elif kind in ("int_type", "int_parsing", "int_from_float"):
            self.report(path, f"must be an integer, got {show(value)}", allowed=self.describe(path))
        elif kind in ("bool_type", "bool_parsing"):  # strict: "yes", 1 or "on" is not taken for true
            self.report(path, f"must be true or false, got {show(value)}")
        elif kind == "string_type":
            self.report(path, f"must be a string, got {show(value)}", allowed="a file path")
        else:  # something pydantic says that is not rephrased here
            self.report(path, item["msg"])

    def allowed_keys(self, parent):
        if parent == ("parameters",):
            return getattr(self, "parameter_names", PARAMETER_NAMES)
        if parent in ALLOWED_KEYS:
            return ALLOWED_KEYS[parent]
        if len(parent) == 2 and parent[0] == "sweep":
            return LINEAR_KEYS[:3] + VALUES_KEYS
        return ()

    def key_hint(self, key, parent, allowed):
        """`` (did you mean 'e'?)``, or where the key belongs if it is in the wrong section."""
        if len(parent) == 2 and parent[0] == "sweep":
            if key in LINEAR_KEYS or key in VALUES_KEYS:
                return "; use either {start, stop, num} or {values: [...]}, not both"
        home = KEY_HOME.get(str(key))
        if home is not None and home != dotted(parent + (key,)):
            return f" (did you mean {home}?)"
        return did_you_mean(str(key), allowed)

    def describe(self, path) -> str | None:
        """What is allowed at ``path``, in words, for type errors."""
        if len(path) == 2:
            section, key = path
            table = {"parameters": getattr(self, "parameter_domains", PARAMETER_DOMAINS), "initial": INITIAL_DOMAINS,
                     "integration": INTEGRATION_DOMAINS}.get(section, {})
            if key in table and table[key] != ANY:
                return table[key].describe()
        if path[:1] == ("sweep",):
            if path[-1:] == ("num",):
                return NUM_DOMAIN.describe()
        return None


def without_missing_typos(errors):
    """Drop "missing start" when "strat: unknown key (did you mean 'start'?)" already says it."""
    suggested = set()
    for item in errors:
        if item["type"] == "extra_forbidden":
            parent, key = tuple(item["loc"][:-1]), str(item["loc"][-1])
            for choice in LINEAR_KEYS + VALUES_KEYS:
                if did_you_mean(key, [choice]):
                    suggested.add(parent + (choice,))
    return [item for item in errors if not (item["type"] == "missing" and tuple(item["loc"]) in suggested)]
