"""vrsweep merge SHARD.h5 ... -o OUT.h5: join the shard files of one run into one result file."""

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
    """
    from vrsweep.store import merge_results

    report = merge_results(shards, output, overwrite=overwrite, allow_missing=allow_missing)
    if not quiet:
        click.echo(str(report), err=True)
