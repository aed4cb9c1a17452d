"""Running a sweep: the points planned into chunks, threads, a local loop or a Dask cluster,
progress, signals, cost estimates, and the job that ties them to an output file.

The only layer that both computes (through ``vrsweep.numerics``) and writes (through
``vrsweep.store``).
"""
