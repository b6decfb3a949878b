"""roadbank's performance benchmark suite (the library behind ``roadbank bench``).

>>> from roadbank.bench import run_suite, markdown
>>> res = run_suite("quick")          # doctest: +SKIP
>>> print(markdown(res, "python"))    # doctest: +SKIP

Built-in extra sections: the estimator designs (:mod:`roadbank.bench.design`), fleets of short
logs on 1 and 2 workers (:mod:`roadbank.bench.fleet`), the exported C
step and long logs (:mod:`roadbank.bench.sections`), a user's first ``roadbank estimate`` with empty caches
(:mod:`roadbank.bench.first_run`), and the default's accuracy targets
(:mod:`roadbank.bench.accuracy`; the real drives with ``--data``). Extend it with :func:`register_section`
(a :class:`Section` with a ``run`` and an optional ``markdown`` function): the section runs after the built-in ones,
its results land in ``res[name]`` and in the report.
"""

from .cold import FAMILY_PROBES, cold_compile, probe_family
from .report import markdown, obstacles, to_json
from .suite import (SECTIONS, SIZES, TARGETS, Section, machine_info, register_section, run_suite,
                    synthetic_log, target_status)
from .accuracy import SECTION as _ACCURACY_SECTION
from .design import SECTION as _DESIGN_SECTION
from .first_run import SECTION as _FIRST_RUN_SECTION
from .fleet import SECTION as _FLEET_SECTION
from .sections import SECTIONS as _BUILTIN_SECTIONS

for _section in (_DESIGN_SECTION, _FLEET_SECTION, *_BUILTIN_SECTIONS, _FIRST_RUN_SECTION, _ACCURACY_SECTION):
    register_section(_section)

__all__ = ["FAMILY_PROBES", "SECTIONS", "SIZES", "TARGETS", "Section", "cold_compile", "machine_info",
           "markdown", "obstacles", "probe_family", "register_section", "run_suite", "synthetic_log",
           "target_status", "to_json"]
