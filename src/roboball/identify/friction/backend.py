"""emcee's HDF5 chain, written once per sampling run instead of once per step.

Why: emcee's ``HDFBackend`` opens the file, reads its shape and writes every step: about 1.3 ms
a step, 12-15% of a friction fit (the pipeline's seven fits run 950-1750 steps each).  This
backend keeps a run's steps in memory and writes them in one go when the run ends
(:meth:`ChunkedHDFBackend.flush`, after every ``run_mcmc`` call of the sampler: one chunk of at
most 50 steps).  The file has emcee's own layout, so a chain stored by either backend is read
and resumed by the other.  A fit killed inside a chunk resumes from the end of the last one,
with the random state stored there, so the chain it completes is the uninterrupted one, step
for step (``tests/identify/test_friction_fit.py``).
"""
from __future__ import annotations

import numpy as np
from emcee.backends import HDFBackend

__all__ = ["ChunkedHDFBackend"]


class ChunkedHDFBackend(HDFBackend):
    """``emcee.backends.HDFBackend`` that buffers the steps of a run until :meth:`flush`.

    Reads (``iteration``, ``get_chain``, ``random_state``, ...) see the stored steps only: call
    :meth:`flush` after each ``run_mcmc`` before reading the chain.  Blobs are not supported
    (a friction posterior returns none).
    """

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self._shape = None
        self._clear()

    def _clear(self) -> None:
        self._coords: list[np.ndarray] = []
        self._log_prob: list[np.ndarray] = []
        self._accepted = None
        self._random_state = None

    def reset(self, nwalkers, ndim):
        super().reset(nwalkers, ndim)
        self._shape = None
        self._clear()

    def grow(self, ngrow, blobs):
        """Nothing to allocate before the run: :meth:`flush` sizes the datasets."""
        if blobs is not None:
            raise ValueError("ChunkedHDFBackend stores no blobs")

    def save_step(self, state, accepted):
        """Keep one step in memory (emcee's checks of the state's shapes, the file read once)."""
        if self._shape is None:
            self._shape = tuple(int(s) for s in self.shape)
        nwalkers, ndim = self._shape
        if state.blobs is not None:
            raise ValueError("ChunkedHDFBackend stores no blobs")
        if state.coords.shape != (nwalkers, ndim) or state.log_prob.shape != (nwalkers,) \
                or accepted.shape != (nwalkers,):
            raise ValueError(f"a step of shape {state.coords.shape} for a chain of {nwalkers} walkers in {ndim} "
                             "dimensions")
        self._coords.append(np.array(state.coords, dtype=float))
        self._log_prob.append(np.array(state.log_prob, dtype=float))
        acc = np.asarray(accepted, dtype=float)
        self._accepted = acc if self._accepted is None else self._accepted + acc
        self._random_state = state.random_state

    def flush(self) -> None:
        """Write the buffered steps, the acceptance counts and the last random state."""
        n = len(self._coords)
        if n == 0:
            return
        with self.open("a") as f:
            g = f[self.name]
            it = int(g.attrs["iteration"])
            g["chain"].resize(it + n, axis=0)
            g["log_prob"].resize(it + n, axis=0)
            g["chain"][it:it + n] = np.stack(self._coords)
            g["log_prob"][it:it + n] = np.stack(self._log_prob)
            g["accepted"][:] += self._accepted
            for i, v in enumerate(self._random_state):
                g.attrs[f"random_state_{i}"] = v
            g.attrs["iteration"] = it + n
        self._clear()
