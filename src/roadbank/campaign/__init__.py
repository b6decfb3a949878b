"""Monte-Carlo campaigns: many randomised simulator runs scored for every estimator, on Dask.

Modules, one concept each:

- :mod:`.sampling` — the random draw of one run (scenario, plant and sensor
  perturbations) from ``(base_seed, run_id)``; reproducible per run index.
- :mod:`.runner` — the per-run work: simulate, run all estimators, score them,
  flat result rows (a failing run becomes rows carrying its error text).
- :mod:`.store` — incremental Parquet parts (one file per finished batch),
  resume by run id, de-duplication.
- :mod:`.execute` — the Dask driver (LocalCluster by default, any scheduler
  address), batching, incremental writes, interruption.
- :mod:`.report` — distribution tables, box plot, failure cells, report.md.

Dask is imported only by :mod:`.execute`, and only when a campaign runs; without
it :func:`roadbank.campaign.execute.run_campaign` raises :class:`DaskMissing`
with the install command.
"""

from .sampling import RunSpec, draw

__all__ = ["RunSpec", "draw"]
