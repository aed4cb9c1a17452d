"""vrsweep merge SHARD.h5 ... -o OUT.h5: join the shard files of one run into one result file."""

import os
import signal
import sys
import threading

import click

from vrsweep.commands.options import overwrite_option, quiet_option


@click.command("merge")
@click.argument("shards", nargs=-1, required=True, metavar="SHARD.h5...", type=click.Path(dir_okay=False))
@click.option("-o", "--output", type=click.Path(dir_okay=False), required=True, help="The merged result file.")
@overwrite_option
@click.option("--allow-missing", is_flag=True,
              help="Write the merged file even if points are missing; it is marked incomplete and "
                   "'vrsweep run CONFIG --resume -o OUT.h5' computes the rest.")
@quiet_option
def command(shards, output, overwrite, allow_missing, quiet):
    """Merge the shard files of one config (from 'vrsweep run --shard') into OUT.h5.

    Every shard must come from the same config; every point must be in some shard (else exit 2,
    naming the missing points and the shard they belong to, unless --allow-missing); a point in
    two shards must have identical values. The result is the file a single run would have written.
    Shards are read block by block, so memory does not grow with their number. OUT.h5 is written
    under a temporary name and renamed at the end: Ctrl-C (exit 130), SIGTERM (143) or an error
    leave OUT.h5 as it was and no temporary file.
    """
    from vrsweep.merge import merge_results

    before = _identity(output)
    try:
        with _StopOnSignal() as stop:
            report = merge_results(shards, output, overwrite=overwrite, allow_missing=allow_missing,
                                   stop=stop.check)
            stop.check()  # a signal during the final rename: the output is complete
    except KeyboardInterrupt as interrupt:
        name = getattr(interrupt, "name", "SIGINT")
        newline = "\n" if sys.stderr.isatty() else ""  # off the terminal's "^C"
        if _identity(output) not in (before, None):  # the signal came after the rename
            click.echo(f"{newline}Interrupted ({name}) as the merge finished: {output} is complete", err=True)
        else:
            state = "left as it was" if before is not None else "not written"
            click.echo(f"{newline}Interrupted ({name}): merge stopped, {output} {state} (no partial file)",
                       err=True)
        sys.exit(128 + getattr(interrupt, "signum", signal.SIGINT))
    if not quiet:
        click.echo(str(report), err=True)


def _identity(path):
    """(device, inode, mtime) of ``path``, or None: tells whether a rename replaced it."""
    try:
        st = os.stat(path)
    except OSError:
        return None
    return (st.st_dev, st.st_ino, st.st_mtime_ns)


class _Stopped(KeyboardInterrupt):
    def __init__(self, signum):
        self.signum = signum
        self.name = signal.Signals(signum).name
        super().__init__(self.name)


class _StopOnSignal:
    """SIGINT and SIGTERM (scancel, a SLURM time limit) stop the merge at its next read of a shard
    (``check``, within milliseconds), so that it unwinds and removes its temporary file
    (store.atomic_write). The handler only takes note: an exception raised from a signal handler
    can land in a finalizer, where Python drops it. A second signal raises at once."""

    SIGNALS = (signal.SIGINT, signal.SIGTERM)

    def __init__(self):
        self.signum = None
        self._previous = {}

    def __enter__(self):
        if threading.current_thread() is threading.main_thread():
            for signum in self.SIGNALS:
                self._previous[signum] = signal.signal(signum, self._handle)
        return self

    def __exit__(self, *exc):
        for signum, handler in self._previous.items():
            signal.signal(signum, handler)

    def _handle(self, signum, frame):
        if self.signum is not None:
            raise _Stopped(self.signum)
        self.signum = signum

    def check(self):
        if self.signum is not None:
            raise _Stopped(self.signum)
