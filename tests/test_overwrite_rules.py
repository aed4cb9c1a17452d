"""Issue 24, class 3: what an output path may be, decided in one place (store/fileio.output_target)
for run, simulate, merge, plot and init.

- Only a regular file is replaced, and only with --overwrite (plot replaces unasked only the
  figures vrsweep wrote: test_hostile_outputs); a folder, a pipe or a device at the path is
  refused with or without it.
- An input of the command (the config being run, a file being merged or plotted) is never
  written over, whatever the flags, also through a symbolic link.
- A symbolic link is followed: the link's target is written (created, replaced or resumed) and the
  link stays a link.
"""

import os
import shutil
import stat

import h5py
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

CONFIG = """\
model: effective
sweep:
  g: {start: 0, stop: 40, num: 3}
integration: {transient_periods: 2, measure_periods: 16}
"""
POINT = """\
model: effective
parameters: {g: 5}
integration: {transient_periods: 1, measure_periods: 2, strobe_periods: 1}
"""
KINDS = ["missing", "regular", "fifo", "folder", "link_to_regular", "dangling_link", "input", "link_to_input"]
SUFFIX = {"run": ".h5", "simulate": ".h5", "merge": ".h5", "plot": ".png", "init": ".yaml"}
OLD = b"old contents"


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    from click.testing import CliRunner

    from vrsweep.cli import main

    folder = tmp_path_factory.mktemp("inputs")
    (folder / "sweep.yaml").write_text(CONFIG)
    (folder / "point.yaml").write_text(POINT)
    result = CliRunner().invoke(main, ["run", str(folder / "sweep.yaml"), "-o", str(folder / "good.h5"), "-q"])
    assert result.exit_code == 0, result.output
    return folder


def _work(tmp_path, inputs, command):
    """A fresh folder with the command's config and a good result file: (folder, config, result)."""
    work = tmp_path / "work"
    work.mkdir()
    config = work / ("point.yaml" if command == "simulate" else "sweep.yaml")
    shutil.copy(inputs / config.name, config)
    result = work / "good.h5"
    shutil.copy(inputs / "good.h5", result)
    return work, config, result


def _setup(tmp_path, inputs, command, kind):
    """(the output path to give, the input files of the command) with the path made of ``kind``."""
    work, config, result = _work(tmp_path, inputs, command)
    command_inputs = {"run": [config], "simulate": [config], "merge": [result], "plot": [result], "init": []}[command]
    out = work / f"out{SUFFIX[command]}"
    target = work / f"target{SUFFIX[command]}"
    if kind == "regular":
        out.write_bytes(OLD)
    elif kind == "fifo":
        os.mkfifo(out)
    elif kind == "folder":
        out.mkdir()
    elif kind == "link_to_regular":
        target.write_bytes(OLD)
        out.symlink_to(target.name)
    elif kind == "dangling_link":
        out.symlink_to(target.name)
    elif kind == "input":
        out = command_inputs[0]
    elif kind == "link_to_input":
        out.symlink_to(command_inputs[0].name)
    return out, target, command_inputs


def _args(command, out, command_inputs, overwrite):
    flag = ["--overwrite"] if overwrite else []
    return {
        "run": ["run", *command_inputs, "-o", out, "-q", *flag],
        "simulate": ["simulate", *command_inputs, "-o", out, "-q", *flag],
        "merge": ["merge", *command_inputs, "-o", out, "-q", *flag],
        "plot": ["plot", *command_inputs, "-o", out, *flag],
        "init": ["init", out, *flag],
    }[command]


@settings(max_examples=40, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(command=st.sampled_from(sorted(SUFFIX)), kind=st.sampled_from(KINDS), overwrite=st.booleans())
def test_what_an_output_may_replace(tmp_path_factory, inputs, invoke, command, kind, overwrite):
    if command == "init" and kind in ("input", "link_to_input", "folder"):
        return  # init has no input; a folder is where init writes NAME.yaml (test_cli_init)
    tmp_path = tmp_path_factory.mktemp(command)
    out, target, command_inputs = _setup(tmp_path, inputs, command, kind)
    before = {path: path.read_bytes() for path in command_inputs}
    result = invoke(*_args(command, out, command_inputs, overwrite))
    lines = result.output.strip().splitlines()
    replaces = overwrite
    if command == "plot" and kind == "input":  # good.h5 is no figure's name: refused for its suffix first
        assert result.exit_code == 2, result.output
    elif kind in ("input", "link_to_input"):
        assert result.exit_code == 2 and "choose another output" in result.output, result.output
    elif kind == "fifo":
        assert result.exit_code == 2 and "not a regular file" in result.output, result.output
        assert stat.S_ISFIFO(os.lstat(out).st_mode)
    elif kind == "folder":
        assert result.exit_code == 2 and "is a directory" in result.output, result.output
    elif kind in ("regular", "link_to_regular") and not replaces:
        assert result.exit_code == 2 and "already exists" in result.output, result.output
        assert (target if kind == "link_to_regular" else out).read_bytes() == OLD
    else:
        assert result.exit_code == 0, result.output
        written = target if "link" in kind else out
        assert written.read_bytes() != OLD and os.path.getsize(written) > 0
        assert stat.S_ISREG(os.lstat(written).st_mode)
        if "link" in kind:  # followed: the link stays a link, to the same target
            assert os.path.islink(out) and os.readlink(out) == target.name
    if result.exit_code == 2 and kind != "folder":  # click refuses a folder for -o with its usage lines
        assert len(lines) == 1, result.output
    for path, contents in before.items():  # inputs are never touched
        assert path.read_bytes() == contents


@pytest.mark.parametrize("command", ["init", "plot"])
@pytest.mark.parametrize("kind", ["sweep", "branch", "link_to_sweep"])
@pytest.mark.parametrize("overwrite", [False, True])
def test_results_are_never_replaced_by_a_config_or_a_figure(tmp_path, inputs, invoke, command, kind, overwrite):
    """`init results.h5 --overwrite` replaced a sweep with the quickstart's YAML: plot refused
    this on its own, init had no such rule. Both now ask output_target (writes=...)."""
    from handmade import write_branch_file

    plotted = tmp_path / "plotted.h5"
    shutil.copy(inputs / "good.h5", plotted)
    results = tmp_path / f"results{SUFFIX[command]}"  # results under the output's own suffix
    if kind == "branch":
        write_branch_file(tmp_path / "branch.h5").rename(results)
    else:
        shutil.copy(inputs / "good.h5", tmp_path / "sweep.h5")
        if kind == "link_to_sweep":
            results.symlink_to("sweep.h5")
        else:
            os.rename(tmp_path / "sweep.h5", results)
    before = {path: path.read_bytes() for path in tmp_path.iterdir()}
    result = invoke(*_args(command, results, [plotted], overwrite))
    assert result.exit_code == 2, result.output
    assert len(result.output.strip().splitlines()) == 1, result.output
    assert "is an HDF5 file (results?)" in result.output and "choose another output" in result.output, result.output
    assert {path: path.read_bytes() for path in tmp_path.iterdir()} == before


@pytest.mark.parametrize("command", [*sorted(SUFFIX), "continue"])
@pytest.mark.parametrize("separator", ["/", "//"])
def test_an_output_ending_in_a_slash_names_a_folder_and_is_refused(tmp_path, inputs, invoke, command, separator):
    """`plot X.h5 -o x.png/` wrote x.png (pathlib drops the slash): a trailing slash names a folder,
    so every command refuses it, in one line, before anything is computed or written."""
    work, config, result_file = _work(tmp_path, inputs, command)
    out = f"{work / 'out'}{SUFFIX.get(command, '.h5')}{separator}"
    args = {"run": ["run", config, "-o", out, "-q"], "simulate": ["simulate", config, "-o", out, "-q"],
            "merge": ["merge", result_file, "-o", out, "-q"], "plot": ["plot", result_file, "-o", out],
            "init": ["init", out], "continue": ["continue", config, "-o", out, "-q"]}[command]
    before = sorted(work.iterdir())
    result = invoke(*args)
    assert result.exit_code == 2, result.output
    (line,) = result.output.strip().splitlines()
    assert "ends in a slash, which names a folder" in line and out in line, line
    assert sorted(work.iterdir()) == before


def test_an_output_ending_in_a_slash_is_refused_in_python_and_in_a_config(tmp_path, inputs, monkeypatch):
    import vrsweep
    from vrsweep.config import load_config
    from vrsweep.errors import ConfigError, UsageError

    monkeypatch.chdir(tmp_path)
    with pytest.raises(UsageError, match="^output o.h5/ ends in a slash, which names a folder"):
        vrsweep.sweep(inputs / "sweep.yaml", output="o.h5/", progress=False)
    with pytest.raises(UsageError, match="^output o.h5/ ends in a slash"):
        vrsweep.simulate(inputs / "point.yaml", output="o.h5/")
    config = tmp_path / "c.yaml"
    config.write_text(CONFIG + "output: results/\n")
    with pytest.raises(ConfigError, match="c.yaml:5: output: must name a file, got 'results/', which ends in a slash"):
        load_config(config)
    assert not (tmp_path / "o.h5").exists() and not (tmp_path / "results").exists()


def test_run_never_replaces_its_own_config(tmp_path, invoke):
    config = tmp_path / "one.yaml"
    config.write_text(CONFIG)
    result = invoke("run", config, "-o", config, "--overwrite")
    assert result.exit_code == 2 and "is the config being run" in result.output
    assert config.read_text() == CONFIG


def test_resume_through_a_link_finishes_the_target_and_keeps_the_link(tmp_path, inputs, invoke):
    partial = tmp_path / "partial.h5"
    shutil.copy(inputs / "good.h5", partial)
    with h5py.File(partial, "r+") as f:
        expected_R = f["R"][()]
        f["done"][1] = 0
        f["R"][1] = np.nan
        f.attrs["vrsweep_complete"] = np.int32(0)
    link = tmp_path / "link.h5"
    link.symlink_to(partial.name)
    result = invoke("run", inputs / "sweep.yaml", "-o", link, "--resume", "-q")
    assert result.exit_code == 0, result.output
    assert os.path.islink(link) and os.readlink(link) == partial.name
    with h5py.File(partial) as f:
        assert int(f.attrs["vrsweep_complete"]) == 1
        np.testing.assert_array_equal(f["R"][()], expected_R)  # the same point, the same bits


CONTINUATION = """\
model: effective
parameters: {gamma: 0.05, alpha: 0.05, Omega: 4.0}
initial: {x: 0.0, v: 0.0}
continuation: {parameter: g, from: 23.0, to: [22.0, 24.0]}
"""


@pytest.mark.parametrize("kind", ["config", "link_to_config", "branch", "link_to_branch", "sweep", "fifo", "device"])
def test_continue_follows_the_one_rule_of_outputs(tmp_path, inputs, invoke, kind):
    """continue wrote through its own rule (store/branch_file.writable_output, now gone): `-o` its own config,
    the --start sweep or the branch file being followed, with --overwrite, replaced it with the
    result, and `-o /dev/null --overwrite` (run as root) replaced the device with a regular file.
    Every refusal comes before anything is integrated, so no kernel is compiled here."""
    from handmade import write_branch_file

    config = tmp_path / "c.yaml"
    config.write_text(CONTINUATION)
    branch = write_branch_file(tmp_path / "branch.h5")
    sweep = tmp_path / "sweep.h5"
    shutil.copy(inputs / "good.h5", sweep)
    fifo = tmp_path / "fifo.h5"
    os.mkfifo(fifo)
    link = tmp_path / "link.h5"
    if kind in ("link_to_config", "link_to_branch"):
        link.symlink_to(config.name if kind == "link_to_config" else branch.name)
    out = {"config": config, "link_to_config": link, "branch": branch, "link_to_branch": link, "sweep": sweep,
           "fifo": fifo, "device": os.devnull}[kind]
    if kind in ("branch", "link_to_branch"):
        args = ["continue", branch, "--point", "0", "--along", "Omega", "--to", "3.9", "4.1"]
    elif kind == "sweep":
        args = ["continue", config, "--start", sweep, "--at", "g=20"]
    else:
        args = ["continue", config]
    before = {path: path.read_bytes() for path in (config, branch, sweep)}
    result = invoke(*args, "-o", out, "--overwrite", "-q")
    assert result.exit_code == 2, result.output
    assert len(result.output.strip().splitlines()) == 1, result.output
    assert "choose another output" in result.output, result.output
    for path, contents in before.items():
        assert path.read_bytes() == contents
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode) and stat.S_ISCHR(os.stat(os.devnull).st_mode)
