"""Options shared by several commands, defined once (after rasterio's ``rio/options.py``)."""

import click

set_option = click.option(
    "--set", "overrides", multiple=True, metavar="NAME=VALUE",
    help="Override a parameter (fixing it if it is swept), an integration setting, "
         "initial.x/initial.v or model; repeatable. E.g. --set g=5 --set rtol=1e-10.",
)
output_option = click.option(
    "-o", "--output", type=click.Path(dir_okay=False), default=None,
    help="Output file (overrides the config's 'output').",
)
threads_option = click.option(
    "--threads", type=click.IntRange(min=1), default=None,
    help="Numba threads (default: all cores, or NUMBA_NUM_THREADS).",
)
quiet_option = click.option("--quiet", "-q", is_flag=True, help="No progress bar or summary.")
overwrite_option = click.option("--overwrite", is_flag=True, help="Replace an existing output file.")
config_argument = click.argument("config_path", metavar="CONFIG.yaml", type=click.Path(dir_okay=False))
