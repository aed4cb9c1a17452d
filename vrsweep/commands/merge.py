"""vrsweep merge SHARD.h5 ... -o OUT.h5: join the shard files of one run into one result file."""

import os
import signal
import sys

import click

from vrsweep.commands.options import PathText, OUTPUT_FLAGS, file_name_only, flag_wording, overwrite_option, quiet_option
from vrsweep.errors import one_line


@click.command("merge")
@click.argument("shards", nargs=-1, required=True, metavar="SHARD.h5...", type=PathText(dir_okay=False))
@click.option("-o", "--output", type=PathText(dir_okay=False), required=True, callback=file_name_only,
              help="The merged result file.")
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
    from vrsweep.store.merge import merge_results
    from vrsweep.execution.signals import GracefulStop

    before = _identity(output)
    try:
        # A signal only takes note; the merge stops at its next read of a shard (stop.check,
        # within milliseconds) and unwinds, removing its temporary file (an exception raised from
        # the handler itself could land in a finalizer, where Python drops it).
        with GracefulStop(announce=False) as stop, flag_wording(
                {**OUTPUT_FLAGS, "resume_into": "'vrsweep run CONFIG --resume -o OUT.h5'"}):
            report = merge_results(shards, output, overwrite=overwrite, allow_missing=allow_missing,
                                   stop=stop.check)
            stop.check()  # a signal during the final rename: the output is complete
    except KeyboardInterrupt as interrupt:
        name = str(interrupt) if getattr(interrupt, "signum", None) else "SIGINT"
        newline = "\n" if sys.stderr.isatty() else ""  # off the terminal's "^C"
        if _identity(output) not in (before, None):  # the signal came after the rename
            click.echo(f"{newline}Interrupted ({name}) as the merge finished: {one_line(output)} is complete", err=True)
        else:
            state = "left as it was" if before is not None else "not written"
            click.echo(f"{newline}Interrupted ({name}): merge stopped, {one_line(output)} {state} (no partial file)",
                       err=True)
        sys.exit(128 + getattr(interrupt, "signum", signal.SIGINT))
    if not quiet:
        click.echo("\n".join(one_line(line) for line in str(report).split("\n")), err=True)


def _identity(path):
    """(device, inode, mtime) of ``path``, or None: tells whether a rename replaced it."""
    try:
        st = os.stat(path)
    except OSError:
        return None
    return (st.st_dev, st.st_ino, st.st_mtime_ns)
