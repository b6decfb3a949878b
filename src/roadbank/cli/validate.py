"""``roadbank validate``: check the estimators on real driving data."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import click


@click.group()
def validate():
    """Validate the estimators on real data sets."""


@validate.command("comma2k19")
@click.argument("path", type=click.Path(path_type=Path))
@click.option("--json", "as_json", is_flag=True,
              help='Print {estimator: {"r", "rms_deg", "offset_deg"}} on stdout.')
@click.option("-o", "--output", type=click.Path(path_type=Path), default=None,
              help="Write the markdown report here (e.g. docs/real-data.md) and a PNG next to it.")
@click.option("--estimators", "-e", "names", default="all", show_default=True,
              help="Comma-separated estimator names or 'all'.")
@click.option("--no-sensitivity", is_flag=True, help="Skip the SUV-parameter and PIF-Q sensitivity runs.")
def comma2k19(path, as_json, output, names, no_sensitivity):
    """Score every estimator against the pose-derived roll of a comma2k19 segment at PATH."""
    from .. import estimators
    from ..io import LogError
    from ..validation import markdown, plot, to_json, validate_comma2k19

    sel = list(estimators.NAMES) if names.strip() == "all" else [n.strip() for n in names.split(",") if n.strip()]
    bad = [n for n in sel if n not in estimators.NAMES]
    if bad:
        raise click.BadParameter(f"unknown estimator(s) {bad}", param_hint="--estimators")
    try:
        res = validate_comma2k19(path, names=sel, sensitivity=not no_sensitivity)
    except (LogError, ValueError, OSError) as exc:
        click.echo(f"error: {exc}", err=True)
        sys.exit(1)
    if output is not None:
        fig = output.with_suffix(".png")
        plot(res, fig)
        cmd = f"roadbank validate comma2k19 {path} -o {output}"
        output.parent.mkdir(parents=True, exist_ok=True)
        output.write_text(markdown(res, figure=fig.name, command=cmd))
        click.echo(f"wrote {output} and {fig}", err=True)
    if as_json:
        click.echo(json.dumps(to_json(res), indent=2))
    elif output is None:
        for name, v in to_json(res).items():
            click.echo(f"{name:14s} r = {v['r']:.3f}  rms = {v['rms_deg']:.3f} deg  offset = {v['offset_deg']:+.3f} deg")
