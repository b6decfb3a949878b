"""``roadbank simulate``: run one of the paper's scenarios on the simulation plant.

Writes one table, SI units, one row per sensor sample (100 Hz): the sensor
signals ``t, vx, ay, r, delta_f, steering_wheel_angle`` and the truth columns
``true_phi_b, true_phi, true_theta, true_vy, true_dvy_dt, true_r, true_ay,
true_vx``. ``.parquet`` (scenario, condition and seed in the schema metadata
under ``roadbank.*`` keys) or ``.csv`` (one header line with the column names)
by the output's extension.
"""

from __future__ import annotations

from pathlib import Path

import click

from .options import PathOption, SEED, checked_output, vehicle_option

FORMATS = (".parquet", ".csv")


def write_result(result, path: Path, vehicle: str | None = None) -> None:
    """Write a :class:`roadbank.sim.SimResult` as Parquet or CSV (by extension).

    ``vehicle`` (the car's name) is stored as ``roadbank.vehicle`` in the Parquet metadata.
    """
    import numpy as np

    cols = result.table()
    ext = path.suffix.lower()
    meta = {"roadbank.scenario": result.scenario, "roadbank.condition": result.condition,
            "roadbank.seed": str(result.seed), "roadbank.units": "SI (s, m/s, m/s^2, rad, rad/s)",
            "roadbank.sample_rate_hz": repr(result.sensors.rate)}
    if vehicle is not None:
        meta["roadbank.vehicle"] = vehicle
    if ext == ".parquet":
        import pyarrow as pa
        import pyarrow.parquet as pq

        table = pa.table({k: pa.array(np.asarray(v, dtype=np.float64)) for k, v in cols.items()})
        table = table.replace_schema_metadata({k.encode(): v.encode() for k, v in meta.items()})
        pq.write_table(table, path)
    else:
        data = np.column_stack([np.asarray(v, dtype=np.float64) for v in cols.values()])
        np.savetxt(path, data, delimiter=",", fmt="%.17g", header=",".join(cols), comments="")


@click.command()
@click.argument("scenario")
@click.option("--condition", "-c", default="nominal", show_default=True,
              help="Plant/sensor condition: nominal, low-mu, misaligned, cf120, cf50, cf150.")
@click.option("--seed", type=SEED, default=0, show_default=True, help="Seed of the sensor noise.")
@click.option("--output", "-o", required=True, type=PathOption(dir_okay=False, path_type=Path),
              callback=checked_output(),
              help="Output file, .parquet or .csv.")
@vehicle_option("The simulated car (plant: its parameters and [plant] table; sensors: its [sensors]).")
def simulate(scenario: str, condition: str, seed: int, output: Path, vehicle) -> None:
    """Simulate SCENARIO (the paper's const-bank, bank-lane-change, s-curve, track-lane1,
    track-lane-change; or identification-drive, the test-track drive `roadbank identify`
    needs, docs/identification.md) and write the sensor signals and the truth."""
    from ..sim.scenarios import CONDITIONS, DRIVES, LOST_CONTROL_DEG, SCENARIOS

    if scenario not in SCENARIOS and scenario not in DRIVES:
        raise click.BadParameter(f"unknown scenario '{scenario}' (choose from {', '.join((*SCENARIOS, *DRIVES))})",
                                 param_hint="SCENARIO")
    if condition not in CONDITIONS:
        raise click.BadParameter(f"unknown condition '{condition}' (choose from {', '.join(CONDITIONS)})",
                                 param_hint="--condition")
    if output.suffix.lower() not in FORMATS:
        raise click.BadParameter(f"output must end in .parquet or .csv, got '{output.name}'",
                                 param_hint="--output")
    if not output.parent.exists():
        raise click.ClickException(f"cannot write {output}: directory {output.parent} does not exist")
    result = vehicle.simulate(scenario, condition=condition, seed=seed)
    try:
        write_result(result, output, vehicle=vehicle.name)
    except OSError as exc:
        raise click.ClickException(f"cannot write {output}: {exc.strerror or exc}") from None
    click.echo(f"{scenario} [{condition}, seed {seed}, {vehicle.name}]: {len(result.signals)} samples "
               f"({result.signals.t[-1]:.1f} s) -> {output}")
    beta = result.truth.max_sideslip_deg()
    if beta > LOST_CONTROL_DEG:
        click.echo(f"warning: the car lost control on this drive (sideslip up to {beta:.0f} deg, above "
                   f"{LOST_CONTROL_DEG:g}; the manoeuvre is beyond this car's grip): no estimator's model holds "
                   "there", err=True)
