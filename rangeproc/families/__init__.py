"""The filter families: one registry keyed by the config's ``processing.filter`` string.

Each family is one module of this package declaring a :class:`Family`: the config string
that names it, the measurement update it uses, the ``[processing]`` keys it reads (with their
units), the steps of the shared forward loop it adds to (``families.STEPS``), the type of its
forward pass's output, what its first pass runs and what follows its passes. Everything that
asks "which filter" asks this registry: the config's allowed values (:data:`FILTERS`,
``settings.ProcessingSettings.filter``), the estimator's choice of a pass's filter
(``fusion.estimator_types``), the forward filter's settings and its compiled specialisation
(``estimation.forward.run_filter``, ``estimation.forward_loop``).

Plain declarations (no numerics, no imports from the rest of the package), so that the
settings at the bottom of the house can list the names.
"""
from __future__ import annotations

from types import MappingProxyType

from rangeproc.families.base import OUTPUTS, STEPS, UPDATES, Family

__all__ = ["FILTERS", "OUTPUTS", "REGISTRY", "STEPS", "UPDATES", "Family", "family"]


def _registry() -> MappingProxyType:
    from rangeproc.families import askf, auto, ekf, imm, sage_husa, spline, stukf, ukf
    families = (auto.FAMILY, ekf.FAMILY, ukf.FAMILY, stukf.FAMILY, sage_husa.FAMILY,
                askf.FAMILY, imm.FAMILY, spline.FAMILY)
    return MappingProxyType({f.name: f for f in families})


#: Every family by its ``processing.filter`` string.
REGISTRY: MappingProxyType = _registry()
#: The ``processing.filter`` strings, in the order the config reference lists them.
FILTERS: tuple[str, ...] = tuple(REGISTRY)


def family(name: str) -> Family:
    """The family named ``name`` (a :data:`FILTERS` string); KeyError names the known ones."""
    try:
        return REGISTRY[name]
    except KeyError:
        raise KeyError(f"unknown filter family {name!r} (expected one of: "
                       f"{', '.join(FILTERS)})") from None
