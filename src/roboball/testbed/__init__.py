"""The virtual test bed: a simulated "physical robot" that writes raw logs as the real one would.

It simulates at higher fidelity than any model the pipeline fits (finer time step and
hydroelastic mesh, full 3-D) and holds physics the paper's models leave out: LuGre/Stribeck
joint friction with true stiction, a shell law from the membrane and its bedliner skin (a
contact-patch flat that restores with a stiffness bounded by the patch, a viscoelastic rolling
loss; membrane.py), and mass properties that differ from the URDF.  Its truth
lives in `truth.yaml` beside this file.  Nothing outside this package may import it or read
that file (tests/testbed/test_isolation.py): the analysis sees only the recordings.
"""
from pathlib import Path

TRUTH_YAML = Path(__file__).with_name("truth.yaml")
