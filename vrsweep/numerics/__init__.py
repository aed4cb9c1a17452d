"""Everything numba compiles, and nothing else: the model's coefficient vector, the right-hand
sides, the Dormand-Prince steps (rk45, dop853), impact location, tangent vectors, the kernel loop
with its per-period records, one trajectory, and the loops over grid lines with the threads that
run them.

Imports nothing from the other layers (only ``vrsweep.errors`` and ``vrsweep.results``): the
kernel knows nothing of files, YAML, progress bars or plots (tests/test_layout.py checks it).
"""
