"""``filter = "imm"``: interacting multiple models (CV, CA, CT; Blom and Bar-Shalom) with
Kim's smoother (``estimation.imm``, ``estimation.imm_smoother``). Its first pass is the
constant-acceleration EKF, whose smoothed start the models begin from."""
from rangeproc.families.base import Family

FAMILY = Family(
    name="imm", summary="interacting multiple models with Kim's smoother",
    parameters=(("imm_models", ""), ("imm_sojourn", "s")), adds=("models",),
    output="IMMOutput", outputs=("xm", "Pm", "mu", "omega"), first_pass="ekf")
