"""Whole test campaigns: many ``rangeproc run``s on a Dask cluster.

``load_campaign`` reads the campaign (a TOML list of sortie configs, or a folder of them or
of sortie folders, ``campaign.spec``); ``run_campaign`` runs every sortie as one Dask task
(``campaign.runner``, ``campaign.sortie``): in parallel on this machine by default, on an
existing cluster with a scheduler address; failures are recorded per sortie and the others
go on; a rerun skips sorties whose outputs match their config and inputs. A campaign is
many runs, nothing else: each sortie's outputs are exactly ``rangeproc run``'s.
"""
from rangeproc.campaign.result import CampaignResult
from rangeproc.campaign.runner import run_campaign
from rangeproc.campaign.sortie import Outcome, run_sortie
from rangeproc.campaign.spec import Campaign, Sortie, load_campaign

__all__ = ["Campaign", "CampaignResult", "Outcome", "Sortie", "load_campaign", "run_campaign",
           "run_sortie"]
