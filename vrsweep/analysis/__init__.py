"""What is computed from the numerics but is not a kernel: the paper's analytic theory, the
diagnostics of a run's records (period, error bars, Lyapunov batches), attractor labels.

Imports from ``vrsweep.numerics`` and nothing above it.
"""
