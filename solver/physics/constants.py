"""The parameters the equations of motion read, unpacked from the flat vector ``p`` in one place.

The rolling equations, the loads and the engine's rules read them with one line,
``r, R, rho, m, j, g, mu, k_r, k_d = constants(p)``, instead of a preamble of ``p[P_*]`` reads; the helper
is inlined. The slipping equations keep their own reads: with this helper their section ran 1.19x slower
(docs/engine-design.md). Kept apart from ``params`` so that importing the parameters loads no numba.
"""

from __future__ import annotations

from rimroll.solver._jit import physics_kernel
from rimroll.solver.physics.params import P_G, P_J, P_K_D, P_K_R, P_M, P_MU, P_R_BALL, P_R_RIM, P_RHO


@physics_kernel(inline=True)
def constants(p):
    """(r, R, rho [m], m [kg], j [1], g [m/s^2], mu [1], k_r, k_d [1/s]) from the flat vector ``p``
    (``Params.as_array``; ``params.P_*`` index it)."""
    return p[P_R_BALL], p[P_R_RIM], p[P_RHO], p[P_M], p[P_J], p[P_G], p[P_MU], p[P_K_R], p[P_K_D]
