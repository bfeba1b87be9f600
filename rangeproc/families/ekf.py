"""``filter = "ekf"``: the extended Kalman filter (He 2015 sec. 3.1), linearised at the
prediction or, in the refinement passes, at the previous smoothed track; Joseph form. The
plain shared loop, with the fused fast path for the common rows."""
from rangeproc.families.base import Family

FAMILY = Family(name="ekf", summary="extended Kalman filter, Joseph form (He 2015)")
