"""`vrsweep run` and `vrsweep validate` start as fast as before the reading side moved to xarray:
neither imports xarray (nor h5netcdf, nor pandas, which xarray brings). Checked in a fresh
interpreter that runs both commands, as a user's shell does."""

import os
import subprocess
import sys
import textwrap

READING_ONLY = ("xarray", "h5netcdf", "pandas")

CHILD = textwrap.dedent("""
    import sys
    from vrsweep.cli import main

    for args in (["validate", sys.argv[1]], ["run", sys.argv[1], "-o", sys.argv[2], "-q"]):
        try:
            main(args, prog_name="vrsweep")
        except SystemExit as exit:
            assert not exit.code, (args, exit.code)
    print("imported:", *sorted({name.split(".")[0] for name in sys.modules} & set(sys.argv[3:])))
""")


def test_run_and_validate_do_not_import_the_reading_side(tmp_path):
    config = tmp_path / "tiny.yaml"
    config.write_text("sweep:\n  g: [5.0, 10.0]\n"
                      "integration: {transient_periods: 2, measure_periods: 3, strobe_periods: 1}\n")
    out = tmp_path / "tiny.h5"
    child = subprocess.run([sys.executable, "-c", CHILD, str(config), str(out), *READING_ONLY],
                           capture_output=True, text=True, env=dict(os.environ), timeout=600)
    assert child.returncode == 0, child.stderr
    assert out.exists()  # the run did run
    assert child.stdout.strip().splitlines()[-1] == "imported:", child.stdout


VALIDATE_ONLY = textwrap.dedent("""
    import sys
    from vrsweep.cli import main

    for path in sys.argv[1:]:
        try:
            main(["validate", path], prog_name="vrsweep")
        except SystemExit as exit:
            print("exit", path, exit.code)
    print("numba imported:", "numba" in sys.modules)
""")
CONTINUATIONS = {  # (config, exit code of validate)
    "effective.yaml": ("model: effective\nparameters: {gamma: 0.05, alpha: 0.05}\n"
                       "continuation: {parameter: g, from: 23.0, to: [21.0, 27.0]}\n", 0),
    "original.yaml": ("parameters: {Omega: 4.3}\ncontinuation: {parameter: g, from: 5.0, to: [4.0, 6.0]}\n", 0),
    "incommensurate.yaml": ("parameters: {Omega: 4.3001}\ncontinuation: {parameter: g, from: 5.0, to: [4.0, 6.0]}\n", 2),
    "outside.yaml": ("model: effective\ncontinuation: {parameter: g, from: 30.0, to: [21.0, 27.0]}\n", 2),
}


def test_validate_of_a_continuation_section_does_not_import_numba(tmp_path):
    """Issue 35: validate checks the section as continue does (its commensurability rule too),
    without the numerics: it starts in a fraction of a second, whatever the config holds."""
    paths = []
    for name, (text, _) in CONTINUATIONS.items():
        (tmp_path / name).write_text(text)
        paths.append(str(tmp_path / name))
    child = subprocess.run([sys.executable, "-c", VALIDATE_ONLY, *paths], capture_output=True, text=True,
                           env=dict(os.environ), timeout=300)
    assert "Traceback" not in child.stderr, child.stderr
    codes = {line.split()[1]: int(line.split()[2]) for line in child.stdout.splitlines() if line.startswith("exit ")}
    assert codes == {str(tmp_path / name): code for name, (_, code) in CONTINUATIONS.items()}, child.stdout
    assert "Omega/omega = 43001/5000" in child.stderr or "Omega/omega = 8.6002" in child.stderr, child.stderr
    assert child.stdout.strip().splitlines()[-1] == "numba imported: False", child.stdout
