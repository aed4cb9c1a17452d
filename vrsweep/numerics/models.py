"""Which compiled kernels and coefficient vectors a config's model uses: one entry for the
paper's two models (model.py, kernel.py, lines.py) and for a written one (written.py, codegen.py).

    kernels_for(model).coefficients(parameters)     (..., n) vectors: coefficients.py's header first
    kernels_for(model).forcing_frequencies(vectors)  (..., K) every frequency of the forcing
    kernels_for(model).integrator(method, lyapunov)  one point (trajectory.simulate)
    kernels_for(model).monodromy(method)             one point with each period's tangent map
    kernels_for(model).run_lines(method, lyapunov)   the sweep's lines on the CPU's threads
    kernels_for(model).gpu_lines(method, lyapunov)   the same call, run on an NVIDIA GPU (cuda.py)
    kernels_for(model).is_cached(method, lyapunov, device)   whether the kernel compiles first (a hint)

``model`` is ``"original"``, ``"effective"`` or a written.WrittenModel (the config's ``model``).
"""

from __future__ import annotations

import numpy as np

from vrsweep.numerics import kernel, lines, rhs
from vrsweep.numerics.model import MODELS, kernel_coefficients
from vrsweep.numerics.written import WrittenModel


class PaperKernels:
    """The paper's family: eq2.1 (original) or eq2.10 (effective), hand-written right-hand sides."""

    def __init__(self, name):
        if name not in MODELS:
            raise ValueError(f"model must be one of {MODELS} or a written model, not {name!r}")
        self.name = name

    def coefficients(self, parameters):
        return kernel_coefficients(parameters, self.name)

    def forcing_frequencies(self, vectors):
        """omega and Omega (0 where g = 0): the two the header holds for dop853 (model.py)."""
        from vrsweep.numerics.coefficients import HARMONIC, N_HARMONICS

        return vectors[..., HARMONIC:HARMONIC + N_HARMONICS]

    def integrator(self, method, lyapunov=False):
        return kernel.integrator(method, lyapunov)

    def monodromy(self, method):
        return kernel.MONODROMY_INTEGRATORS[method]

    def run_lines(self, method, lyapunov=False):
        return lines.RUN_LINES[method, lyapunov]

    def is_cached(self, method, lyapunov=False, device="cpu"):
        if device == "cuda":
            return _gpu_is_cached(self, method, lyapunov)
        return lines.kernel_is_cached(method, lyapunov)

    def gpu_kernel(self, method, lyapunov=False):
        from vrsweep.numerics import cuda

        return cuda.line_kernel(method, lyapunov, *rhs.paper_functions(lyapunov),
                                gather=cuda.GATHER_LANES_BY_MODEL.get(self.name))

    def gpu_lines(self, method, lyapunov=False):
        from vrsweep.numerics import cuda

        return cuda.DeviceLines(self.gpu_kernel(method, lyapunov))


class WrittenKernels:
    """A written model's generated module (codegen.py), imported on first use."""

    def __init__(self, model: WrittenModel):
        self.model = model

    def coefficients(self, parameters):
        from vrsweep.numerics import codegen
        from vrsweep.numerics.coefficients import HARMONIC, N_HEADER, SCAN_STEP, STICK_SCAN_FRACTION
        from vrsweep.numerics.written import coefficients

        vectors = coefficients(self.model, parameters)
        module = codegen.compiled(self.model)
        # The frequencies whose phases dop853 rotates: found in the equation when it was generated.
        vectors[..., HARMONIC:HARMONIC + 2] = module.harmonic_frequencies(vectors[..., N_HEADER:])
        # The release scan of a stuck mass steps 1/64 of the shortest forcing period, as the paper's
        # models do: max_step / 8 alone (T / 64 by default) stepped over a pull of cos(9 omega t)
        # that lasted 0.03 rad, and the mass stayed stuck (stuck_fraction 0.216 for 0.196).
        frequencies = np.abs(module.forcing_frequencies(vectors[..., N_HEADER:]))
        if frequencies.shape[-1]:
            fastest = np.max(frequencies, axis=-1)
            with np.errstate(divide="ignore", invalid="ignore"):
                scan = np.where(fastest > 0.0, STICK_SCAN_FRACTION * (2.0 * np.pi) / fastest, np.inf)
            vectors[..., SCAN_STEP] = np.minimum(vectors[..., SCAN_STEP], scan)
        return vectors

    def forcing_frequencies(self, vectors):
        """Every frequency of the acceleration's sines and cosines, with or without a phase: more
        than the two dop853 rotates (HARMONIC), which are phase-free and the response's first."""
        from vrsweep.numerics import codegen
        from vrsweep.numerics.coefficients import N_HEADER

        return codegen.compiled(self.model).forcing_frequencies(vectors[..., N_HEADER:])

    def _function(self, name):
        from vrsweep.numerics import codegen

        return getattr(codegen.compiled(self.model), name)

    def integrator(self, method, lyapunov=False):
        return self._function(f"integrate_{method}{'_lyapunov' if lyapunov else ''}")

    def monodromy(self, method):
        return self._function(f"integrate_{method}_monodromy")

    def run_lines(self, method, lyapunov=False):
        return lines.ThreadedLines(self._function(f"run_lines_{method}{'_lyapunov' if lyapunov else ''}"))

    def is_cached(self, method, lyapunov=False, device="cpu"):
        from vrsweep.numerics import codegen

        if device == "cuda":
            return _gpu_is_cached(self, method, lyapunov)
        return codegen.is_cached(self.model, f"run_lines_{method}{'_lyapunov' if lyapunov else ''}")

    def gpu_kernel(self, method, lyapunov=False):
        from vrsweep.numerics import codegen, cuda

        return cuda.line_kernel(method, lyapunov, *codegen.written_functions(codegen.compiled(self.model), lyapunov))

    def gpu_lines(self, method, lyapunov=False):
        from vrsweep.numerics import cuda

        return cuda.DeviceLines(self.gpu_kernel(method, lyapunov))


def _gpu_is_cached(kernels, method, lyapunov):
    """Whether the GPU's kernel is in numba's cache (a hint); True where numba-cuda is missing, so
    that no compile is announced for a run that will stop at its one-line error (execution/device.py)."""
    try:
        from vrsweep.numerics import cuda
    except ImportError:
        return True
    return cuda.is_cached(kernels.gpu_kernel(method, lyapunov))


def kernels_for(model):
    """The kernels of a config's model: a name of the paper's models, or a WrittenModel."""
    if isinstance(model, WrittenModel):
        return WrittenKernels(model)
    return PaperKernels(model)
