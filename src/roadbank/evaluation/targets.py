"""A target of the default estimator and its verdict: what ``roadbank validate``, ``roadbank campaign`` and
``roadbank bench`` report (:mod:`roadbank.validation.targets`, :func:`roadbank.tuning.simulated.sim_targets`,
:func:`roadbank.campaign.report.default_target`)."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Target:
    """One target: the data it is judged on, what it asks, what was measured (text, deg or s as it says), and
    whether it is met."""

    data: str
    text: str
    measured: str
    met: bool
