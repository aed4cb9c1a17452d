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
