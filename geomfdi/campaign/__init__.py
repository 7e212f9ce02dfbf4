"""Monte-Carlo campaigns: seeds x fault sizes x onsets x plant models, on any executor.

* :mod:`~geomfdi.campaign.spec` -- :class:`Scenario`, :class:`Uncertainty`.
* :mod:`~geomfdi.campaign.runner` -- :class:`Campaign` (blocks, executors, seeds).
* :mod:`~geomfdi.campaign.executors` -- where the blocks run: the job shipped once per
  worker, task sizes, worker set-up, lost workers retried.
* :mod:`~geomfdi.campaign.result` -- :class:`CampaignResult` (table, summary, curves).

Layer: above simulation and evaluation.  It may import :mod:`geomfdi.model`,
:mod:`geomfdi.simulation`, :mod:`geomfdi.evaluation`, :mod:`geomfdi.io` (scenario files)
and, inside functions, :mod:`geomfdi.plotting`; never the synthesis.
"""

from geomfdi.campaign.executors import DASK_THROUGHPUT, local_dask_client
from geomfdi.campaign.result import CampaignResult
from geomfdi.campaign.runner import Campaign
from geomfdi.campaign.spec import Scenario, Uncertainty

__all__ = [
    "DASK_THROUGHPUT",
    "Campaign",
    "CampaignResult",
    "Scenario",
    "Uncertainty",
    "local_dask_client",
]
