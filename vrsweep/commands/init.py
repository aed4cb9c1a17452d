"""vrsweep init [PATH] [--example NAME]: write a commented starter config (a shipped example).

The examples are the YAML files of ``vrsweep/examples/`` (in a clone also reachable as
``configs/``, a link to that folder), installed with the package so that ``pip install vrsweep``
users have them too. Each one's description is the first sentence of its leading comment.
"""

import re
import shlex
from importlib import resources
from pathlib import Path

import click
from click.core import ParameterSource

from vrsweep.commands.options import PathText
from vrsweep.errors import one_line

DEFAULT_EXAMPLE = "quickstart"
# What init writes is a config: its name says so (plot's -o goes by its suffix the same way).
CONFIG_SUFFIXES = (".yaml", ".yml")


@click.command("init")
@click.argument("path", required=False, type=PathText(), metavar="[PATH]")
@click.option("--example", "-e", "name", default=DEFAULT_EXAMPLE, show_default=True, metavar="NAME",
              help="The shipped example to start from (--list names them).")
@click.option("--list", "list_only", is_flag=True,
              help="List the shipped examples and exit; with --example, describe that one in full.")
@click.option("--overwrite", is_flag=True, help="Replace PATH if it exists.")
def command(path, name, list_only, overwrite):
    """Write a commented starter config to PATH (default: NAME.yaml here).

    The quickstart by default (a coarse R(g) sweep that runs in seconds), or any shipped example
    with --example: the paper's figures, a g-Omega map, a hysteresis sweep. Then:
    `vrsweep validate PATH`, `vrsweep run PATH`. An existing file is never replaced without
    --overwrite; if PATH is a directory, the config is written into it as NAME.yaml, else PATH
    ends in .yaml or .yml.
    """
    from vrsweep.errors import UsageError

    examples = shipped_examples()
    name = name.removesuffix(".yaml")
    if name not in examples:
        raise UsageError(f"--example {name}: no such example; shipped: {', '.join(examples)} "
                         "(vrsweep init --list describes them)")
    if list_only:
        # --list writes nothing: a PATH or --overwrite given with it would be dropped silently
        # (the user meant to write a file), so they are refused; --example NAME asks about one.
        if path is not None or overwrite:
            given = "PATH " + one_line(path) if path is not None else "--overwrite"
            raise UsageError(f"--list writes nothing, so {given} would be ignored: "
                             "leave out --list to write a config")
        if click.get_current_context().get_parameter_source("name") is ParameterSource.DEFAULT:
            _print_list(examples)
        else:
            _print_one(name, examples[name])
        return
    target = Path(path) if path else Path(f"{name}.yaml")
    from vrsweep.config.wording import folder_ending
    from vrsweep.store.fileio import output_target, write_bytes

    # PATH/ names a folder (Path() drops the slash): written into when it exists, never as a file
    if folder_ending(path) and not target.is_dir():
        raise UsageError(f"PATH {path} ends in a slash, which names a folder, and there is no such folder: "
                         "create it first, or give the file's name (without the slash)")
    if target.is_dir():
        target = target / f"{name}.yaml"
    elif target.suffix.lower() not in CONFIG_SUFFIXES:
        # `init x.h5` wrote YAML into a file named as results (which `run` then refused as "not
        # HDF5" only if given it as a result); validate, run and a reader of the folder go by the name.
        raise UsageError(f"PATH {one_line(path)}: a config is YAML, named .yaml or .yml: give a name ending in "
                         f"one of them (or a folder that exists, to write {name}.yaml into it)")

    shown = target
    target = Path(output_target(target, overwrite=overwrite, writes="a config", exists_error=lambda: UsageError(
        f"{shown} already exists: pass --overwrite to replace it")))
    if not target.parent.is_dir():
        raise UsageError(f"directory {target.parent} does not exist (PATH: {target})")

    text = examples[name].read_text(encoding="utf-8")
    # Its comments show the commands that run it, written for the clone's configs/NAME.yaml: name
    # the new file instead (padded where a comment follows, to keep the comments aligned).
    written = shlex.quote(str(target))
    text = re.sub(rf"configs/{re.escape(name)}\.yaml( +)(?=#)",
                  lambda match: written.ljust(len(match.group(0)) - 1) + " ", text)
    text = text.replace(f"configs/{name}.yaml", written)
    # Written beside and renamed into place: a full disk leaves the old file or none, never a
    # 0-byte config that validate would then accept.
    write_bytes(target, text.encode("utf-8"), doing="write the config")
    click.echo(f"-> {one_line(target)} (example {name}); run it with: {_run_command(text, written)}", err=True)
    _make_output_folder(target)


def shipped_examples():
    """{name: resource} of the shipped example configs, the default first, then by name."""
    folder = resources.files("vrsweep") / "examples"
    found = {entry.name.removesuffix(".yaml"): entry for entry in folder.iterdir()
             if entry.name.endswith(".yaml")}
    order = sorted(found, key=lambda example: (example != DEFAULT_EXAMPLE, example))
    return {example: found[example] for example in order}


def description(text, width=None):
    """The first sentence of a config's leading comment, cut to ``width`` characters."""
    comment = []
    for line in text.splitlines():
        if not line.startswith("#"):
            break
        words = line.lstrip("#").strip()
        if not words and comment:  # a blank comment line ends the first paragraph
            break
        comment.append(words)
    paragraph = " ".join(comment)
    sentence = re.split(r"(?<!Fig)\.(?:\s|$)", paragraph, maxsplit=1)[0].strip()
    if width and len(sentence) > width:
        head = sentence[:width - 3]
        if sentence[width - 3] != " ":  # cut inside a word: drop it
            head = head.rsplit(" ", 1)[0]
        sentence = head.rstrip(",;: ") + "..."
    return sentence


def _own_command(text, path):
    """The first `vrsweep run|simulate|continue PATH ...` of the config's comments that runs this
    config (PATH), as one line; None if none does.

    A config's comments may first make what it reads (continuation_hysteresis.yaml runs the
    hysteresis sweep before continuing itself): the first command of any config was taken, and
    `init` told the user to run another example's file, which their folder did not even hold."""
    for match in re.finditer(r"^#\s+(vrsweep (?:run|simulate|continue) [^#]*)", text, flags=re.MULTILINE):
        try:
            words = shlex.split(match.group(1))  # a written path may be quoted: 'my runs/x.yaml'
        except ValueError:
            continue
        if len(words) > 2 and words[2] == path:
            return " ".join(match.group(1).split())
    return None


def _command_of(text, name):
    """'simulate' or 'continue' for an example whose comments run it with that command, else 'run'."""
    own = _own_command(text, f"configs/{name}.yaml")
    return own.split()[1] if own else "run"


def _run_command(text, written):
    """The command of the config's comments that runs the written config, else `vrsweep run PATH`."""
    return _own_command(text, shlex.split(written)[0]) or f"vrsweep run {written}"


def _print_list(examples):
    import shutil

    width = max(len(example) for example in examples)
    columns = shutil.get_terminal_size((120, 24)).columns  # one line per example
    click.echo("Shipped examples (vrsweep init --example NAME [PATH] writes one):")
    for example, resource in examples.items():
        text = resource.read_text(encoding="utf-8")
        start = f"  {example:<{width}}  {_command_of(text, example):<8}  "
        click.echo(start + description(text, max(40, columns - 1 - len(start))))


def _print_one(name, resource):
    """One example's leading comment in full (--list --example NAME), and how to write it."""
    text = resource.read_text(encoding="utf-8")
    comment = []
    for line in text.splitlines():
        if not line.startswith("#"):
            break
        # the commands name the file init writes (NAME.yaml here), not the clone's configs/
        comment.append(line[1:].removeprefix(" ").replace(f"configs/{name}.yaml", f"{name}.yaml"))
    while comment and not comment[-1].strip():
        comment.pop()
    click.echo(f"{name} ({_command_of(text, name)}):")
    for line in comment:
        click.echo(f"  {line}".rstrip())
    click.echo(f"Write it with: vrsweep init --example {name} [PATH]")


def _make_output_folder(target):
    """A relative ``output: folder/file.h5`` needs its folder where the config will be run:
    make it here, where the user is (run refuses to write into a missing folder)."""
    from vrsweep.config import load_config

    output = load_config(target).output_path()
    folder = output.parent
    if not output.is_absolute() and not folder.exists():
        folder.mkdir(parents=True)
        click.echo(f"   created {one_line(folder)}/ for its output {one_line(output)} (relative to the directory you run it in)",
                   err=True)
