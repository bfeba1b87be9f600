"""``filter = "stukf"``: Ye and Cui's strong-tracking UKF with multiple suboptimal fading
factors (``estimation.fading``). Its first pass is the plain UKF: fading is for the model
errors the refined noise leaves, not for a track still converging from its start."""
from rangeproc.families.base import Family

FAMILY = Family(
    name="stukf", summary="strong-tracking UKF, multiple fading factors (Ye and Cui)",
    update="ukf", parameters=(("stukf_forgetting", ""), ("stukf_weakening", ""),
                              ("stukf_ratios", "")),
    adds=("fading",), outputs=("fade",), first_pass="ukf")
