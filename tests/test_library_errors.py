"""The library words its errors without command-line flags; the commands add them (issue 11)."""

import pytest

from vrsweep.errors import InvalidArgument, UsageError
from vrsweep.execution.job import FailureAdvice, JobReport, parse_shard
from vrsweep.results import Status


@pytest.mark.parametrize("text, env, words", [
    ("x", {}, "shard x: expected I/N (e.g. 0/8) or 'auto'"),
    ("3/3", {}, "shard 3/3: shard index 3 is not in 0..2"),
    ("auto", {}, "shard auto: needs SLURM_ARRAY_TASK_ID and SLURM_ARRAY_TASK_COUNT"),
])
def test_a_bad_shard_is_worded_for_the_library_and_for_the_option(text, env, words):
    with pytest.raises(InvalidArgument) as caught:
        parse_shard(text, env)
    assert str(caught.value).startswith(words)
    assert "--shard" not in str(caught.value)
    worded = caught.value.as_option("--shard")
    assert isinstance(worded, UsageError) and worded.exit_code == 2
    assert str(worded) == "--" + str(caught.value)  # "--shard x: ..." as the run command always said


def test_a_bad_dask_address_is_worded_without_the_flag():
    from vrsweep.execution.distributed import parse_local

    with pytest.raises(InvalidArgument) as caught:
        parse_local("local:0")
    assert str(caught.value) == "Dask address local:0: expected local:N with N >= 1 workers (e.g. local:4)"
    assert str(caught.value.as_option("--dask")) == "--dask local:0: expected local:N with N >= 1 workers (e.g. local:4)"


def test_the_advice_for_steps_too_small_names_extreme_parameters_too():
    """c = 1e300 ends every point step_too_small; loosening the tolerances, the only advice, cannot help."""
    from types import SimpleNamespace

    from vrsweep.execution.job import _remedy

    advice, setting = _remedy(Status.STEP_TOO_SMALL, SimpleNamespace(rtol=1e-9, atol=1e-11))
    assert advice.startswith("loosen integration.rtol/atol (now 1e-09/1e-11), unless the parameters") and setting is None
    assert "extreme" in advice


def test_failure_advice_is_data_the_command_words():
    from types import SimpleNamespace

    integration = SimpleNamespace(max_steps=500, max_impacts_per_period=10, stick_velocity=1e-7,
                                  divergence_bound=1e6, rtol=1e-9, atol=1e-11)
    report = JobReport("out.h5", 100, 100, {Status.OK: 50, Status.MAX_STEPS: 48, Status.DIVERGED: 2}, integration)
    # 2 of 100 diverged is under FAILURE_ADVICE_FRACTION: no advice for it
    assert report.advice() == [FailureAdvice(Status.MAX_STEPS, 48, 100, "raise integration.max_steps (now 500)",
                                             "max_steps=5000")]
