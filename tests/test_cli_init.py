"""``vrsweep init``: starter configs from the shipped examples (issue 10)."""

from pathlib import Path

import pytest

from vrsweep.commands.init import description, shipped_examples
from vrsweep.config import load_config

REPOSITORY = Path(__file__).resolve().parent.parent
CONFIGS = REPOSITORY / "configs"


def test_configs_is_the_package_folder_so_there_is_one_copy():
    assert CONFIGS.is_symlink() and CONFIGS.resolve() == (REPOSITORY / "vrsweep" / "examples").resolve()
    names = {path.stem for path in CONFIGS.glob("*.yaml")}
    assert names == set(shipped_examples()) and "quickstart" in names


def test_list_names_every_example_with_its_first_sentence(invoke):
    # A terminal wide enough for the whole sentence (the list cuts lines to the terminal's width,
    # which is 80 in a pytest-xdist worker and whatever the developer's window is).
    result = invoke("init", "--list", env={"COLUMNS": "200"})
    assert result.exit_code == 0, result.output
    lines = result.stdout.splitlines()[1:]
    assert [line.split()[0] for line in lines] == list(shipped_examples())
    assert lines[0].split()[:2] == ["quickstart", "run"]
    first_comment = (CONFIGS / "quickstart.yaml").read_text().splitlines()[0].lstrip("# ")
    assert first_comment.split(".")[0] in lines[0]
    fig3 = next(line for line in lines if line.split()[0] == "fig3")
    assert fig3.split()[1] == "simulate"  # a trajectory example says which command runs it


def test_list_with_an_example_describes_that_one_in_full(invoke, tmp_path, monkeypatch):
    # --example was ignored with --list: the whole list came back, as if it had not been given
    monkeypatch.chdir(tmp_path)
    result = invoke("init", "--list", "--example", "fig1")
    assert result.exit_code == 0, result.output
    lines = result.stdout.splitlines()
    assert lines[0] == "fig1 (run):" and lines[-1] == "Write it with: vrsweep init --example fig1 [PATH]"
    comment = [line.lstrip("# ").strip() for line in (CONFIGS / "fig1.yaml").read_text().splitlines()
               if line.startswith("#")]
    shown = " ".join(result.stdout.split())
    assert comment[1] and comment[1] in shown  # beyond the first sentence
    assert "vrsweep run fig1.yaml" in shown and "configs/" not in shown  # the file init writes
    assert not list(tmp_path.iterdir())  # nothing written


@pytest.mark.parametrize("extra, named", [(["mine.yaml"], "PATH mine.yaml"), (["--overwrite"], "--overwrite")])
def test_list_refuses_what_it_would_ignore(extra, named, invoke, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    result = invoke("init", "--list", *extra)
    assert result.exit_code == 2 and f"--list writes nothing, so {named} would be ignored" in result.output
    assert "Traceback" not in result.output and not list(tmp_path.iterdir())


def test_list_with_an_unknown_example_is_refused(invoke):
    result = invoke("init", "--list", "--example", "nope")
    assert result.exit_code == 2 and "--example nope: no such example" in result.output


def test_description_is_the_first_sentence_cut_at_a_word():
    text = "# Paper Fig. 7: one thing. Then another.\n#\n# More.\nmodel: original\n"
    assert description(text) == "Paper Fig. 7: one thing"
    assert description(text, width=20) == "Paper Fig. 7: one..."
    assert description(text, width=19) == "Paper Fig. 7..."


def test_default_is_the_quickstart_and_it_validates_and_runs(tmp_path, monkeypatch, invoke):
    monkeypatch.chdir(tmp_path)
    result = invoke("init")
    assert result.exit_code == 0, result.output
    written = tmp_path / "quickstart.yaml"
    shipped = (CONFIGS / "quickstart.yaml").read_text()
    def words(text):  # the comments after a command are re-aligned
        return [line.split() for line in text.splitlines()]

    assert words(written.read_text()) == words(shipped.replace("configs/quickstart.yaml", "quickstart.yaml"))
    assert written.read_text().startswith("#")  # commented
    assert "run it with: vrsweep run quickstart.yaml" in result.stderr
    assert invoke("validate", "quickstart.yaml").exit_code == 0
    run = invoke("run", "quickstart.yaml", "-q", "--set", "transient_periods=2", "--set", "measure_periods=2",
                 "--set", "strobe_periods=2")
    assert run.exit_code == 0, run.output
    assert (tmp_path / load_config(written).output).exists()


@pytest.mark.parametrize("name", list(shipped_examples()))
def test_every_example_written_by_init_validates(name, tmp_path, monkeypatch, invoke):
    monkeypatch.chdir(tmp_path)
    result = invoke("init", "--example", name, "mine.yaml")
    assert result.exit_code == 0, result.output
    text = (tmp_path / "mine.yaml").read_text()
    assert f"configs/{name}.yaml" not in text  # its comments name the new file
    assert invoke("validate", "mine.yaml").exit_code == 0
    output = load_config(tmp_path / "mine.yaml").output_path()
    assert output.parent.is_dir()  # e.g. results/: run can write there


def test_never_overwrites_without_the_flag(tmp_path, monkeypatch, invoke):
    monkeypatch.chdir(tmp_path)
    target = tmp_path / "quickstart.yaml"
    target.write_text("# mine\n")
    result = invoke("init")
    assert result.exit_code == 2 and "--overwrite" in result.stderr and "already exists" in result.stderr
    assert target.read_text() == "# mine\n"
    assert invoke("init", "--overwrite").exit_code == 0 and target.read_text() != "# mine\n"


def test_path_options_and_unknown_example(tmp_path, invoke):
    (tmp_path / "dir").mkdir()
    assert invoke("init", "-e", "fig2.yaml", tmp_path / "dir").exit_code == 0
    assert (tmp_path / "dir" / "fig2.yaml").exists()  # a directory gets NAME.yaml
    result = invoke("init", "-e", "fig7", tmp_path / "x.yaml")
    assert result.exit_code == 2 and "fig7" in result.stderr and "quickstart" in result.stderr
    result = invoke("init", tmp_path / "missing" / "x.yaml")
    assert result.exit_code == 2 and "does not exist" in result.stderr
    assert not (tmp_path / "x.yaml").exists()


def _quoted_commands():
    """(example, line, argv) for every `vrsweep ...` command in the shipped examples' comments."""
    import shlex

    for name, resource in shipped_examples().items():
        for line in resource.read_text(encoding="utf-8").splitlines():
            if not line.startswith("#"):
                break
            if line.lstrip("#").strip().startswith("vrsweep "):
                yield name, line, shlex.split(line.lstrip("#"), comments=True)[1:]


QUOTED = list(_quoted_commands())


def test_the_examples_quote_commands():
    assert len(QUOTED) > 20 and {argv[0] for _, _, argv in QUOTED} >= {"run", "plot", "simulate", "theory"}


@pytest.mark.parametrize("example, line, argv", QUOTED, ids=[f"{name}:{argv[0]}" for name, _, argv in QUOTED])
def test_every_command_quoted_in_an_example_parses(example, line, argv):
    """Each command the examples' comments show is one click accepts (options, --kind choices),
    and a command that reads a config accepts its --set overrides for that config (a result file
    it names need not exist: the check parses, it does not run)."""
    import click

    from vrsweep.cli import main
    from vrsweep.execution.simulate import check_single_point

    command = main.commands[argv[0]]
    try:
        context = command.make_context(argv[0], list(argv[1:]))
    except click.ClickException as error:  # click.UsageError, BadParameter: a quoted command that fails
        pytest.fail(f"{example}.yaml: {line.strip()}: {error.format_message()}")
    if "config_path" in context.params:
        config_path = context.params["config_path"]
        assert config_path.startswith("configs/"), line  # init rewrites these paths for the new file
        config = load_config(REPOSITORY / config_path, context.params.get("overrides", ()))
        if argv[0] == "simulate":
            check_single_point(config)


@pytest.mark.parametrize("name", list(shipped_examples()))
def test_init_names_the_command_that_runs_the_example_itself(name, tmp_path, monkeypatch, invoke):
    # continuation_hysteresis.yaml's comments first run the hysteresis sweep it reads: init said
    # "run it with: vrsweep run configs/hysteresis_effective.yaml ..." (another example, not in the
    # user's folder) and --list called it a `run` example; fig1_continue.yaml the same.
    import shlex

    monkeypatch.chdir(tmp_path)
    (tmp_path / "my dir").mkdir()
    result = invoke("init", "--example", name, "my dir/mine.yaml")
    assert result.exit_code == 0, result.output
    command = shlex.split(result.stderr.split("run it with: ", 1)[1].splitlines()[0])
    assert command[2] == "my dir/mine.yaml", command
    config = load_config(tmp_path / "my dir" / "mine.yaml")
    continuation_only = config.continuation is not None and not config.axes
    assert command[1] == "continue" if continuation_only else command[1] in ("run", "simulate"), command
    listed = invoke("init", "--list", env={"COLUMNS": "200"})
    line = next(line for line in listed.stdout.splitlines() if line.split()[0] == name)
    assert line.split()[1] == command[1], line
