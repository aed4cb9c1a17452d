"""--resume compares configs parsed, not as text: a checkpoint whose stored config text was written
by an earlier version (the hand-written emitter, before config/yaml.py wrote it through ruamel)
still resumes, bit for bit; one from a different config still refuses.

tests/data/resolved_config_hand_emitted.yaml is ``Config.to_yaml()`` of OLD_STYLE_SOURCE with
``--set alpha=0.125``, exactly as vrsweep 0.1.0 (main at d9a4c16) wrote it into result files.
"""

import signal
import textwrap
from pathlib import Path

import h5py
import numpy as np
import pytest

from vrsweep.config import parse_config, same_config
from vrsweep.errors import ResultFileError

HAND_EMITTED = (Path(__file__).resolve().parent / "data" / "resolved_config_hand_emitted.yaml").read_text(
    encoding="utf-8")
OLD_STYLE_SOURCE = textwrap.dedent("""\
    parameters: {Omega: 4.0}
    sweep:
      g: {start: 0.0, stop: 30.0, num: 6}
      e: [0.95, 0.8]
    integration: {transient_periods: 3, measure_periods: 3, strobe_periods: 2}
    output: "out\\té.h5"
    """)
OVERRIDES = ["alpha=0.125"]


def the_config():
    return parse_config(OLD_STYLE_SOURCE, "old.yaml", OVERRIDES)


def test_the_stored_old_text_is_the_same_config():
    config = the_config()
    assert same_config(HAND_EMITTED, config)
    assert parse_config(HAND_EMITTED) == config
    # Today's text for it differs (ruamel escapes the tab as \t, the old emitter wrote \x09), so
    # the file below resumes only because the configs are compared parsed.
    assert config.to_yaml() != HAND_EMITTED
    assert same_config(config.to_yaml(), config)
    # any spelling of the same config is the same config: another layout, order, comments, defaults
    respelled = textwrap.dedent("""\
        output: "out\\té.h5"
        integration: {strobe_periods: 2, measure_periods: 3, transient_periods: 3, rtol: 1.0e-9}
        sweep:
          g: {values: [0.0, 6.0, 12.0, 18.0, 24.0, 30.0]}   # the linspace, listed
          e: [0.95, 0.8]
        parameters: {Omega: 4, alpha: 0.125, gamma: 0.22}
        """)
    assert same_config(respelled, config)


def test_what_changes_no_point_is_not_compared():
    # A config given an output: key or a continuation section after its sweep stopped computes the
    # same points: --resume refused it ("first difference ... 'output: null' vs ...").
    config = the_config()
    moved = HAND_EMITTED.replace('output: "out\\x09\u00e9.h5"', 'output: "elsewhere.h5"')
    assert moved != HAND_EMITTED and same_config(moved, config)
    assert same_config(HAND_EMITTED + "continuation: {parameter: g, from: 10, to: [5, 20]}\n", config)


def test_a_run_resumes_after_its_config_gains_an_output_key(tmp_path, invoke, write_config):
    config = write_config(tmp_path, """\
        model: effective
        sweep:
          g: [1.0, 2.0, 3.0]
        integration: {transient_periods: 1, measure_periods: 2, strobe_periods: 1}
        """)
    out = tmp_path / "run.h5"
    assert invoke("run", config, "-o", out, "--shard", "0/3", "--quiet").exit_code == 0
    assert invoke("merge", tmp_path / "run.shard0of3.h5", "-o", out, "--allow-missing").exit_code == 0
    with open(config, "a", encoding="utf-8") as handle:
        handle.write("output: results/elsewhere.h5\n")
    done = invoke("run", config, "-o", out, "--resume", "--quiet")
    assert done.exit_code == 0, done.output
    with h5py.File(out, "r") as f:
        assert f["done"][()].all()


def test_another_config_is_not_the_same():
    config = the_config()
    assert not same_config(HAND_EMITTED.replace("alpha: 0.125", "alpha: 0.12"), config)
    assert not same_config(HAND_EMITTED.replace("num: 6", "num: 7"), config)
    assert not same_config(HAND_EMITTED.replace("  e: [0.95, 0.8]", "  e: [0.95, 0.9]"), config)
    assert not same_config("not: [a, config", config)  # unreadable: never the same
    assert not same_config("", config)  # the defaults, not this config


def _run_interrupted(config, out):
    """The first chunk of two lines written, then stopped as by Ctrl-C."""
    from vrsweep.execution.job import GracefulStop, Interrupted, run_job
    from vrsweep.execution.sweep import run_sweep

    def small_chunks(config, **kwargs):
        return run_sweep(config, chunk_lines=2, **kwargs)

    stop = GracefulStop()
    stop.signum = signal.SIGINT
    with pytest.raises(Interrupted):
        run_job(config, out, threads=1, stop=stop, executor=small_chunks)
    with h5py.File(out, "r") as f:
        assert int(f["done"][()].sum()) == 2


def _as_an_earlier_version_wrote_it(out):
    with h5py.File(out, "r+") as f:
        f.attrs["config"] = HAND_EMITTED
        del f.attrs["vrsweep_attributes_sha256"]  # attributes had no checksum then


def _contents(path):
    """Every dataset's bytes and every root attribute but when, how and as what text it was written."""
    skip = ("created", "date_created", "history", "config", "vrsweep_attributes_sha256")  # the last: of the text
    with h5py.File(path, "r") as f:
        attrs = {key: repr(value) for key, value in f.attrs.items() if key not in skip}
        data = {name: (ds.dtype.str, ds.shape, np.asarray(ds[()]).tobytes()) for name, ds in f.items()}
    return attrs, data


def test_a_checkpoint_holding_the_old_text_resumes_bit_identical(tmp_path):
    from vrsweep.execution.job import run_job

    config = the_config()
    out = tmp_path / "old.h5"
    _run_interrupted(config, out)
    _as_an_earlier_version_wrote_it(out)

    report = run_job(config, out, threads=1, resume=True)
    assert report.n_run == config.n_points - 2

    fresh = tmp_path / "fresh.h5"
    run_job(config, fresh, threads=2)
    assert _contents(out) == _contents(fresh)
    with h5py.File(out, "r") as f:
        assert f.attrs["config"] == HAND_EMITTED  # the file keeps the text it was created with


def test_a_checkpoint_holding_the_old_text_of_another_config_refuses(tmp_path):
    from vrsweep.execution.job import run_job

    config = the_config()
    out = tmp_path / "old.h5"
    _run_interrupted(config, out)
    _as_an_earlier_version_wrote_it(out)
    before = out.read_bytes()

    other = parse_config(OLD_STYLE_SOURCE, "old.yaml", ["alpha=0.25"])
    with pytest.raises(ResultFileError, match="different config") as caught:
        run_job(other, out, threads=1, resume=True)
    assert "alpha: 0.125" in str(caught.value)
    assert out.read_bytes() == before


@pytest.mark.parametrize("written_by", ["0.1.0", None])
def test_a_checkpoint_of_a_version_whose_points_differ_refuses_naming_it(tmp_path, written_by):
    # 0.2.0 decides impacts on each step's interpolant (issue 23): a 0.1.0 point differs from the
    # same point now, so a file of 0.1.0 (or of an unknown version) is not continued
    from vrsweep.execution.job import run_job

    config = the_config()
    out = tmp_path / "old.h5"
    _run_interrupted(config, out)
    with h5py.File(out, "r+") as f:
        if written_by is None:
            del f.attrs["vrsweep_version"]
        else:
            f.attrs["vrsweep_version"] = written_by
    before = out.read_bytes()
    with pytest.raises(ResultFileError, match="written by vrsweep " + (written_by or r"\(unknown version\)")):
        run_job(config, out, threads=1, resume=True)
    assert out.read_bytes() == before


@pytest.mark.parametrize("written_by", ["0.7.0", "0.7.1", "0.7.2", "0.7.3", "0.7.4", "0.7.5", "0.7.6", "0.7.7",
                                        "0.7.8", "0.7.9", "0.7.10", "0.7.13", "0.7.14", "0.7.17"])
def test_a_checkpoint_of_070_refuses_naming_what_changed(tmp_path, written_by):
    """0.7.1 reads a periodic point's R over whole cycles of the response frequency too, 0.7.2
    takes R_err from the spread of |Q| (its last digits), 0.7.3 sticks a rebound whose flight
    is below rounding, 0.7.4 locates a written model's kinks and 0.7.5 its jumps, with a frozen
    mode, 0.7.6 jumps the tangent vectors there, 0.7.7 slides on them, 0.7.8 leaves a slide on a
    short step, 0.7.9 slides from the arrival, 0.7.10 counts a slide's first fields in n_rhs and
    0.7.14 holds a fractional power of a kink beyond its surface, 0.7.18 lets a stuck mass go only where
    the force pulls it away: a checkpoint of any is not this
    version's, so it is not continued; the message names the latest change."""
    from vrsweep.execution.job import run_job

    config = the_config()
    out = tmp_path / "old.h5"
    _run_interrupted(config, out)
    with h5py.File(out, "r+") as f:
        f.attrs["vrsweep_version"] = written_by
    before = out.read_bytes()
    with pytest.raises(ResultFileError, match=f"written by vrsweep {written_by}.*where the force at rest on its stop"
                                              ".*since 0.7.18"):
        run_job(config, out, threads=1, resume=True)
    assert out.read_bytes() == before
