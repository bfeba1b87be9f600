"""A filter family's declaration (:class:`Family`) and the vocabulary it declares in: the
steps of the shared forward loop, the measurement updates, the output types."""
from __future__ import annotations

from dataclasses import dataclass

#: The steps of the shared forward loop (``estimation.forward_loop``) a family may add to:
#:
#: * ``jerk-input``: a known jerk input added to each prediction (the spline filter);
#: * ``fading``: fading factors on the predicted covariance before the epoch's rows, from
#:   the epoch's innovations (strong tracking);
#: * ``anomaly``: the epoch's anomaly test before its rows, the adapted sigmas of an
#:   anomalous epoch's rows, the accepted rows' residual sums and the jerk segments after
#:   them (the spline filter);
#: * ``adaptive-noise``: each row's sigmas from the window of accepted innovations, the
#:   window recorded after the update and emptied at a divergence reset (Sage-Husa);
#: * ``norm-constraint``: the maneuver-norm pseudo-measurement after each epoch's rows
#:   (the constrained ASKF, in its refinement passes);
#: * ``models``: several motion models mixed every epoch (the IMM; its own loop over the
#:   same row update, ``estimation.imm``).
STEPS = ("jerk-input", "fading", "anomaly", "adaptive-noise", "norm-constraint", "models")
#: Measurement updates: linearised (Joseph form) or unscented.
UPDATES = ("ekf", "ukf")
#: Output types of a forward pass (``estimation.outputs``).
OUTPUTS = ("FilterOutput", "IMMOutput")


@dataclass(frozen=True, kw_only=True, slots=True)
class Family:
    """One filter family, as its module declares it.

    name: the ``processing.filter`` string.
    summary: one line on what it is (and whose method).
    update: the measurement update (:data:`UPDATES`).
    parameters: ``(key, unit)`` of each ``[processing]`` key it reads beyond the common ones
        (the unit as the key's declaration in ``settings`` writes it; "" for none).
    adds: the steps of the shared loop it adds to (:data:`STEPS`); empty: the plain loop.
    output: the type of its forward pass's output (:data:`OUTPUTS`); ``outputs``: the fields
        of that type it fills beyond the common ones.
    first_pass: the family of the estimator's first pass (before the refinement passes).
    chooses: it names no filter of its own but chooses one per object
        (``fusion.filter_choice``); the family it runs meanwhile is ``first_pass``.
    spline_fit: the batch cubic B-spline fit follows its passes (``fusion.spline_refine``).
    """

    name: str
    summary: str
    update: str = "ekf"
    parameters: tuple[tuple[str, str], ...] = ()
    adds: tuple[str, ...] = ()
    output: str = "FilterOutput"
    outputs: tuple[str, ...] = ()
    first_pass: str = ""
    chooses: bool = False
    spline_fit: bool = False

    def __post_init__(self) -> None:
        unknown = [s for s in self.adds if s not in STEPS]
        if unknown or self.update not in UPDATES or self.output not in OUTPUTS:
            raise ValueError(f"filter family {self.name!r}: unknown step, update or output "
                             f"({unknown}, {self.update!r}, {self.output!r})")

    @property
    def first(self) -> str:
        """The family the first pass runs (itself unless declared)."""
        return self.first_pass or self.name
