"""``filter = "ukf"``: the unscented Kalman filter (sigma points alpha = 1, beta = 2,
kappa = 3 - n after Ye and Cui); the linear prediction is exact. The plain shared loop."""
from rangeproc.families.base import Family

FAMILY = Family(name="ukf", summary="unscented Kalman filter", update="ukf")
