"""``filter = "sage-husa"``: the EKF with improved Sage-Husa adaptive measurement noise over
windows of accepted rows per sensor component (Song et al. 2011, ``estimation.adaptive``)."""
from rangeproc.families.base import Family

FAMILY = Family(
    name="sage-husa", summary="EKF with improved Sage-Husa adaptive measurement noise "
    "(Song et al. 2011)", parameters=(("sage_husa_window", "rows"), ("sage_husa_mean", "")),
    adds=("adaptive-noise",), outputs=("sigma_used",))
