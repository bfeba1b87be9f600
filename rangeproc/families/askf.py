"""``filter = "askf"``: the augmented-state filter of patent CN109581356A: the EKF with the
constant maneuver-norm constraint on the acceleration block, imposed in the refinement passes
(``estimation.constraint``); the first pass is unconstrained and estimates the norm when the
config gives none."""
from rangeproc.families.base import Family

FAMILY = Family(
    name="askf", summary="EKF with the maneuver-norm constraint (patent CN109581356A)",
    parameters=(("maneuver_norm", "m/s^2"),), adds=("norm-constraint",))
