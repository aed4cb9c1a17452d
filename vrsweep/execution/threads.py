"""How many threads numba runs here: one answer for the whole program, without importing numba.

numba's ceiling is NUMBA_NUM_THREADS when that is a whole number ≥ 1, else the CPUs this process
may run on (its affinity mask: what SLURM's --cpus-per-task gives a bound task), not the machine's
CPU count. numba ignores an unreadable NUMBA_NUM_THREADS with a warning; so does this.
"""

import os
import re
import sys

from vrsweep.errors import clip, one_line
from vrsweep.numbertext import read_int


def available_threads() -> int:
    """numba's thread ceiling in this process (``--threads`` can lower it, never raise it)."""
    try:
        threads = read_int(os.environ.get("NUMBA_NUM_THREADS", "").strip() or 0)
    except ValueError:
        threads = 0
    if threads >= 1:
        return threads
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):  # no affinity masks (macOS)
        return os.cpu_count() or 1


def drop_unreadable_setting() -> None:
    """An unreadable NUMBA_NUM_THREADS ('abc', '0'): say so in one line and unset it, before numba
    is imported (numba would ignore it too, but with a warning that prints a traceback); one above
    the machine's CPU count: say so and lower it to that count."""
    value = os.environ.get("NUMBA_NUM_THREADS")
    if value is None or "numba" in sys.modules:
        return
    try:
        readable = read_int(value.strip()) >= 1  # "١٢" too is dropped: numba's int() read it as 12
    except ValueError:
        readable = False
    if not readable:
        del os.environ["NUMBA_NUM_THREADS"]
        sys.stderr.write(f"vrsweep: NUMBA_NUM_THREADS={clip(repr(value))} is not a whole number >= 1: ignored, "
                         f"using the {available_threads()} CPUs this process may run on\n")
        return
    # numba starts every thread at import: NUMBA_NUM_THREADS=100000 segfaults, larger values are
    # killed for memory. More threads than the machine has CPUs is never faster: capped there.
    most = machine_cpus()
    if read_int(value.strip()) > most:
        os.environ["NUMBA_NUM_THREADS"] = str(most)
        sys.stderr.write(f"vrsweep: NUMBA_NUM_THREADS={clip(value.strip())} is more than the {most} CPUs of this "
                         f"machine: using {most}\n")


# numba's words for an environment variable it cannot parse (numba/core/config.py, _readenv): a
# RuntimeWarning holding the parser's whole traceback, eight lines for NUMBA_DISABLE_JIT=yes.
_NUMBA_UNREADABLE = re.compile(r"Environment variable '(?P<name>[^']*)' is defined but its associated value "
                               r"'(?P<value>.*)' could not be parsed", re.DOTALL)


def word_numba_setting_warnings() -> None:
    """Have a NUMBA_* variable that numba cannot parse (NUMBA_DISABLE_JIT=yes, NUMBA_OPT=bogus) said
    in one line when numba reads it, as NUMBA_NUM_THREADS is (drop_unreadable_setting): numba
    ignores it, using its default, and printed a RuntimeWarning with a traceback. Every other
    warning is shown as before (the hook chains to the one it replaces)."""
    import warnings

    shown = warnings.showwarning
    if getattr(shown, "vrsweep_numba_words", False):
        return

    def show(message, category, filename, lineno, file=None, line=None):
        match = _NUMBA_UNREADABLE.match(str(message)) if issubclass(category, RuntimeWarning) else None
        if match is None:
            return shown(message, category, filename, lineno, file, line)
        reason = [text for text in str(message).splitlines() if text.strip()][-1].strip()
        (file or sys.stderr).write(one_line(f"vrsweep: {match['name']}={clip(repr(match['value']))} is not a value "
                                            f"numba can read ({clip(reason, 80)}): ignored, numba uses its default")
                                   + "\n")

    show.vrsweep_numba_words = True
    warnings.showwarning = show


def machine_cpus() -> int:
    """The machine's logical CPUs: the most threads (or local workers) vrsweep will start."""
    return os.cpu_count() or 1
