"""Text from outside in one line: a file name, a YAML key or a setting holding a newline, a
carriage return, a terminal escape or a byte that is not UTF-8 is shown escaped wherever vrsweep
quotes it (errors, notices, `info`), so that one problem stays one line (docs/faults.md)."""

import os
import shutil

import pytest

from vrsweep.errors import one_line

TINY = """
model: effective
integration: {transient_periods: 2, measure_periods: 16}
"""


@pytest.mark.parametrize("raw, shown", [
    ("a\nb", "a\\nb"), ("a\rb", "a\\rb"), ("a\tb", "a\\tb"), ("\x1b[2J", "\\x1b[2J"), ("\x7f", "\\x7f"),
    ("\x85", "\\x85"), ("a\u2028b", "a\\u2028b"), ("\u202eevil", "\\u202eevil"),
    ("\udcff.h5", "\\xff.h5"),  # os.fsdecode of the byte 0xff: as a file's history writes it
    ("ω Δ é ü ≤ ẋ", "ω Δ é ü ≤ ẋ"), ("plain: text (1, 2)", "plain: text (1, 2)"),
])
def test_one_line_escapes_what_breaks_a_line_and_keeps_the_rest(raw, shown):
    assert one_line(raw) == shown
    assert len(one_line(raw).splitlines()) == 1


def _lines(result):
    return result.output.splitlines()


@pytest.mark.parametrize("args", [("info", "a\nb.h5"), ("plot", "a\nb.h5"), ("validate", "a\nb.yaml"),
                                  ("run", "a\nb.yaml"), ("info", "a\rb.h5")])
def test_a_missing_file_whose_name_breaks_the_line_is_one_line(tmp_path, monkeypatch, invoke, args):
    # "Error: results file not found: a" and then "b.h5" on a line of its own
    monkeypatch.chdir(tmp_path)
    result = invoke(*args)
    assert result.exit_code == 2
    assert len(_lines(result)) == 1 and one_line(args[1]) in result.output, result.output


def test_each_problem_of_a_config_is_one_line(tmp_path, write_config, invoke):
    config = write_config(tmp_path, 'parameters: {"g\\nh": 5, "bad\\rkey": 1}\nintegration: {"x\\ty": 1}\n')
    result = invoke("validate", config)
    assert result.exit_code == 2
    lines = _lines(result)
    assert lines[0] == "Error: 3 problems:" and len(lines) == 4, result.output
    assert "parameters.g\\nh" in lines[1] and "parameters.bad\\rkey" in lines[2] and "integration.x\\ty" in lines[3]


def test_one_problem_with_a_newline_in_its_key_is_one_line(tmp_path, write_config, invoke):
    result = invoke("validate", write_config(tmp_path, 'parameters: {"g\\nOmega": 5}\n'))
    assert result.exit_code == 2 and len(_lines(result)) == 1 and "parameters.g\\nOmega: unknown key" in result.output


def test_info_of_a_file_whose_name_breaks_the_line(tmp_path, sweep_file, invoke):
    _, made = sweep_file(tmp_path, TINY)
    odd = tmp_path / "a\nb\x1b[2J.h5"
    shutil.copy(made, odd)
    result = invoke("info", odd)
    assert result.exit_code == 0
    first = _lines(result)[0]
    assert first.endswith("a\\nb\\x1b[2J.h5: vrsweep sweep, format 1, complete"), result.output
    assert "\x1b" not in result.output and _lines(result)[1].startswith("points:")


def test_the_result_line_and_notices_name_an_odd_output_in_one_line(tmp_path, write_config, invoke):
    config = write_config(tmp_path, TINY)
    output = tmp_path / "new\nfolder" / "o\r.h5"
    result = invoke("run", config, "-o", output)
    assert result.exit_code == 0 and output.exists()
    created = [line for line in _lines(result) if line.startswith("Created the output folder")]
    assert len(created) == 1 and created[0].endswith("new\\nfolder"), result.output
    assert _lines(result)[-1].endswith("-> " + one_line(str(output))), result.output


def test_a_click_refusal_of_vrsweeps_own_option_is_one_line(invoke):
    # `vrsweep --bogus` printed click's four lines (usage, hint, blank, error), as commands did
    result = invoke("--bogus")
    assert result.exit_code == 2 and len(_lines(result)) == 1, result.output
    assert result.output.startswith("Error: No such option '--bogus' (see ") and "--help)" in result.output


def test_a_click_refusal_quoting_a_newline_is_one_line(invoke):
    result = invoke("plot", "x.h5", "--kind", "a\nb")
    assert result.exit_code == 2 and len(_lines(result)) == 1 and "'a\\nb'" in result.output, result.output


LINE = """
model: effective
sweep:
  g: [1.0, 2.0, 3.0]
integration: {transient_periods: 2, measure_periods: 16}
"""


def test_a_figures_description_does_not_depend_on_where_the_canvas_broke_its_lines(tmp_path, sweep_file, invoke):
    # A PDF's Subject made each of the caption's line breaks a "; ": "γ = 0.22; α = 0.1" at one
    # size, "γ = 0.22,  α = 0.1" at another, and a long note broken mid-phrase ("the; barrier's").
    from vrsweep.plot.labels import read_description

    _, made = sweep_file(tmp_path, LINE)
    found = {}
    for size in ("3.5,3", "9,5"):
        for suffix in (".pdf", ".png", ".svg"):
            figure = tmp_path / f"f{size.replace(',', 'x')}{suffix}"
            assert invoke("plot", made, "-o", figure, "--size", size).exit_code == 0
            found[size, suffix] = read_description(figure)["Description"]
    first, *others = found.values()
    assert all(text.replace("\n", "; ") == first.replace("\n", "; ") for text in others), found
    title, _, caption = found["3.5,3", ".png"].partition("\n")
    assert title.startswith("Response gain R against g") and "\n" not in caption
    assert "γ = 0.22, α = 0.1, c = 0.04, ω0 = 0.1, ω = 0.5, Δ = 1, e = 0.95, Ω = 4, x(0) = 0.99, ẋ(0) = 0.5" in caption
    assert "the barrier's level" in caption


def test_a_wrapped_caption_keeps_its_items_on_one_line():
    from vrsweep.plot.labels import Wrapped, _wrap, caption_lines, plain_text

    items = ["file.h5", "a long item of many words " * 4, "$\\gamma$ = 0.22", "x = 1"]
    wrapped = _wrap(items, 30)
    assert "\n" in wrapped and plain_text(wrapped) == ", ".join(items)
    both = caption_lines(wrapped, Wrapped("curves:\nc.h5", "curves: c.h5"))
    assert plain_text(both) == ", ".join(items) + "\ncurves: c.h5" and str(both).count("\n") > 2
    assert plain_text("a note\nof its own") == "a note\nof its own"


ODD_VALUES = {"a number": 3, "an array": [1, 2], "bytes not UTF-8": b"\xff\xfe"}
# Attributes info reads for itself: as a number (R_solver_err_rtol), as text (a version), as
# codes (status's flag_values: text there failed int()); the rest it lists through the same
# conversion (info._json_ready).
READ_BY_INFO = (("/", "numba_version"), ("/", "R_solver_err_rtol"), ("status", "flag_values"))


def test_info_describes_a_file_whose_attributes_another_tool_wrote(tmp_path, sweep_file, invoke):
    # A file without a checksum (an earlier vrsweep's, or h5py's by hand) is read as it is, with one
    # note: numba_version written as a number failed json.dumps (info --json), R_solver_err_rtol
    # as '' or an array failed float() (info), each a traceback.
    import json

    import h5py
    import numpy as np

    _, made = sweep_file(tmp_path, LINE)
    for odd, value in ODD_VALUES.items():
        value = np.bytes_(value) if isinstance(value, bytes) else np.array(value) if isinstance(value, list) else value
        for owner, name in READ_BY_INFO:
            odd_file = tmp_path / f"{name}.h5"
            shutil.copy(made, odd_file)
            with h5py.File(odd_file, "r+") as f:
                del f.attrs["vrsweep_attributes_sha256"]
                f[owner].attrs[name] = value
            text, as_json = invoke("info", odd_file), invoke("info", odd_file, "--json")
            assert text.exit_code in (0, 2) and as_json.exit_code == text.exit_code, (name, odd, text.output)
            if text.exit_code == 2:  # refused: one line, naming the file
                assert len(text.output.strip().splitlines()) == 1 and odd_file.name in text.output, (name, text.output)
            else:
                json.loads(as_json.output[as_json.output.index("{"):])


@pytest.mark.parametrize("group, name, value, words", [
    ("/", "title", b"\xff\xfe", "attribute title must be text"),  # open_results: UnicodeDecodeError
    ("/", "numba_version", 5, "attribute numba_version must be text"),
    ("effective", "model", [1, 2], "attribute /effective.model must be text"),  # plot: unhashable type
    ("effective", "model", "original", "/effective is the run of another model ('original')"),
])
def test_a_trajectory_file_with_attributes_of_another_kind_is_refused_by_every_reader(
        tmp_path, write_config, invoke, group, name, value, words):
    # As a branch file's text attributes are checked where it is opened (branch_file._texts_are_text).
    import h5py
    import numpy as np

    import vrsweep
    from vrsweep.errors import ResultFileError

    trajectory = tmp_path / "traj.h5"
    config = write_config(tmp_path, TINY)
    assert invoke("simulate", config, "-o", trajectory, "-q").exit_code == 0
    with h5py.File(trajectory, "r+") as f:
        del f.attrs["vrsweep_attributes_sha256"]  # as an earlier vrsweep's file, or one made by hand
        f[group].attrs[name] = np.bytes_(value) if isinstance(value, bytes) else value
    for args in (("info", trajectory), ("info", trajectory, "--json"), ("plot", trajectory, "-o", tmp_path / "t.png")):
        result = invoke(*args)
        assert result.exit_code == 2 and result.output.strip().splitlines()[-1] == f"Error: {trajectory} is corrupt: {words}"
    with pytest.raises(ResultFileError, match="is corrupt: " + words.replace("(", r"\(").replace(")", r"\)")):
        vrsweep.open_results(trajectory)


@pytest.mark.parametrize("command", ["run", "simulate", "init"])
def test_a_link_into_a_missing_folder_is_refused_and_no_folder_is_made(tmp_path, monkeypatch, write_config, invoke,
                                                                        command):
    # A stale link (a purged scratch folder, a network mount not mounted): the folder was created
    # and the results written on whatever disk held the mount point.
    monkeypatch.chdir(tmp_path)
    config = write_config(tmp_path, TINY)
    gone = tmp_path / "mount" / "gone"
    link = tmp_path / ("out.yaml" if command == "init" else "out.h5")
    link.symlink_to(gone / link.name)
    args = {"run": ("run", config, "-o", link), "simulate": ("simulate", config, "-o", link),
            "init": ("init", link)}[command]
    result = invoke(*args)
    assert result.exit_code == 2 and len(result.output.strip().splitlines()) == 1, result.output
    assert f"the link's folder {gone} does not exist" in result.output
    assert not (tmp_path / "mount").exists() and os.path.islink(link)


def test_a_link_into_an_existing_folder_is_still_followed(tmp_path, write_config, invoke):
    config = write_config(tmp_path, TINY)
    (tmp_path / "there").mkdir()
    link = tmp_path / "out.h5"
    link.symlink_to(tmp_path / "there" / "x.h5")
    assert invoke("run", config, "-o", link, "-q").exit_code == 0
    assert (tmp_path / "there" / "x.h5").is_file() and os.path.islink(link)
