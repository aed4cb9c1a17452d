"""The project's own exceptions. The CLI turns each into one clear message and an exit code."""


class VrsweepError(Exception):
    """Base class. ``exit_code`` is what the CLI exits with."""

    exit_code = 1


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
    """Bad command-line usage that click itself cannot see (e.g. output exists without --overwrite)."""

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


class RunFailed(VrsweepError):
    """A run stopped by a failure after the chunks finished so far were saved: resuming the run
    computes the rest. Exit 1, like any failure at run time."""
