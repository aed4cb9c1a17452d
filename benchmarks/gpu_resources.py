"""The GPU line kernel's registers, stack frame and spills, this checkout against another, no GPU needed.

    python benchmarks/gpu_resources.py [/path/to/old/checkout]

For the paper's original model, a written model with a kink, a jump and a barrier, and a written
stick-slip model (its sliding motion followed), each method, with and without the tangent
vectors: the kernel as a run launches it (vrsweep.numerics.cuda's defaults), compiled to PTX for
sm_90 (cuda.compile_for, which needs no device) and assembled by ptxas -v (from the
cuda-toolkit[nvcc] wheels of the `test` extra). Each checkout runs in a process of its own with
its own numba cache. Spills are local-memory traffic in every step on a card: a change that adds
them where there were none is a change to measure there (benchmarks/gpu.py).
"""

import json
import os
import re
import subprocess
import sys
import tempfile
import textwrap
from pathlib import Path

HERE = Path(__file__).resolve().parent
NEW = HERE.parent

KINKED = """
model:
  acceleration: "-2*zeta*v - x - k*max(x - d, 0) - mu*sign(v) + F*cos(omega*t)"
  parameters: {zeta: 0.05, k: 3.0, d: 0.5, mu: 0.02, F: 1.0, omega: 0.8, Delta: 1.2, r: 0.8}
  barriers: [{position: Delta, side: above, restitution: r}]
  period: "2*pi/omega"
  response: {frequency: omega, scale: F}
"""
STICK_SLIP = """
model:
  acceleration: "-2*zeta*v - x - mu*sign(v - belt) + F*cos(omega*t)"
  parameters: {zeta: 0.05, mu: 0.6, F: 1.0, omega: 0.5, belt: 0.2}
  period: "2*pi/omega"
  response: {frequency: omega, scale: F}
"""
CASES = [("original", None), ("written, kink + jump + barrier", KINKED), ("written, stick-slip", STICK_SLIP)]


def measure():
    """{label: (registers, frame bytes, spill stores, spill loads)} for this process's vrsweep."""
    from cuda.pathfinder import find_nvidia_binary_utility

    from vrsweep.config import load_config
    from vrsweep.numerics import codegen, cuda, rhs

    ptxas = find_nvidia_binary_utility("ptxas")
    folder = Path(tempfile.mkdtemp())
    out = {}
    for name, text in CASES:
        if text is not None:
            config = folder / "model.yaml"
            config.write_text(textwrap.dedent(text))
            try:
                model = load_config(config).model
            except Exception as error:  # an old version without the feature (sliding before 0.7.7)
                print(f"{name}: {error}", file=sys.stderr)
                continue
        for method in ("rk45", "dop853"):
            for tangents in (False, True):
                if text is None:
                    functions = rhs.paper_functions(tangents)
                else:
                    functions = codegen.written_functions(codegen.compiled(model), tangents)
                ptx = cuda.compile_for(method, tangents, *functions)
                source = folder / "kernel.ptx"
                source.write_text(ptx)
                done = subprocess.run([ptxas, "-arch=sm_90", "-v", str(source), "-o", str(folder / "kernel.cubin")],
                                      capture_output=True, text=True, check=True)
                entry = (done.stderr + done.stdout)
                entry = entry[entry.index("Compiling entry function"):]
                registers = int(re.search(r"Used (\d+) registers", entry).group(1))
                frame = int(re.search(r"(\d+) bytes stack frame", entry).group(1))
                stores, loads = (int(n) for n in re.search(r"(\d+) bytes spill stores, (\d+) bytes spill loads",
                                                          entry).groups())
                label = f"{name} | {method} | {'tangents' if tangents else 'state'}"
                out[label] = (registers, frame, stores, loads)
                print(label, out[label], file=sys.stderr, flush=True)
    return out


def _child(checkout):
    env = dict(os.environ, PYTHONPATH=str(checkout), NUMBA_CACHE_DIR=tempfile.mkdtemp())
    done = subprocess.run([sys.executable, __file__, "--child"], capture_output=True, text=True, env=env,
                          cwd=checkout, check=True)
    return {key: tuple(value) for key, value in json.loads(done.stdout.strip().splitlines()[-1]).items()}


def main():
    if sys.argv[1:] == ["--child"]:
        import vrsweep

        print(json.dumps({"version": [vrsweep.__version__], **measure()}))
        return
    checkouts = [NEW] + [Path(path).resolve() for path in sys.argv[1:2]]
    results = [_child(checkout) for checkout in checkouts]
    header = "kernel | method | vectors"
    columns = [f"{result.pop('version')[0]}: registers, frame, spill stores/loads" for result in results]
    print(" | ".join([header, *columns]))
    for label in results[0]:
        cells = []
        for result in results:
            if label in result:
                registers, frame, stores, loads = result[label]
                cells.append(f"{registers}, {frame} B, {stores}/{loads} B")
            else:
                cells.append("-")
        print(" | ".join([label, *cells]))


if __name__ == "__main__":
    main()
