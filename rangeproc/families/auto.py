"""``filter = "auto"`` (the default): the EKF, or for an object measured by range rates
alone the EKF's passes then the batch spline fit (``fusion.filter_choice``)."""
from rangeproc.families.base import Family

FAMILY = Family(
    name="auto", summary="chosen per object: the EKF, or the EKF's passes then the batch "
    "spline fit for range rates alone (fusion.filter_choice)", first_pass="ekf", chooses=True)
