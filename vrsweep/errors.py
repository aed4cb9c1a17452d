"""The project's own exceptions. The CLI turns each into one clear message and an exit code."""

import unicodedata

# What one line of a message may not hold raw: controls (a newline or a carriage return in a file
# name or a YAML key began a second line, an escape sequence restyled the terminal), Unicode's
# line and paragraph separators, the halves of a byte that is not UTF-8 (surrogateescape), and the
# marks that reverse the direction of the text after them (a name shown backwards).
_ESCAPED_CATEGORIES = {"Cc", "Zl", "Zp", "Cs"}
_BIDI_CONTROLS = set("\u061c\u200e\u200f") | {chr(c) for c in range(0x202A, 0x202F)} | \
    {chr(c) for c in range(0x2066, 0x206A)}
_SHORT_ESCAPES = {"\n": "\\n", "\r": "\\r", "\t": "\\t"}


# How much of a value a message quotes: a 400-digit --set value, a long key or expression was
# quoted whole, a paragraph of digits around the one thing the message says.
SHOWN_CHARACTERS = 40


def clip(text, limit=SHOWN_CHARACTERS) -> str:
    """``text`` as a message quotes it: whole up to ``limit`` characters, else its start and '...'."""
    text = str(text)
    return text if len(text) <= limit else text[:limit - 3] + "..."


def one_line(text) -> str:
    """``text`` as one line of a terminal: every character that would break the line or change
    how the rest reads written as its escape, as Python writes it (a newline as \\n, a byte that
    is not UTF-8 as \\xNN, as a file's ``history`` writes it); the rest as it is (ω, Δ, é).

    Messages quote what the user typed or named (paths, YAML keys, settings): a file named
    "a<newline>b.h5" made an error two lines, the second looking like vrsweep's own."""
    text = str(text)
    out = []
    for char in text:
        if char in _SHORT_ESCAPES:
            out.append(_SHORT_ESCAPES[char])
        elif "\udc80" <= char <= "\udcff":  # a byte that is not UTF-8, as os.fsdecode holds it
            out.append(f"\\x{ord(char) - 0xdc00:02x}")
        elif char in _BIDI_CONTROLS or unicodedata.category(char) in _ESCAPED_CATEGORIES:
            code = ord(char)
            out.append(f"\\x{code:02x}" if code < 0x100 else f"\\u{code:04x}")
        else:
            out.append(char)
    return "".join(out)


class VrsweepError(Exception):
    """Base class. ``exit_code`` is what the CLI exits with.

    The library words its messages without command-line flags: an error about a function's
    arguments is made with :meth:`naming`, its message a template where ``{argument}`` names an
    argument; a command re-words it for its own flags with :meth:`reworded` (``{x_axis}`` is
    ``x_axis`` in Python, ``--x`` at the command line).
    """

    exit_code = 1
    template = None  # set by naming(): the message with its arguments as {placeholders}

    @classmethod
    def naming(cls, template: str, /, argument_words=None, **values):
        """The error ``template.format(**values)``, where a ``{placeholder}`` that is not in
        ``values`` is an argument, worded as ``argument_words`` says (default: its own name).

        Values (paths, numbers) go in ``values``, never into the template, so that their braces
        are never read as placeholders.
        """
        # A whole number of 400 digits (samples_per_period=10**400) is quoted short, as clip quotes
        # a value; a path or another text is quoted whole: it names what to look at
        shown = {name: _Clipped(clip(value)) if isinstance(value, int) and not isinstance(value, bool)
                 and len(str(value)) > SHOWN_CHARACTERS else value for name, value in values.items()}
        error = cls(template.format_map(_Wording(argument_words or {}, shown)))
        error.template, error.argument_words, error.values = template, dict(argument_words or {}), values
        return error

    def reworded(self, flags: dict):
        """This error with its arguments worded by ``flags`` ({argument: "--flag"}), for a command
        that took them from the command line; the error itself if it names no argument."""
        if self.template is None:
            return self
        return type(self).naming(self.template, {**self.argument_words, **flags}, **self.values)


class _Clipped(str):
    """A value cut short for a message, shown as it is whatever format the template asks ({n:g})."""

    def __format__(self, spec):
        return str(self)


class _Wording(dict):
    def __init__(self, words, values):
        super().__init__(values)
        self.words = words

    def __missing__(self, key):
        return self.words.get(key, key)


class ConfigError(VrsweepError):
    """A config (or a --set override) is invalid. ``problems`` lists every problem found.

    Each problem is a string already naming file, line and field path, e.g.
    ``sweep.yaml:7: parameters.e: must be in (0, 1], got 1.5``.
    """

    exit_code = 2

    def __init__(self, problems, source=None):
        if isinstance(problems, str):
            problems = [problems]
        self.problems = list(problems)
        self.source = source
        super().__init__("\n".join(self.problems))


class UsageError(VrsweepError):
    """Bad usage that click itself cannot see: of a command (the output exists and overwriting was
    not asked for) or of a library function (an axis the file does not have)."""

    exit_code = 2


class ResultFileError(VrsweepError):
    """A results file is missing, not a vrsweep file, truncated, unfinished, or too new."""

    exit_code = 2


class OutputError(VrsweepError):
    """Writing an output failed at run time: the disk or a quota is full, the file or its folder
    was removed or replaced by another process, an I/O error. Exit 1, unlike bad input (exit 2)."""

    exit_code = 1


class InvalidArgument(UsageError):
    """A library function was given a value it cannot use (a shard ``x``, a Dask address
    ``local:0``). Worded without command-line flags: ``argument`` names what was given, ``value``
    is the value, ``problem`` says what is wrong. A command that took the value from an option
    rewords it with :meth:`as_option` (``--shard x: expected I/N ...``). Exit 2, as bad input."""

    def __init__(self, argument, value, problem):
        self.argument, self.value, self.problem = argument, value, problem
        super().__init__(f"{argument} {clip(value)}: {problem}")

    def as_option(self, option) -> UsageError:
        """The same problem, worded for the command-line ``option`` the value came from."""
        return UsageError(f"{option} {clip(self.value)}: {self.problem}")


class FlagTypeError(UsageError, TypeError):
    """A library function's boolean flag given something other than True or False
    (``overwrite="no"``): a TypeError, as Python's own argument checks raise, and a UsageError, as
    every other bad argument of vrsweep's (exit 2). A truthy string would otherwise act as True."""

    def __init__(self, argument, value):
        self.argument, self.value = argument, value
        super().__init__(f"{argument} must be True or False, got {value!r}")


class PathTypeError(UsageError, TypeError):
    """A library function's path argument given something other than a str or os.PathLike path
    (``output=123``, ``output=b"o.h5"``): a TypeError, as Python's own argument checks raise, and a
    UsageError (exit 2), raised before anything is computed."""

    def __init__(self, argument, value):
        self.argument, self.value = argument, value
        hint = " (decode it: os.fsdecode)" if isinstance(value, bytes) else ""
        super().__init__(f"{argument} must be a path (a str or an os.PathLike such as pathlib.Path), "
                         f"got {type(value).__name__} {value!r}"[:300] + hint)


class RunFailed(VrsweepError):
    """A run stopped by a failure after the chunks finished so far were saved: resuming the run
    computes the rest. Exit 1, like any failure at run time."""
