"""Signals as "stop at the next safe point": SIGINT (Ctrl-C), SIGTERM (scancel, a SLURM time
limit), SIGHUP (the terminal closed, an ssh session dropped) and SIGUSR1/SIGUSR2 (SLURM's
``--signal=USR1@60``, sent before the time limit) for long commands (run, merge, continue).

No numerics and no I/O libraries here, so that any command can use it without importing numba.
"""

import os
import signal
import sys
import threading


# The signals that ask a command to stop. Left to their default action, SIGHUP, SIGUSR1 and
# SIGUSR2 killed a run at once: the chunk in flight lost, no word in the log, exit 129/138/140 as
# a shell reports a killed process. (Not on every platform: Windows has neither.)
STOP_SIGNALS = tuple(getattr(signal, name) for name in ("SIGINT", "SIGTERM", "SIGHUP", "SIGUSR1", "SIGUSR2")
                     if hasattr(signal, name))
# Of these, the ones vrsweep takes over only where nobody else handles them: `nohup` ignores SIGHUP
# on purpose, and a program that runs vrsweep's API may use SIGUSR1 for its own ends.
_ONLY_IF_DEFAULT = tuple(signum for signum in STOP_SIGNALS if signum not in (signal.SIGINT, signal.SIGTERM))


class Interrupted(KeyboardInterrupt):
    """The run was stopped by a signal (SIGINT: Ctrl-C; SIGTERM: scancel, a time limit; SIGHUP:
    the terminal closed; SIGUSR1/SIGUSR2: SLURM's warning before a time limit)."""

    def __init__(self, signum):
        super().__init__(signal.Signals(signum).name)
        self.signum = signum

    @property
    def exit_code(self):
        return 128 + self.signum  # what a shell reports for a process killed by the signal


class GracefulStop:
    """Turn SIGINT, SIGTERM, SIGHUP, SIGUSR1 and SIGUSR2 into "stop after the chunk in flight is
    written".

    The numba kernel cannot be interrupted, and a chunk computed but not written would be lost,
    so the first signal only sets a flag (and says so on stderr); ``check()``, called by run_job
    after each chunk is written, then raises :class:`Interrupted`. A second signal raises at once
    (the file is crash-safe either way, only the chunk in flight is lost). SIGTERM is included
    because SLURM sends it at the time limit and on scancel, some 30 s (KillWait) before SIGKILL;
    SIGUSR1/SIGUSR2 because ``sbatch --signal=USR1@60`` sends one a chosen time before; SIGHUP
    because a closed terminal sends it (its stdout and stderr then go to /dev/null: writing to a
    hung-up terminal fails). SIGHUP, SIGUSR1 and SIGUSR2 are taken only where their handler is
    the default (or the command line's own): a ``nohup`` run ignores SIGHUP as asked.

    A context manager; outside the main thread (where Python cannot handle signals) it does
    nothing.
    """

    SIGNALS = STOP_SIGNALS

    def __init__(self, announce=True):
        self.signum = None
        self.announce = announce
        self._previous = {}

    def __enter__(self):
        if threading.current_thread() is threading.main_thread():
            for signum in self.SIGNALS:
                if signum in _ONLY_IF_DEFAULT and not _unclaimed(signum):
                    continue
                self._previous[signum] = signal.signal(signum, self._handle)
            # A signal whose Interrupted an import swallowed before this stop was set up: the run
            # went on as if never asked to stop (see _raise_interrupted). Stop now, nothing written.
            try:
                raise_if_swallowed()
            except Interrupted:
                self.__exit__()
                raise
        return self

    def __exit__(self, *exc):
        for signum, handler in self._previous.items():
            signal.signal(signum, handler)
        self._previous.clear()

    def announce_with(self, what):
        """Announce the first signal with ``what`` happens next (instead of a sweep's chunk)."""
        self.announce = what

    def _handle(self, signum, frame):
        _leave_a_lost_terminal()
        if self.signum is not None:
            raise Interrupted(signum)
        self.signum = signum
        if self.announce:
            what = self.announce if isinstance(self.announce, str) else "stopping once the chunk in progress is saved"
            try:
                sys.stderr.write(f"\n{signal.Signals(signum).name}: {what} (send it again to stop at once)\n")
                sys.stderr.flush()
            except (OSError, ValueError):  # nowhere to say it (stderr closed): the stop goes on all the same
                pass

    def check(self):
        if self.signum is not None:
            raise Interrupted(self.signum)


def _unclaimed(signum) -> bool:
    """Whether ``signum`` is left to its default action, or to the command line's own handlers."""
    return signal.getsignal(signum) in (signal.SIG_DFL, _exit_interrupted, _raise_interrupted)


def _leave_a_lost_terminal() -> None:
    """Send stdout and stderr to /dev/null where writing to them fails: a terminal that hung up
    (SIGHUP: the window closed, ssh dropped) answers every write with EIO, and the progress bar's
    next update, or the line that says where the run stopped, raised it out of the command, which
    then ended with exit 1 instead of the signal's code. A write of nothing tests it (0 on a file
    or a pipe, EIO on a hung-up terminal)."""
    for fd in (1, 2):
        try:
            os.write(fd, b"")
        except OSError:
            try:
                devnull = os.open(os.devnull, os.O_WRONLY)
                os.dup2(devnull, fd)
                os.close(devnull)
            except OSError:
                pass


# Signals whose Interrupted _raise_interrupted raised: C code that clears whatever error it meets
# may swallow one (numpy.random's Cython module, imported with numba at `run`'s start, registers
# its classes with abc, and an exception raised there vanished: a SIGTERM 0.3 s into `vrsweep run`
# was lost, and the run went on to its end, exit 0). GracefulStop looks here when it starts.
_raised = []


def _take_swallowed():
    """The signal of an Interrupted raised and never handled, or None; forgotten once taken."""
    return _raised.pop() if _raised else None


def raise_if_swallowed() -> None:
    """Raise the :class:`Interrupted` of a signal that C code swallowed (see ``_raised``), once;
    nothing if there is none. The command line asks after every command (cli.py): simulate, plot,
    info ... have no stop of their own, and one swallowed during their imports ended them with
    exit 0, the scancel lost (0.7.5 fixed run only)."""
    swallowed = _take_swallowed()
    if swallowed is not None:
        raise Interrupted(swallowed)


def forget_raised() -> None:
    """The Interrupted of _raise_interrupted reached its handler (cli.py): nothing was swallowed.
    Left noted, it stopped the next command run in the same process (the Python API, tests)."""
    _raised.clear()


def _exit_interrupted(signum, frame):
    # Nothing is written yet and nothing is held: say so in the one line every command uses, and
    # leave with the shell's code for the signal, without unwinding an import half done.
    _leave_a_lost_terminal()
    newline = "\n" if sys.stderr.isatty() and signum == signal.SIGINT else ""
    try:
        os.write(2, f"{newline}Interrupted ({signal.Signals(signum).name})\n".encode())
    except OSError:
        pass
    os._exit(128 + signum)


def exit_at_once_on_sigint() -> None:
    """Ctrl-C while the command line starts (imports take ~0.3 s; a traceback from inside one is
    what Python would print): exit 130 with one line; SIGTERM likewise, 143 (without a handler it
    ended the process with no word, as at no other moment). The command line calls
    :func:`raise_on_sigint` once a command runs, where KeyboardInterrupt is handled (cli.py)."""
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, _exit_interrupted)
        for signum in (signal.SIGTERM, *_ONLY_IF_DEFAULT):  # SIGHUP, SIGUSR1, SIGUSR2 likewise: 129, 138, 140
            if signal.getsignal(signum) is signal.SIG_DFL:
                signal.signal(signum, _exit_interrupted)


def _compiling() -> bool:
    """numba holds its compiler lock in this thread: it compiles, or loads from its cache (read
    from sys.modules: this module must not import numba)."""
    lock_module = sys.modules.get("numba.core.compiler_lock")
    if lock_module is None:
        return False
    try:
        return bool(lock_module.global_compiler_lock.is_locked())
    except Exception:  # noqa: BLE001 -- a numba without the lock's API: raise as usual
        return False


def _raise_interrupted(signum, frame):
    if _compiling():
        # llvmlite calls back into Python while numba compiles, and an exception cannot leave such a
        # callback: Python would print "Exception ignored on calling ctypes callback function" with
        # a traceback and go on, the Ctrl-C lost. Nothing is computed or written while a kernel
        # compiles, so leave at once, as during start-up.
        _exit_interrupted(signum, frame)
    # Interrupted, not Python's bare KeyboardInterrupt: when a bare one leaves code that exec() or
    # eval() runs from a string (dataclasses and namedtuples are made so, many while numba is
    # imported), CPython 3.11 notes an "unhandled Ctrl-C" even if a caller catches it, and
    # `python -m vrsweep` then ends killed by SIGINT after the command line has printed its one
    # line and chosen exit 130. Only the exact class is noted; the command line catches the
    # subclass as any KeyboardInterrupt (cli.py), with the same line and code.
    _raised[:] = [signum]  # taken by GracefulStop if the Interrupted is swallowed on its way
    raise Interrupted(signum)


def raise_on_sigint() -> None:
    """KeyboardInterrupt on SIGINT again (as :class:`Interrupted`), if exit_at_once_on_sigint set
    it aside; and on SIGTERM, SIGHUP, SIGUSR1 and SIGUSR2, where nothing else handles them. Without a handler SIGTERM (scancel, a
    SLURM time limit, `timeout`) ended simulate, plot or info with exit 143 and not a word in the
    job's log; now it is the one line and code of any interrupted command (cli.py). Commands that
    stop at a safe point (run, merge, continue) install their own for as long as they run."""
    if threading.current_thread() is not threading.main_thread():
        return
    if signal.getsignal(signal.SIGINT) is _exit_interrupted:
        signal.signal(signal.SIGINT, _raise_interrupted)
    for signum in (signal.SIGTERM, *_ONLY_IF_DEFAULT):
        if signal.getsignal(signum) in (signal.SIG_DFL, _exit_interrupted):
            signal.signal(signum, _raise_interrupted)
