"""Joint-friction identification on the stand recordings: least squares, emcee posteriors,
model comparison, and the one reader of the fit files it writes."""
