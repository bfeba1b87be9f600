"""A campaign's outcome: what ``campaign.runner`` returns and ``campaign.page`` shows."""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from rangeproc.campaign.sortie import Outcome


@dataclass(frozen=True, slots=True)
class CampaignResult:
    """Outcomes in campaign order, the records folder, the wall time (s) and the cluster."""

    outcomes: tuple[Outcome, ...]
    out_dir: Path
    seconds: float
    cluster: str

    @property
    def failed(self) -> tuple[Outcome, ...]:
        return tuple(o for o in self.outcomes if o.status == "failed")

    def counts(self) -> dict[str, int]:
        out = {"done": 0, "skipped": 0, "failed": 0}
        for o in self.outcomes:
            out[o.status] += 1
        return out
