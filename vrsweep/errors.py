"""The project's own exceptions. The CLI turns each into one clear message and an exit code."""


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
        error = cls(template.format_map(_Wording(argument_words or {}, values)))
        error.template, error.argument_words, error.values = template, dict(argument_words or {}), values
        return error

    def reworded(self, flags: dict):
        """This error with its arguments worded by ``flags`` ({argument: "--flag"}), for a command
        that took them from the command line; the error itself if it names no argument."""
        if self.template is None:
            return self
        return type(self).naming(self.template, {**self.argument_words, **flags}, **self.values)


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
        super().__init__(f"{argument} {value}: {problem}")

    def as_option(self, option) -> UsageError:
        """The same problem, worded for the command-line ``option`` the value came from."""
        return UsageError(f"{option} {self.value}: {self.problem}")


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
