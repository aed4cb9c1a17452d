"""How densely a trajectory must be sampled to draw its fastest force, in plain Python (no numba):
``vrsweep simulate`` words its help with it, and the figures warn with it, before any kernel is
imported. What the fastest force is comes from diagnostics.sampling_of_forcing."""

SAMPLES_PER_CYCLE = 20
"""Samples per cycle of the fastest force that a trajectory's default sampling gives, at least: at
Omega = 50, 200 samples a slow period were 2 a cycle, each at a zero of sin(Omega t), and the
velocity's fast wiggle (g/Omega = 0.1) vanished from the figure."""
RESOLVED_SAMPLES_PER_CYCLE = SAMPLES_PER_CYCLE // 2
"""Fewer samples a cycle of the fastest force than this do not draw its wiggle: a figure says so."""
