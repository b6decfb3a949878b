"""``roadbank robustness``: the fault x estimator robustness table (docs/robustness.md)."""

from __future__ import annotations

from pathlib import Path

import click

from .options import PathOption, checked_output


@click.command()
@click.option("--output", "-o", required=True, type=PathOption(dir_okay=False, path_type=Path),
              callback=checked_output(next_to=(".csv",)),
              help="Report to write: markdown (e.g. docs/robustness.md) or, ending in .html, a "
                   "self-contained HTML page; a .csv with the same stem is written too.")
@click.option("--scenario", default="bank-lane-change", show_default=True, help="Simulated base scenario.")
@click.option("--estimators", default="", help="Comma-separated estimator names (default: all).")
def robustness(output: Path, scenario: str, estimators: str) -> None:
    """Inject every fault into a simulated log and tabulate what each estimator does."""
    from ..estimators import NAMES
    from ..sim import SCENARIOS

    if scenario not in SCENARIOS:
        raise click.BadParameter(f"unknown scenario '{scenario}' (choose from {', '.join(SCENARIOS)})",
                                 param_hint="--scenario")
    names = tuple(n.strip() for n in estimators.split(",") if n.strip()) or NAMES
    bad = [n for n in names if n not in NAMES]
    if bad:
        raise click.BadParameter(f"unknown estimator(s) {', '.join(bad)} (choose from {', '.join(NAMES)})",
                                 param_hint="--estimators")
    if output.suffix.lower() not in (".md", ".markdown", ".html", ".htm"):
        raise click.BadParameter(f"{output}: the report must end in .md or .html", param_hint="--output")
    if not output.parent.exists():
        raise click.ClickException(f"cannot write {output}: directory {output.parent} does not exist")
    from ..faults.table import markdown, robustness_rows
    from ..report.html import write_document

    rows = robustness_rows(scenario, names=names)
    cmd = f"roadbank robustness -o {output}" + (f" --scenario {scenario}" if scenario != "bank-lane-change" else "")
    try:
        write_document(output, markdown(rows, scenario, cmd), "roadbank robustness")
        import csv

        with open(output.with_suffix(".csv"), "w", newline="") as fh:
            w = csv.DictWriter(fh, fieldnames=list(rows[0]))
            w.writeheader()
            w.writerows(rows)
    except OSError as exc:
        raise click.ClickException(f"cannot write {output}: {exc.strerror or exc}") from None
    n_bad = sum(r["nonfinite"] for r in rows)
    click.echo(f"{len(rows)} fault x estimator cells, {n_bad} with non-finite output -> {output}")
