"""System identification from the stand and shell recordings.

* :mod:`roboball.identify.shell`: decay of each shell release and the pressure regressions.
* :mod:`roboball.identify.friction`: joint-friction laws on the stand logs, least squares then
  emcee posteriors (resumable HDF5 chains), model comparison.
"""
