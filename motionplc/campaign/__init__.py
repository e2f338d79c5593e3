"""Scenario campaigns: thousands of deterministic simulated runs of one machine and program,
parameter grids, seeded random draws and fault injections, on Dask.

    from motionplc.campaign import load_campaign, run_campaign, report_text

    c = load_campaign("configs/campaigns/demo_faults.yaml")   # validated up front
    result = run_campaign(c, workers=2)                       # LocalCluster on 127.0.0.1
    print(report_text(result))

A scenario is one run on the simulated clock (:func:`run_scenario`): the same inputs give the
same bits, in whichever process or order. Results are kept per finished task in Parquet under
the output directory (``out/campaigns/<name>`` by default): an interrupted campaign resumes,
a finished one reruns nothing. The file format: ``docs/reference/campaign.md``.
"""

from motionplc.campaign.engine import CampaignResult, output_dir, run_campaign
from motionplc.campaign.scenario import VERDICTS, Job, run_batch, run_scenario
from motionplc.campaign.spec import Campaign, Fault, Scenario, load_campaign
from motionplc.campaign.store import ResultStore, table_digest

__all__ = [
    "VERDICTS",
    "Campaign",
    "CampaignResult",
    "Fault",
    "Job",
    "ResultStore",
    "Scenario",
    "load_campaign",
    "output_dir",
    "run_batch",
    "run_campaign",
    "run_scenario",
    "table_digest",
]
