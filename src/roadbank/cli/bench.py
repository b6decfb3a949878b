"""``roadbank bench``: parse the options, run :mod:`roadbank.bench`, print or write the report."""

from __future__ import annotations

import json
import shlex
import sys
from pathlib import Path

import click

from .options import PathOption, checked_output


@click.command()
@click.option("-o", "--output", type=PathOption(path_type=Path), default=None, callback=checked_output(),
              help="Write the report here: markdown (e.g. docs/benchmarks.md), or a self-contained page for .html.")
@click.option("--quick", is_flag=True, help="Shorter repeats and peers; finishes within 45 s (no reproduce).")
@click.option("--tiny", is_flag=True, help="A 10 s log, for tests: checks the runner, not the speed.")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object with all results on stdout.")
@click.option("--fleet-logs", type=click.IntRange(min=0), default=0, show_default=True, metavar="N",
              help="Also run a fleet at scale: N Parquet logs of 10 min at 100 Hz end to end on 1 and 2 "
                   "workers (written to a temporary folder, about 1 MB a log; 0: not run).")
@click.option("--data", type=PathOption(exists=True, file_okay=False, path_type=Path), default=None, metavar="DIR",
              help="Also score the default's targets on the real data sets under DIR (e.g. ../shared/data: KITTI "
                   "drives, comma2k19 segments), as `roadbank validate all` does; not timed.")
def bench(output, quick, tiny, as_json, fleet_logs, data):
    """Benchmark the estimators, the plant, cold start and reproduce against peers and speed targets."""
    size = "tiny" if tiny else "quick" if quick else "full"
    # one BLAS thread: set for every command by roadbank.runtime when roadbank.cli loads
    from ..bench import markdown, run_suite, to_json
    from ..report.html import write_document
    command = "roadbank bench" + "".join(f" {a}" for a in sys.argv[2:]) if sys.argv[1:2] == ["bench"] \
        else "roadbank bench" + (f" -o {output}" if output else "") + (f" --{size}" if size != "full" else "")
    options = {k: v for k, v in (("fleet_logs", fleet_logs), ("data", data and str(data))) if v}
    res = run_suite(size, progress=lambda msg: click.echo(f"[bench] {msg}", err=True), options=options or None)
    if output is not None:
        output.parent.mkdir(parents=True, exist_ok=True)
        write_document(output, markdown(res, shlex.join(shlex.split(command))), "roadbank benchmarks")
        click.echo(f"wrote {output}", err=True)
    if as_json:
        click.echo(json.dumps(to_json(res), indent=1))
    elif output is None:
        click.echo(markdown(res, command))
