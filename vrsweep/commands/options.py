"""Options shared by several commands, defined once (after rasterio's ``rio/options.py``)."""

from contextlib import contextmanager

import click

# The library's messages name what a caller can do in its own terms (vrsweep.errors,
# VrsweepError.naming); at the command line they name these flags.
OUTPUT_FLAGS = {"overwrite": "--overwrite", "resume": "--resume", "start_afresh": "run without --resume",
                "output": "-o", "allow_missing": "--allow-missing"}


@contextmanager
def flag_wording(flags=OUTPUT_FLAGS):
    """Re-word the library's errors raised in the block for the command line (``flags``:
    {argument: "--flag"}), as rasterio's ``rio`` commands add their flags to the library's errors."""
    from vrsweep.errors import VrsweepError

    try:
        yield
    except VrsweepError as error:
        raise error.reworded(flags) from None

def say_cache_notice():
    """Say once per process where the numba cache went when it is not where the user asked
    (vrsweep.numerics.numba_cache.notice), to standard error."""
    from vrsweep.numerics import numba_cache

    message = numba_cache.notice()
    if message and not getattr(say_cache_notice, "said", False):
        say_cache_notice.said = True
        click.echo(f"Note: {message}", err=True)


def say_if_compiling(is_cached, what="the numba kernel", duration="about 30 s", pronoun="it"):
    """Say, before the work starts, that ``what`` compiles first when the cache lacks it
    (``is_cached()``, a hint: numba_cache.is_compiled), or on every run when there is no cache:
    a first run is otherwise silent for as long as numba takes (run, continue)."""
    from vrsweep.numerics.numba_cache import cache_dir, enabled

    say_cache_notice()
    if not enabled():
        click.echo(f"Compiling {what} ({duration}, on every run: not cached)", err=True)
    elif not is_cached():
        click.echo(f"Compiling {what} ({duration}, once: later runs load {pronoun} from {cache_dir()})", err=True)


class PathText(click.Path):
    """click.Path that refuses an empty path: '' named no file, and each command read it as its
    own thing (``run -o ''`` as the folder ".", ``plot -o ''`` and ``init ''`` as no -o or PATH
    at all, ``merge -o ''`` as a write failure, exit 1)."""

    def convert(self, value, param, ctx):
        if isinstance(value, str) and value == "":
            self.fail("an empty path names no file: give the file's name", param, ctx)
        return super().convert(value, param, ctx)


set_option = click.option(
    "--set", "overrides", multiple=True, metavar="NAME=VALUE",
    help="Override a parameter (fixing it if it is swept), an integration setting, "
         "initial.x/initial.v, model or continuation.KEY; repeatable. E.g. --set g=5 (a parameter of "
         "the paper's model; a written model's by their names) --set rtol=1e-10 "
         "--set continuation.max_step=0.05.",
)
device_option = click.option(
    "--device", type=click.Choice(["cpu", "cuda"]), default=None,
    help="Where the points are integrated: cpu (all cores) or cuda (an NVIDIA GPU; needs "
         "pip install \"vrsweep[cuda]\"). Overrides integration.device; the same as --set device=...",
)
def file_name_only(ctx, param, value):
    """A click callback for an option that names a file to write: ``-o x.png/`` names a folder, and
    pathlib, which every command hands the path to, would drop the slash and write ``x.png``."""
    if value is not None:
        from vrsweep.store.fileio import refuse_a_folder_name

        with flag_wording({"output": param.opts[0]}):
            refuse_a_folder_name(value)
    return value


output_option = click.option(
    "-o", "--output", type=PathText(dir_okay=False), default=None, callback=file_name_only,
    help="Output file (overrides the config's 'output').",
)
def _option_name(param):
    return param.opts[0] if param is not None and param.opts else "the value"


class FiniteFloatRange(click.ParamType):
    """A number option, read by the one rule of numbers as text (vrsweep.numbertext): decimal ASCII
    digits, finite, one a double holds. click's float() took nan and inf (1e400 read as inf), "١٢"
    and the fullwidth "１２" as 12, and 1e-400 as 0."""

    name = "number"

    def __init__(self, min=None):
        self.min = min

    def convert(self, value, param, ctx):
        from vrsweep.errors import clip
        from vrsweep.numbertext import NumberTextError, read_float

        if isinstance(value, float) or isinstance(value, int) and not isinstance(value, bool):
            return float(value)  # a default
        try:
            number = read_float(value)
        except NumberTextError as error:
            raise click.UsageError(f"{_option_name(param)} {clip(value)}: {error}", ctx) from None
        if self.min is not None and number < self.min:
            raise click.UsageError(f"{_option_name(param)} {clip(value)}: expected a number >= {self.min}", ctx)
        return number


class WholeNumberRange(click.ParamType):
    """A whole-number option, read by the one rule of numbers as text (vrsweep.numbertext) and
    refused in words: '1e9' was "not a valid integer range" and 5 "not in the range
    20<=x<=1200"; now "--dpi 1e9: expected a whole number from 20 to 1200". click's int() took "١٢"
    and the fullwidth "１２" as 12."""

    name = "integer"

    def __init__(self, min=None, max=None):
        self.min, self.max = min, max

    def _bounds(self):
        if self.min is None:
            return ""
        if self.max is None:
            return f" of at least {self.min}"
        return f" from {self.min} to {self.max}"

    def convert(self, value, param, ctx):
        from vrsweep.errors import clip
        from vrsweep.numbertext import NumberTextError, read_int

        if isinstance(value, int) and not isinstance(value, bool):
            number = value  # a default
        else:
            try:
                number = read_int(value)
            except NumberTextError as error:
                digits = f" in ASCII digits 0-9 (it holds {error.foreign})" if error.foreign else ""
                raise click.UsageError(f"{_option_name(param)} {clip(value)}: expected a whole number"
                                       f"{self._bounds()}{digits}", ctx) from None
        if (self.min is not None and number < self.min) or (self.max is not None and number > self.max):
            raise click.UsageError(f"{_option_name(param)} {clip(value)}: expected a whole number{self._bounds()}",
                                   ctx)
        return number


# More threads than any machine has CPUs: a number past it is a typo, not a request to cap.
MAX_THREADS = 65536
threads_option = click.option(
    "--threads", type=WholeNumberRange(min=1, max=MAX_THREADS), default=None,
    help="Threads for the kernel (default: all cores, or NUMBA_NUM_THREADS).",
)
quiet_option = click.option("--quiet", "-q", is_flag=True, help="No progress bar or summary.")
overwrite_option = click.option("--overwrite", is_flag=True, help="Replace an existing output file.")
config_argument = click.argument("config_path", metavar="CONFIG.yaml", type=PathText(dir_okay=False))


def capped_threads(threads):
    """--threads, lowered to what numba can run here, saying so on stderr (never silently)."""
    from vrsweep.execution.threads import available_threads

    available = available_threads()
    if threads is not None and threads > available:
        click.echo(f"--threads {threads}: numba can run {available} thread{'s' if available != 1 else ''} "
                   f"here (NUMBA_NUM_THREADS or the CPUs this process may use); using {available}", err=True)
        return available
    return threads


def announce_fixed_axes(config_path, overrides, config):
    """One stderr line for each --set that fixed a swept parameter, removing its axis."""
    from vrsweep.config import load_config
    from vrsweep.errors import ConfigError

    names = {item.partition("=")[0].strip() for item in overrides}
    names = {name.removeprefix("parameters.") for name in names}
    if not names & (set(config.parameters) - set(config.axis_names)):
        return
    try:
        as_written = load_config(config_path)
    except ConfigError:  # the overrides are what make it valid: nothing to compare with
        return
    for axis in as_written.axes:
        if axis.name in names and axis.name not in config.axis_names:
            values = axis.values
            click.echo(f"--set {axis.name}={config.parameters[axis.name]:g}: {axis.name} was swept "
                       f"({len(values)} values from {min(values):g} to {max(values):g}); it is now fixed "
                       "and that axis is gone", err=True)
