"""Fast reduced-order models of the stand, shell and ramp experiments, batched over parameter
sets.  They stand in for Drake where thousands of simulations are needed (friction posteriors,
diagnosis); tests hold each against Drake."""
