"""Paths as typed: an empty one, one through '..' past a folder that is missing or a link, and
environment variables in a config's ``output``: docs/faults.md, the table's rows on paths."""

import os

import pytest

import vrsweep
from vrsweep.errors import ResultFileError, UsageError

TINY = """
model: effective
sweep:
  g: [0.0, 10.0]
integration: {transient_periods: 2, measure_periods: 16}
"""


@pytest.mark.parametrize("args", [
    ("run", "CONFIG", "-o", ""), ("simulate", "CONFIG", "--set", "g=1", "-o", ""), ("continue", "CONFIG", "-o", ""),
    ("plot", "CONFIG", "-o", ""), ("merge", "CONFIG", "-o", ""), ("init", ""), ("info", ""), ("run", ""),
    ("validate", ""), ("merge", "", "-o", "m.h5"),
])
def test_an_empty_path_is_refused_by_name(tmp_path, monkeypatch, write_config, invoke, args):
    # run -o '' wrote at "." ("output . is a directory"), plot -o '' and init '' took it as no path
    # at all (the default figure, quickstart.yaml), merge -o '' failed writing, exit 1.
    _refused_before_writing(tmp_path, monkeypatch, write_config, invoke, args, "an empty path names no file")


def _refused_before_writing(tmp_path, monkeypatch, write_config, invoke, args, words):
    """The command (CONFIG: a small sweep's config) exits 2 saying ``words`` and writes nothing."""
    monkeypatch.chdir(tmp_path)
    config = write_config(tmp_path, TINY)
    result = invoke(*[config if a == "CONFIG" else a for a in args])
    assert result.exit_code == 2, result.output
    assert words in result.output, result.output
    assert sorted(os.listdir(tmp_path)) == ["sweep.yaml"]


def test_an_empty_path_in_the_api_is_refused(tmp_path):
    with pytest.raises(ResultFileError, match="empty path"):
        vrsweep.open_results("")
    with pytest.raises(UsageError, match="output is an empty path"):
        vrsweep.sweep(TINY, output="", progress=False)


def test_a_path_through_a_missing_folder_and_dotdot(tmp_path, monkeypatch, invoke):
    # x/../c.yaml: every check read the folder lexically (".") and passed; the system, which opens
    # x first, refused (init: "directory x/.. does not exist"; run: "cannot create", exit 1).
    monkeypatch.chdir(tmp_path)
    result = invoke("init", "x/../c.yaml")
    assert result.exit_code == 0, result.output
    assert (tmp_path / "c.yaml").is_file() and not (tmp_path / "x").exists()
    result = invoke("run", "c.yaml", "--set", "g=1", "--set", "transient_periods=2",
                    "--set", "measure_periods=16", "-o", "x/../y.h5", "-q")
    assert result.exit_code == 0, result.output
    assert (tmp_path / "y.h5").is_file() and not (tmp_path / "x").exists()
    assert invoke("run", "c.yaml", "--set", "g=1", "--set", "transient_periods=2",
                  "--set", "measure_periods=16", "-o", "x/../y.h5", "-q", "--resume").exit_code == 0


def test_a_path_through_a_link_and_dotdot_goes_where_the_system_goes(tmp_path, monkeypatch, invoke):
    # link/../c.yaml is other/c.yaml to the system; the checks and the temporary file went to ./
    (tmp_path / "other" / "d").mkdir(parents=True)
    (tmp_path / "work").mkdir()
    os.symlink(tmp_path / "other" / "d", tmp_path / "work" / "link")
    monkeypatch.chdir(tmp_path / "work")
    result = invoke("init", "link/../c.yaml")
    assert result.exit_code == 0, result.output
    assert (tmp_path / "other" / "c.yaml").is_file()
    assert sorted(os.listdir(tmp_path / "work")) == ["link"]


def test_environment_variables_in_the_config_output(tmp_path, monkeypatch, write_config, invoke):
    # "$VRS_OUT/x.h5" made a folder named "$VRS_OUT" in the current directory (docs/config.md).
    monkeypatch.chdir(tmp_path)
    config = write_config(tmp_path, TINY + "output: $VRS_OUT/${VRS_NAME}_$$.h5\n")
    monkeypatch.delenv("VRS_OUT", raising=False)
    monkeypatch.setenv("VRS_NAME", "map")
    for command in ("validate", "run"):
        result = invoke(command, config, "-q") if command == "run" else invoke(command, config)
        assert result.exit_code == 2, result.output
        assert "sweep.yaml:6: output: '$VRS_OUT/${VRS_NAME}_$$.h5' uses the environment variable VRS_OUT, " \
               "which is not set" in result.output, result.output
    assert sorted(os.listdir(tmp_path)) == ["sweep.yaml"]
    (tmp_path / "out").mkdir()
    monkeypatch.setenv("VRS_OUT", str(tmp_path / "out"))
    result = invoke("run", config, "-q")
    assert result.exit_code == 0, result.output
    assert os.listdir(tmp_path / "out") == ["map_$$.h5"]  # a $ before no name stays
    with vrsweep.open_results(tmp_path / "out" / "map_$$.h5") as ds:
        assert "output: \"$VRS_OUT/${VRS_NAME}_$$.h5\"" in ds.attrs["config"]  # stored as written


@pytest.mark.parametrize("args", [("info", "PIPE"), ("plot", "PIPE"), ("merge", "PIPE", "-o", "m.h5"),
                                  ("info", "/dev/zero"), ("plot", "/dev/zero")])
def test_a_pipe_or_a_device_as_a_file_to_read_is_refused(tmp_path, monkeypatch, vrsweep_process, args):
    # info FIFO waited forever inside HDF5's open; /dev/zero was "empty (0 bytes)". A real
    # process, so that a hang is a timeout here, not a stuck test run.
    monkeypatch.chdir(tmp_path)
    os.mkfifo(tmp_path / "pipe")
    process = vrsweep_process(*[tmp_path / "pipe" if a == "PIPE" else a for a in args])
    try:
        _, err = process.communicate(timeout=60)
    finally:
        process.kill()
    assert process.returncode == 2, err
    assert "is not a regular file (a device, a pipe or a socket), so not a vrsweep file" in err, err
    assert "Traceback" not in err
    with pytest.raises(ResultFileError, match="not a regular file"):
        vrsweep.open_results(tmp_path / "pipe")


@pytest.mark.parametrize("args", [("run", "CONFIG", "-o", "out.h5/."), ("plot", "CONFIG", "-o", "fig.png/."),
                                  ("simulate", "CONFIG", "--set", "g=1", "-o", "t.h5/.")])
def test_a_path_ending_in_slash_dot_names_a_folder(tmp_path, monkeypatch, write_config, invoke, args):
    # pathlib drops a trailing '/.' as it drops '/': run -o out.h5/. wrote a file out.h5
    _refused_before_writing(tmp_path, monkeypatch, write_config, invoke, args, "ends in '/.', which names a folder")


def test_a_config_output_ending_in_slash_dot_names_a_folder(tmp_path, write_config, invoke):
    config = write_config(tmp_path, TINY + "output: out.h5/.\n")
    result = invoke("validate", config)
    assert result.exit_code == 2, result.output
    assert "sweep.yaml:6: output: must name a file, got 'out.h5/.', which ends in '/.' (a folder): give the " \
           "file's name, e.g. out.h5/results.h5" in result.output, result.output


@pytest.mark.parametrize("output, variable", [("$VRS_OUT/x.h5", "VRS_OUT"), ("${VRS_OUT}/x.h5", "VRS_OUT"),
                                              ("~/x.h5", "HOME")])
def test_an_empty_variable_in_the_config_output_is_refused(output, variable, tmp_path, monkeypatch,
                                                           write_config, invoke):
    """A variable set but empty left the path's start empty, as an unset one would have: "/x.h5",
    and `run` wrote its results at the file system's root (an export in a job script that found
    nothing, SCRATCH=""; HOME="" for ~, which expanduser reads as the home folder "")."""
    monkeypatch.chdir(tmp_path)
    config = write_config(tmp_path, TINY + f"output: {output}\n")
    monkeypatch.setenv(variable, "")
    if variable == "VRS_OUT":
        words = f"uses the environment variable {variable}, which is empty"
    else:
        words = "starts with ~, the home folder, but HOME is empty"
    for command in ("validate", "run"):
        result = invoke(command, config, "-q") if command == "run" else invoke(command, config)
        assert result.exit_code == 2, result.output
        assert f"sweep.yaml:6: output: '{output}' {words}" in result.output, result.output
        assert len(result.stderr.strip().splitlines()) == 1, result.stderr
    assert sorted(os.listdir(tmp_path)) == ["sweep.yaml"] and not os.path.exists("/x.h5")
