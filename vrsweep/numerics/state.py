"""The kernel's state vector: which component is what (the one module that owns this layout).

    y[X], y[V]                       position and velocity of the mass
    y[QS_INTEGRAL], y[QC_INTEGRAL]   Fourier quadratures of the current slow period (eq3.1, eq3.2):
                                     d/dt = x sin(omega t), x cos(omega t); reset at t = nT
    y[TANGENT + 2 i], y[TANGENT + 2 i + 1]
                                     the i-th tangent vector (dx, dv), i = 0, 1: a solution of the
                                     variational equations (tangent.py), present only in the
                                     kernels that compute Lyapunov exponents (integration.lyapunov)

Only x and v are error-controlled (integrator.N_CONTROLLED) and interpolated (dense output);
the tangent vectors are linear in themselves with the Jacobian along (x, v), so the steps that
resolve (x, v) resolve them too, and leaving them out of error control keeps the steps, and so
R, identical to a run without them.
"""

X, V = 0, 1
QS_INTEGRAL, QC_INTEGRAL = 2, 3
N_STATE = 4

TANGENT = 4                 # first component of the first tangent vector
N_TANGENT_VECTORS = 2       # both exponents: the largest, and the sum (for the divergence check)
N_STATE_WITH_TANGENTS = TANGENT + 2 * N_TANGENT_VECTORS
