"""Shell identification: damping ratio and natural frequency of each free response (decay), and
their pressure regressions zeta(p), omega_n(p) (paper Fig. 10)."""
