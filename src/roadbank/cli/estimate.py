"""``roadbank estimate``: run estimators on recorded logs."""

from __future__ import annotations

import sys
from pathlib import Path

import click

from .options import vehicle_option


def _parse_estimators(values: tuple[str, ...]) -> list[str]:
    from .. import estimators

    names: list[str] = []
    for v in values:
        for n in (x.strip() for x in v.split(",")):
            if not n:
                continue
            if n == "all":
                names.extend(estimators.NAMES)
            elif n not in estimators.NAMES:
                raise click.BadParameter(f"unknown estimator '{n}' (choose from "
                                         f"{', '.join(estimators.NAMES)} or 'all')",
                                         param_hint="--estimators")
            else:
                names.append(n)
    return list(dict.fromkeys(names)) or ["pif-modified"]


def plot_estimates(path, t, estimates, reference_roll=None, title: str = "") -> None:
    """theta and phi_b (deg) against time, one line per estimator (Agg backend)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    fig, axes = plt.subplots(2, 1, sharex=True, figsize=(9, 6))
    tt = np.asarray(t) - t[0]
    for est in estimates:
        th = np.where(est.valid, np.degrees(est.theta), np.nan)
        pb = np.where(est.valid, np.degrees(est.phi_b), np.nan)
        axes[0].plot(tt, th, lw=0.9, label=est.name)
        axes[1].plot(tt, pb, lw=0.9, label=est.name)
    if reference_roll is not None:
        axes[0].plot(tt, np.degrees(reference_roll), "k--", lw=1.0, label="reference roll")
    axes[0].set_ylabel("theta = bank + roll (deg)")
    axes[1].set_ylabel("phi_b road bank (deg)")
    axes[1].set_xlabel(f"time from {t[0]:.2f} s (s)")
    axes[0].legend(fontsize=8, ncol=3)
    for ax in axes:
        ax.grid(alpha=0.3)
    if title:
        axes[0].set_title(title, fontsize=10)
    fig.tight_layout()
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _unique_stem(stem: str, used: set[str]) -> str:
    s, k = stem, 1
    while s in used:
        k += 1
        s = f"{stem}-{k}"
    used.add(s)
    return s


@click.command()
@click.argument("logs", nargs=-1, required=True, type=click.Path(path_type=Path))
@click.option("--channels", "channels", type=click.Path(path_type=Path), default=None,
              help="Channel map (TOML). Default: roadbank's own columns (roadbank simulate files).")
@click.option("--format", "fmt", type=click.Choice(["csv", "parquet", "mdf4", "comma2k19"]), default=None,
              help="Input format. Default: from the file suffix (a directory = comma2k19 segment).")
@click.option("--estimators", "-e", "est_names", multiple=True, default=("pif-modified",),
              show_default=True, help="Estimators, comma-separated or repeated; 'all' for every one.")
@click.option("-o", "--output", required=True, type=click.Path(path_type=Path),
              help="Output .csv/.parquet for one log; a directory for several (or a path ending in '/').")
@click.option("--output-format", type=click.Choice(["csv", "parquet"]), default="parquet", show_default=True,
              help="Table format of the files written into an output directory.")
@click.option("--plot", type=click.Path(path_type=Path), default=None,
              help="PNG of theta/phi_b (deg) vs time; for several logs, a directory of PNGs.")
@click.option("--steering-ratio", type=float, default=None,
              help="Steering-wheel / road-wheel ratio when the log has a steering-wheel angle "
                   "(default: the channel map's, else VehicleParams' 16).")
@vehicle_option("Every estimator is designed for this car: its parameters and its [tuning] tables.")
def estimate(logs, channels, fmt, est_names, output, output_format, plot, steering_ratio, vehicle):
    """Estimate the road bank angle on recorded LOGS and write t, theta, phi_b, valid per estimator.

    \b
    roadbank estimate drive.parquet -o drive_bank.csv --plot drive.png
    roadbank estimate logs/*.csv --channels car.toml -e kinematic,pif-modified -o out/

    A bad log is reported (name and reason) and skipped; the exit code is 1 if
    any log failed, 0 otherwise. Output columns are SI (rad).
    """
    from .. import estimators
    from ..io import LogError, load_log, read_channel_map
    from ..io.writers import estimate_table, write_table

    names = _parse_estimators(est_names)
    if steering_ratio is not None:
        try:
            vehicle = vehicle.with_params(steering_ratio=steering_ratio)
        except ValueError as exc:
            raise click.BadParameter(str(exc), param_hint="--steering-ratio")
    cmap = None
    if channels is not None:
        try:
            cmap = read_channel_map(channels)
        except LogError as exc:
            click.echo(f"error: {exc}", err=True)
            sys.exit(1)
    batch = len(logs) > 1 or str(output).endswith(("/", "\\")) or output.is_dir()
    if not batch and output.suffix.lower() not in (".csv", ".parquet", ".pq"):
        raise click.BadParameter("for one log, -o must end in .csv or .parquet (or be a directory)",
                                 param_hint="-o")
    params = vehicle.params
    ests = [vehicle.make(n) for n in names]
    failures: list[tuple[Path, str]] = []
    used: set[str] = set()
    written = 0
    with click.progressbar(logs, label=f"estimating ({', '.join(names)})", file=sys.stderr,
                           item_show_func=lambda p: p.name if p else "") as bar:
        for path in bar:
            try:
                log = load_log(path, channels=cmap, format=fmt, params=params)
                results = [e.run(log.signals) for e in ests]
                for w in log.warnings:
                    click.echo(f"\nwarning: {w}", err=True)
                cols = estimate_table(log.signals.t, results, log.reference_roll)
                meta = {"source": str(path), "estimators": ",".join(names),
                        "steering_ratio": str(cmap.steering_ratio if cmap and cmap.steering_ratio
                                              else params.steering_ratio)}
                if batch:
                    stem = _unique_stem(path.stem if path.is_file() else path.name, used)
                    out = output / f"{stem}.bank.{output_format}"
                    png = plot / f"{stem}.png" if plot is not None else None
                else:
                    out, png = output, plot
                write_table(out, cols, meta)
                if png is not None:
                    plot_estimates(png, log.signals.t, results, log.reference_roll, title=str(path))
                written += 1
            except (LogError, ValueError, OSError) as exc:
                failures.append((path, str(exc)))
            except Exception as exc:  # never a traceback for one bad file
                failures.append((path, f"{type(exc).__name__}: {exc}"))
    for path, reason in failures:
        click.echo(f"FAILED {reason}" if reason.startswith(str(path)) else f"FAILED {path}: {reason}",
                   err=True)
    click.echo(f"{written} log(s) written, {len(failures)} failed", err=True)
    sys.exit(1 if failures else 0)
