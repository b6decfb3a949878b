"""Benchmark section ``accuracy``: the default's accuracy targets, as ``roadbank validate`` and ``campaign`` judge them.

Accuracy, not speed, so that one benchmark run states every target of the project, timed and not:

* **real data** (:mod:`roadbank.validation.targets`): the KITTI validation drives and every comma2k19 segment
  found (at any depth, each once) under ``roadbank bench --data DIR`` (e.g. ``../shared/data``), as ``roadbank
  validate all`` reads them, every causal estimator run (the KITTI target compares the default with all of them);
  without ``--data`` it says so;
* **simulated validation set, car known** (:func:`roadbank.tuning.simulated.sim_targets`), the default only;
* **campaign** (:func:`roadbank.campaign.report.default_target`): its first :data:`CAMPAIGN_RUNS` runs (seed 0,
  standstill starts, offsets learnt online), the default only, in this process.

The simulated parts run in the full suite only, with or without ``--data``. A part that fails or finds nothing to
judge is a note; the others still run.
"""

from __future__ import annotations

import dataclasses
import time

from .suite import Section

#: runs of the campaign part (the campaign documented in docs/campaign.md has 400)
CAMPAIGN_RUNS = 400


def _real(data) -> tuple[list, list]:
    """The real-data targets on the data sets under ``data``, as ``roadbank validate all`` reads them (every KITTI
    drive, every comma2k19 segment, each once), and notes on what could not be judged."""
    from ..validation.comma2k19 import comma2k19_outcome, named_apart, unique_segments
    from ..validation.datasets import find_datasets
    from ..validation.kitti import validate_kitti
    from ..validation.scoring import ESP_DEFAULT
    from ..validation.targets import CAUSAL, comma_targets, kitti_targets

    names = [*CAUSAL, ESP_DEFAULT]          # the default without the roll rate too: its own target row
    found, targets = find_datasets(data), []
    notes = list(found["notes"])
    if found["kitti"]:
        v = validate_kitti(found["kitti"], names=names, sensitivity=False)
        judged = kitti_targets(v)
        targets += judged
        notes += [f"KITTI: not read: {e}" for e in v.errors]
        if not judged:
            notes.append(f"KITTI: no validation drive among the {len(found['kitti'])} drives found")
    else:
        notes.append("KITTI: no drive found")
    segments, seg_notes = unique_segments(found["comma2k19"])
    notes += [f"comma2k19: {n}" for n in seg_notes]
    results = []
    for path in segments:
        res, error = comma2k19_outcome(path, names=names, sensitivity=False)
        if error is None:
            results.append(res)
        else:
            notes.append(f"comma2k19: not read: {error}")
    for res in named_apart(results):
        judged = comma_targets(res)
        # several segments: each target names its segment (one: as validate all's report says it)
        targets += judged if len(results) == 1 else [dataclasses.replace(t, data=f"{t.data} {res.label}")
                                                     for t in judged]
    if not segments:
        notes.append("comma2k19: no segment found")
    return targets, notes


def _simulated() -> tuple[list, list]:
    from ..estimators import DEFAULT
    from ..tuning.simulated import score_simulated, sim_targets

    return sim_targets(score_simulated([DEFAULT])), []


def _campaign() -> tuple[list, list]:
    import pandas as pd

    from ..campaign.report import default_target
    from ..campaign.runner import RunOptions, run_batch
    from ..campaign.sampling import draw
    from ..estimators import DEFAULT

    rows = run_batch([draw(k, 0) for k in range(CAMPAIGN_RUNS)], RunOptions(names=(DEFAULT,)))
    target = default_target(pd.DataFrame(rows))
    return ([], ["campaign: no run scored"]) if target is None else ([target], [])


def accuracy(cfg: dict) -> dict:
    """The targets measured (module docstring); ``notes`` say which parts did not run and why."""
    if cfg["size"] == "tiny":
        return {"reason": "not run with --tiny (it scores real drives and simulated sets)"}
    full = cfg["size"] == "full"
    parts = (("real data", lambda: _real(cfg["data"]), bool(cfg.get("data")),
              "no real data given (roadbank bench --data DIR, e.g. ../shared/data)"),
             ("simulated validation set", _simulated, full, "full suite only"),
             ("campaign", _campaign, full, "full suite only"))
    targets, notes, wall = [], [], {}
    for what, run, ok, why in parts:
        if not ok:
            notes.append(f"{what}: not run: {why}")
            continue
        t0 = time.perf_counter()
        try:
            found, said = run()
        except Exception as exc:            # one part that fails never loses the others
            found, said = [], [f"{what}: failed: {type(exc).__name__}: {exc}"]
        wall[what] = time.perf_counter() - t0
        targets += found
        notes += said
    return {"targets": [dataclasses.asdict(t) for t in targets], "notes": notes, "wall_s": wall,
            "data": cfg.get("data")}


def accuracy_markdown(out: dict) -> list[str]:
    from ..evaluation.targets import Target
    from ..report.tables import targets_markdown

    took = ", ".join(f"{k} {v:.0f} s" for k, v in out["wall_s"].items())
    data = f", data under `{out['data']}`" if out["data"] else ""
    notes = [f"- {n}" for n in out["notes"]]
    return targets_markdown([Target(**t) for t in out["targets"]]) + notes + ([""] if notes else []) + [
        "Not timed" + (f" ({took})" if took else "") + f". The same verdicts as `roadbank validate all` "
        f"(docs/real-data.md{data}), `roadbank validate sim` (docs/sim-validation.md) and the campaign report "
        "(docs/campaign.md); measured medians and percentiles in deg. What the simulated targets owe to each "
        "perturbation of the plant: docs/sim-validation.md (\"Where the error comes from\") and docs/campaign.md "
        "(\"What the 1 deg goal needs\")."]


SECTION = Section("accuracy", "The default's accuracy targets", accuracy, accuracy_markdown)
