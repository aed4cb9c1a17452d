"""The README's "Results in Python" snippets, run as written, in order, on the files their
comments name (made here by the same commands, on smaller grids and shorter windows)."""

import os
import re
from pathlib import Path

import pytest

pytest.importorskip("xarray")

ROOT = Path(__file__).resolve().parent.parent
SHORT = ("--set", "transient_periods=2", "--set", "measure_periods=2", "--set", "strobe_periods=2")


def readme_snippets():
    text = (ROOT / "README.md").read_text()
    section = text.split("## Results in Python", 1)[1].split("\n## ", 1)[0]
    return re.findall(r"```python\n(.*?)```", section, flags=re.S)


def test_the_section_has_a_snippet_for_each_way_in():
    joined = "\n".join(readme_snippets())
    for needle in ("vrsweep.open_results(", ".sel(Omega=4)", ".plot(", ".to_dataframe()", "h5py.File("):
        assert needle in joined, needle


def test_every_snippet_runs(tmp_path, monkeypatch, invoke, write_config):
    monkeypatch.chdir(tmp_path)
    assert invoke("run", ROOT / "configs" / "quickstart.yaml", "-o", "quickstart.h5", "--quiet", *SHORT).exit_code == 0
    small_map = write_config(tmp_path, """\
        model: original
        sweep:
          g: {start: 0.0, stop: 60.0, num: 5}
          Omega: {start: 3.0, stop: 6.0, num: 7}
        """, name="map.yaml")
    os.makedirs("results")
    assert invoke("run", small_map, "-o", "results/map_g_Omega.h5", "--quiet", *SHORT).exit_code == 0
    result = invoke("simulate", ROOT / "configs" / "fig3.yaml", "--compare", "effective", "-o", "traj.h5")
    assert result.exit_code == 0, result.output
    for number, code in enumerate(readme_snippets(), 1):
        exec(compile(code, f"README.md Results in Python, snippet {number}", "exec"), {})
    assert Path("map_g_Omega.csv").read_text().startswith("g,Omega,R,R_err,period")
    assert Path("R_map.png").stat().st_size > 0
