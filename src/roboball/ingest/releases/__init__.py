"""Finding the releases in a recording.

A *release* is what the experimenters did by hand in the stand and shell tests: move the
body, hold it still away from its rest position, let go.  A free oscillation follows: the
body accelerates towards rest, overshoots, and swings about rest with decaying amplitude
until it stops or a hand intervenes again.  The recordings do not mark these events, so the
tools find them themselves.

Method (all thresholds are relative to the signal's own noise level and swing size, so the
same code works for a 1-mrad-quantised pendulum log at 80 Hz and a 100 Hz shell log):

1. Drop duplicate stamps, resample onto a uniform grid (linear interpolation; gaps of a
   few samples are harmless), smooth with a Savitzky-Golay filter, and estimate the noise
   level sigma (robust MAD of the high-pass residual, floored by the quantisation step).
2. Find the turning points of the smoothed signal with a hysteresis ("zig-zag") of 5 sigma.
3. Every turning point is a candidate hold, and so is a hold inside a monotone stretch (a
   hand that catches a swing, lowers the body towards rest, holds it and lets go makes no
   turning point there: still for `min_hold_s` between clearly larger moves on both sides).
   A candidate is accepted as a release when
   - the body was held: slower than 10% of the free swing's peak speed (offset x omega)
     for at least `min_hold_s` AND for clearly longer (2.5x) than the turning point of a free
     swing of the same frequency and amplitude is (this separates a hand hold from a
     turning point of an ongoing oscillation);
   - it lies further than 20 sigma from the final rest of the motion that follows (the level
     the body settles at after its last swing, unless its swings do not swing about that
     level: then a hand's hold, and the rest is extrapolated from their decay, leaving out
     a last point where the record ends mid-swing, which is no turning point), and its
     offset is at least 5% of the largest release in the file (a hand's tremor while it
     holds the body makes tiny "releases" of its own);
   - the body was held in place: within 5% of the offset of where it is let go;
   - the following motion crosses rest at least twice, with amplitudes not growing, its
     first half swing (from the end of the hold) lasts 0.5-2 half periods and overshoots
     rest by at least 0.4x the decay ratio of the next half swing (a free oscillation,
     not a hand lowering the body into a hand-held jiggle); or, with strong dry friction,
     it overshoots rest once by at least 10% of the offset and then stops.
   A record that starts slow and away from rest (a simulation started at the release
   state) has its release at the first sample.  So does a log trimmed at (or a few samples
   after) the let-go, with no hold before it: its first turning point is its first sample,
   from which it swings towards rest into a decaying oscillation as above, no later than
   45 deg into its swing (its speed over its distance from rest times omega is at most 1) and
   with an offset of at least a quarter of the record's range (a hand's tremor while it holds
   the body is no release).  A record that starts at rest is not one.
4. The free response ends at the last turning point before the amplitude grows again (a
   hand), the rhythm breaks (a hold or a stop), or the swings sink into the noise, plus
   half a period; or at the end of the file.
5. The release instant is refined on the raw samples by fitting a hinge model: a (nearly)
   constant hold, continued after the release instant t_r by the onset of free motion
   y_h + v0 tau + c2 tau^2 + c3 tau^3 (tau = t - t_r): released from rest the body starts
   with zero velocity and constant acceleration, so the kink in curvature marks t_r.

Ramp recordings are different: the robot starts from rest and rolls, so the single
"release" is the start of motion of the drive rate (hinge fit of a constant followed by a
linear/quadratic rise), ending at ``ramp_exit_s`` if the recording says when the robot left
the ramp.

Modules: ``find`` (the entry points: find_releases, recording_releases, require_releases),
``record`` (the Release), ``signal`` (steps 1-2), ``holds``, ``rest`` and ``trimmed`` (step 3),
``oscillation`` (steps 3-5 for the oscillating kinds), ``hinge`` (step 5), ``ramp``.
"""
