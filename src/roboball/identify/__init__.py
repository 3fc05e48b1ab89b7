"""System identification from the stand and shell recordings.

* :mod:`roboball.identify.friction_fit`: joint-friction laws on the stand logs, least squares
  then emcee posteriors (resumable HDF5 chains), model comparison.
"""
