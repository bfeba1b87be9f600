"""``filter = "spline"``: Zhou et al.'s self-adaptive spline filter (``estimation
.spline_filter``): a piecewise-constant jerk input, the epoch anomaly test, adapted noise and
a new segment at anomalies; then the batch cubic B-spline fit (``fusion.spline_refine``)."""
from rangeproc.families.base import Family

FAMILY = Family(
    name="spline", summary="self-adaptive spline filter, then the batch spline fit (Zhou et "
    "al. 2001)", parameters=(("spline_anomaly_probability", ""),
                             ("spline_knot_spacing", "s")),
    adds=("jerk-input", "anomaly"), outputs=("fade", "jerk", "anomaly", "knot"),
    spline_fit=True)
