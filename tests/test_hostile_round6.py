"""Round 6 of the hostile inputs: files that are not what their names (or a command) take them
for, the theory at parameters beyond a double's range, and a written model's caption of forty
parameters."""

import os

import pytest

from test_hostile_round5 import _written_branch_file


# --------------------------------------------------------------------------------------------
# init: what it writes is a config, named as one
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("name", ["x.h5", "config", "x.yaml.h5", "fig.png"])
def test_init_refuses_a_name_that_is_no_configs(tmp_path, invoke, name):
    """`vrsweep init x.h5` wrote the quickstart's YAML into a file named x.h5 (and `init config`
    into a file with no suffix)."""
    result = invoke("init", tmp_path / name)
    assert result.exit_code == 2, result.output
    assert result.output.strip() == (f"Error: PATH {tmp_path / name}: a config is YAML, named .yaml or .yml: give a "
                                     "name ending in one of them (or a folder that exists, to write "
                                     "quickstart.yaml into it)")
    assert os.listdir(tmp_path) == []


@pytest.mark.parametrize("name", ["c.yaml", "c.yml", "C.YAML"])
def test_init_writes_a_name_that_is_a_configs(tmp_path, invoke, name):
    result = invoke("init", tmp_path / name)
    assert result.exit_code == 0, result.output
    assert (tmp_path / name).read_text().startswith("# Quickstart")


