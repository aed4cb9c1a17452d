"""A result file whose derived dataset cannot be opened is corrupt, not a file without it.

h5py's ``Group.items()`` yields None for an object whose header fails its checksum (its
``get`` swallows the KeyError), so the reader used to skip the damaged dataset and
``vrsweep info`` succeeded on a file that had lost A_theory_stable (found with the issue-15
quickstart layout by tests/test_errors.py's byte-overwrite scan).
"""

import shutil

import h5py
import pytest

from vrsweep.errors import ResultFileError
from vrsweep.store.reading import open_results


def test_a_damaged_object_header_is_an_error(tmp_path, invoke):
    config = tmp_path / "small.yaml"
    config.write_text("model: effective\nsweep:\n  g: {start: 0, stop: 40, num: 5}\n"
                      "integration: {transient_periods: 2, measure_periods: 16}\n")
    good = tmp_path / "good.h5"
    assert invoke("run", config, "-o", good, "-q").exit_code == 0
    with h5py.File(good, "r") as f:
        header = h5py.h5o.get_info(f["A_theory_stable"].id).addr
    bad = tmp_path / "bad.h5"
    shutil.copy(good, bad)
    with open(bad, "r+b") as handle:  # inside the object header: its checksum no longer matches
        handle.seek(header + 16)
        handle.write(b"\xff" * 32)
    with pytest.raises(ResultFileError, match="corrupt"):
        open_results(bad)
    result = invoke("info", bad)
    assert result.exit_code == 2 and "corrupt" in result.output
