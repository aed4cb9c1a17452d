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
