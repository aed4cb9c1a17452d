"""The ``vrsweep`` command line: thin click commands over the library.

Each command lives in ``vrsweep/commands/<name>.py``; this module only groups them and turns the
project's own exceptions into one clear message and an exit code (2: bad input, 1: runtime,
130: Ctrl-C).
"""

import os
import sys
import warnings

import click

from vrsweep import __version__
from vrsweep.errors import VrsweepError, one_line
from vrsweep.execution.signals import forget_raised
from vrsweep.store.provenance import record_command_line


class _Group(click.Group):
    def main(self, args=None, *pos, **kwargs):
        # history (CF) records the exact command line, as typed
        record_command_line(sys.argv[1:] if args is None else args)
        return super().main(args, *pos, **kwargs)

    def parse_args(self, ctx, args):
        # An option of vrsweep itself refused (`vrsweep --bogus`) is parsed here, before invoke's
        # handler: click printed four lines, usage, hint, blank, error. One line, as a command's.
        try:
            return super().parse_args(ctx, args)
        except click.exceptions.NoArgsIsHelpError:
            raise  # `vrsweep` alone: the help, which is what was asked for
        except click.UsageError as error:
            click.echo(f"Error: {_one_line(error)}", err=True)
            ctx.exit(2)

    def invoke(self, ctx):
        try:
            from vrsweep.execution.signals import raise_if_swallowed, raise_on_sigint

            raise_on_sigint()  # from here on, KeyboardInterrupt: handled below (and by run)
            # numpy's overflow warnings from vrsweep's own arithmetic (omega = 1e-320 in the theory)
            # print source lines to a user who can do nothing with them: the results already say
            # it (NaN, a status, "-" in a table).
            with warnings.catch_warnings():
                warnings.filterwarnings("ignore", category=RuntimeWarning, module=r"vrsweep\.")
                result = super().invoke(ctx)
            # A signal whose Interrupted C code swallowed while the command ran (an import:
            # numpy.random registering its classes with abc) ended simulate, plot, info ... with
            # exit 0, as if never sent (run, merge and continue ask their stop). The command has
            # finished, and what it wrote is complete (written under a temporary name, renamed):
            # the line and code of a signal that arrives at its last moment.
            raise_if_swallowed()
            return result
        except click.UsageError as error:
            # click's own refusal of an option (--dpi 5, --kind nope, a missing argument) is four
            # lines: usage, a hint, a blank line, the error. One line, as every other bad input.
            click.echo(f"Error: {_one_line(error)}", err=True)
            ctx.exit(2)
        except VrsweepError as error:
            # Each problem one line, whatever the names it quotes hold (one_line: a newline in a
            # file name or a YAML key made a second line that read as vrsweep's own).
            problems = getattr(error, "problems", None)
            if problems and len(problems) > 1:
                click.echo(f"Error: {len(problems)} problems:", err=True)
                for problem in problems:
                    click.echo(f"  {one_line(problem)}", err=True)
            else:
                click.echo(f"Error: {one_line(error)}", err=True)
            ctx.exit(error.exit_code)
        except BrokenPipeError:  # `vrsweep info ... | head`: the reader has all it wants
            # Later writes (Python flushes stdout on exit) would fail too: send them nowhere.
            try:
                os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
            except (OSError, ValueError):  # no file descriptor (e.g. click's CliRunner)
                pass
            ctx.exit(141)  # 128 + SIGPIPE, what a shell reports for a writer killed by it
        except OSError as error:  # disk full, permission denied, ...: a message, not a traceback
            click.echo(one_line(f"Error: {error.strerror or error}: {error.filename or ''}".rstrip(": ")), err=True)
            ctx.exit(1)
        except MemoryError:  # a safety net: runs count what they hold first (estimate.memory_problem)
            click.echo("Error: out of memory: this command needs more than the process may have; ask for less "
                       "(a smaller grid, fewer measure_periods) or run where more memory is free", err=True)
            ctx.exit(1)
        except KeyboardInterrupt as interrupt:
            # Not click's "Aborted!" and exit 1: one line and the shell's code for SIGINT, 128 + 2,
            # as `run` does (which handles its own, to say how to resume). Files are written to a
            # temporary name and renamed into place, so an interrupted command leaves none half done.
            newline = "\n" if sys.stderr.isatty() else ""  # off the terminal's "^C"
            click.echo(f"{newline}Interrupted ({str(interrupt) or 'SIGINT'})", err=True)
            ctx.exit(getattr(interrupt, "exit_code", 130))
        finally:
            # Whatever Interrupted was raised has been handled (here, or by run, merge, continue):
            # left noted, it would stop the next command run in this process (the API, tests).
            forget_raised()


def _one_line(error):
    """click's message for a refused option or argument, on one line, with the help to read."""
    message = one_line(" ".join(error.format_message().split()))
    command = error.ctx.command_path if error.ctx is not None else "vrsweep"
    return f"{message.rstrip('.')} (see {command} --help)"


@click.group(cls=_Group, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="vrsweep")
def main():
    """Vibrational resonance in impacting oscillators: sweeps, trajectories and continuation of the
    paper's vibro-impact Van der Pol-Duffing oscillator, or of one written in the config (vrsweep
    init --example impact_linear writes one)."""


def _register():
    import importlib

    for name in ("init", "run", "theory", "validate", "plot", "simulate", "continue_", "merge", "info"):
        try:
            module = importlib.import_module(f"vrsweep.commands.{name}")
        except ModuleNotFoundError as error:
            if error.name == f"vrsweep.commands.{name}":
                continue  # command not built yet
            raise
        main.add_command(module.command)


_register()

if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
