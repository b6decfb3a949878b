"""``roadbank export c``: generate a self-contained C99 module of a designed estimator.

Writes ``roadbank_<estimator>.h``, ``roadbank_<estimator>.c`` and
``README_roadbank_<estimator>.md`` (interface, units, footprint) into the output
directory. The module is the Python ``lpv`` kernel written out in C, with the
designed speed schedule as ``static const`` tables (docs/embedded.md).
"""

from __future__ import annotations

import math
from pathlib import Path

import click
import numpy as np

from .options import PathOption, vehicle_offsets, vehicle_option


def _rate(ctx, param, value):
    """``--rate``: a number of Hz within :data:`~roadbank.export.design.RATE_RANGE_HZ` (usage error otherwise)."""
    from ..export.design import RATE_RANGE_HZ       # (the export package loads the estimators)

    lo, hi = RATE_RANGE_HZ
    if value is not None and not (math.isfinite(value) and lo <= value <= hi):
        raise click.BadParameter(f"must be {lo:g} to {hi:g} Hz (the target's sample rate), got {value:g}")
    return value


@click.group()
def export():
    """Export a designed estimator for embedded targets."""


@export.command("c")
@vehicle_option("The estimator is designed for this car, with its [tuning.<estimator>] options; with --log "
                "and no --vehicle, for the shipped car that fits the log, as `roadbank estimate` chooses it.",
                none_if_absent=True)
@click.option("--estimator", "-e", "name", default="pif-modified", show_default=True,
              help="Estimator to export (a speed-scheduled linear observer: kinematic, uio, pio-*, "
                   "pif-* steady-state, kalman, ...).")
@click.option("--rate", type=float, default=None, callback=_rate,
              help="Nominal sample rate of the target (Hz, 1 to 10000); the design is for it (the sensors' noise "
                   "densities at that rate, the default's lead). Default: the sample rate of --log, else the "
                   "vehicle's sensor rate (100).")
@click.option("--float32", "float32", is_flag=True, help="Single precision (tables, state and arithmetic).")
@click.option("--fixed-rate/--no-fixed-rate", "fixed_rate", default=None,
              help="With (default, as roadbank runs the estimator) or without the exact discrete tables "
                   "for --rate: samples at that rate cost one small matrix update, others take the "
                   "general path. Without: about half the flash, up to ~0.03 deg from roadbank's output.")
@click.option("--roll", type=click.Choice(["static", "dynamic", "none"]), default=None,
              help="Roll separation (default: the vehicle's tuning, else static).")
@click.option("--v-step", "v_step", type=float, default=None,
              help="Spacing of the schedule's speed grid (m/s; default 0.25). Coarser: smaller tables.")
@click.option("--v-max", "v_max", type=float, default=None,
              help="Last speed of the schedule (m/s; default 100); faster samples use its gains.")
@click.option("--name", "module_name", default=None,
              help="Module name: files roadbank_<name>.h/.c, symbols roadbank_<name>_* (default: the "
                   "estimator's name). Two tunings of one estimator in one program need two names.")
@click.option("--online-offsets", "online_offsets", is_flag=True,
              help="Add the online sensor-offset learner (<prefix>_step_learning: yaw-rate offset at "
                   "standstill; on straights only with straight_ay set, see docs/estimators.md).")
@click.option("--log", "log", type=PathOption(path_type=Path), default=None,
              help="A recorded drive of the car (any format `roadbank estimate` reads): the module is designed "
                   "for its conditions as `roadbank estimate` designs for it (the road noise of its first minute "
                   "of driving, quiet or loud, the running noise's reference; its sample rate unless --rate).")
@click.option("--roll-rate", "roll_rate", is_flag=True,
              help="With --log: design as `roadbank estimate` does for a log with a roll rate: where the log's "
                   "roll rate is usable and its ay loud, kinematic-pif is the gyro-aided filter, whose module reads "
                   "the roll rate in place of the steering angle and corrects it for the grade "
                   "(<prefix>_roll_rate, from ax and, where the log's pitch rate is an INS's, the pitch rate). "
                   "Without it the module reads the ESP channels (a log's roll rate is not used).")
@click.option("--channels", "channels", type=PathOption(path_type=Path), default=None,
              help="Channel map (TOML) of --log, as for `roadbank estimate` (only with --log).")
@click.option("--format", "fmt", default=None, help="Format of --log (default: from its suffix; only with --log).")
@click.option("--output", "-o", required=True, type=PathOption(file_okay=False, path_type=Path),
              help="Output directory (created if missing).")
def export_c_cmd(vehicle, name: str, rate: float | None, float32: bool, roll: str | None,
                 v_step: float | None, v_max: float | None, module_name: str | None, fixed_rate: bool | None,
                 online_offsets: bool, log: Path | None, roll_rate: bool, channels: Path | None, fmt: str | None,
                 output: Path):
    """Write roadbank_<estimator>.h/.c (C99, no malloc, tables in flash) and its README.

    \b
    roadbank export c --vehicle car.toml -e pif-modified --rate 100 -o ecu/
    roadbank export c -e kinematic-pif --log drive.parquet --rate 100 -o ecu/
    roadbank export c -e kinematic-pif --log drive.parquet --roll-rate -o ecu/
    """
    from .. import estimators
    from ..export import NotExportable, export_c
    from ..export.design import RATE_RANGE_HZ
    from ..estimators import NoStabilisingSolution

    known = estimators.NAMES + estimators.PRESETS + estimators.GYRO      # what estimate takes, each the same filter
    if name not in known:
        raise click.BadParameter(f"unknown estimator '{name}' (choose from {', '.join(known)})",
                                 param_hint="--estimator")
    if log is None:
        for given, option in ((channels, "--channels"), (fmt, "--format"), (roll_rate or None, "--roll-rate")):
            if given is not None:       # would be ignored: a design without a log reads no channel map
                raise click.UsageError(f"{option} describes --log, which is not given (a design for a recorded "
                                       f"drive: --log drive.csv {option} ...)")
    cond, params, car_name = _log_design(log, channels, fmt, vehicle)
    if vehicle is None and params is None:
        from ..vehicle import load_vehicle
        vehicle = load_vehicle()                   # the paper's SUV
    if rate is None:
        rate = cond.get("log_rate") or float(getattr(getattr(vehicle, "sensors", None), "rate", 100.0))
        lo, hi = RATE_RANGE_HZ
        if not (math.isfinite(rate) and lo <= rate <= hi):
            what = f"--log {log}: its sample rate" if cond.get("log_rate") else "the vehicle's sensor rate"
            raise click.UsageError(f"{what} {rate:g} Hz is outside {lo:g} to {hi:g} Hz: give the target's "
                                   "sample rate with --rate")
    if module_name is not None:
        from ..export.design import c_identifier

        try:
            c_identifier(module_name)
        except ValueError as exc:
            raise click.BadParameter(str(exc), param_hint="--name") from None
    overrides = {k: v for k, v in (("roll", roll), ("v_step", v_step), ("v_max", v_max)) if v is not None}
    car_name = car_name or vehicle.name
    try:      # designed for the target's rate (and the log's conditions), as every command designs
        from ..vehicle import for_conditions
        from ..vehicle.conditions import esp_conditions
        # without --roll-rate the C step reads the ESP channels: a roll rate in the log does not choose the
        # gyro-aided filter; an ECU's task runs at its sensors' rate (a held log's conditions are read at it), so the
        # C step takes every sample
        est = for_conditions(name, {**(cond if roll_rate else esp_conditions(cond)), "log_rate": rate,
                                    "log_held": None}, params,
                             vehicle=vehicle, described=params is None, **overrides)
    except (ValueError, TypeError, NoStabilisingSolution) as exc:
        raise click.ClickException(f"{name}: cannot design for vehicle {car_name!r}: {exc}") from None
    if isinstance(est, estimators.HandOver):        # an ECU runs one design: a hand-over is the log tool's
        est = est.inner
    if online_offsets:
        est = estimators.with_online_offsets(est)
    try:
        res = export_c(est, output, rate=rate, float32=float32, module_name=module_name, discrete=fixed_rate,
                       offsets=vehicle_offsets(vehicle, "the measured channels in every C function that takes them"))
    except NotExportable as exc:
        from ..vehicle.conditions import QUIET_FILTER
        inner = getattr(est, "inner", est)
        quiet = name == "kinematic-pif" and not isinstance(inner, (estimators.KinematicPIF, estimators.KinematicGyro))
        why = str(exc).split("not exportable: ", 1)[-1]
        raise click.ClickException(f"{name}: the log is quiet, so {name} is {QUIET_FILTER} for it, not exportable: "
                                   f"{why}" if quiet else str(exc)) from None
    except ValueError as exc:
        raise click.ClickException(f"{name}: cannot export: {exc}") from None
    except OSError as exc:
        raise click.ClickException(f"cannot write into {output}: {exc.strerror or exc}") from None
    d = res.design
    if roll_rate and d.first_input != "p":
        why = ("none, one that does not follow the roll in ay, or a quiet log" if name in ("kinematic-pif",)
               + estimators.GYRO else f"{name} reads none; kinematic-pif and kinematic-gyro do")
        click.echo(f"warning: --log {log}: the module reads the ESP channels: the log's roll rate is not used "
                   f"({why})", err=True)
    click.echo(f"{name} for {car_name} ({'float32' if float32 else 'float64'}, {rate:g} Hz"
               f"{'' if res.design.discrete is None else ' with fixed-rate tables'}, "
               f"{d.n} observer states, roll {est.roll}{_gyro_words(d)}): tables {res.table_bytes} bytes "
               f"({d.ng} speeds x {d.nk}{'' if d.discrete is None else f' + {d.n * d.n + 6 * d.n}'}), "
               f"fingerprint {d.fingerprint(float32)}")
    for path in (res.header, res.source, res.readme):
        click.echo(f"  {path}")


def _gyro_words(d) -> str:
    """What the summary line says of a gyro-aided module (its first input the roll rate, its grade correction)."""
    if d.first_input != "p":
        return ""
    if d.grade is None:
        return ", reads the roll rate"
    return (", reads the roll rate, corrected for the grade by "
            + ("ax and the pitch rate" if d.grade["observer"] is not None else "ax"))


def _log_design(log: Path | None, channels: Path | None, fmt: str | None, vehicle) -> tuple[dict, object, str | None]:
    """``(conditions, params, car name)`` of ``log``: its :func:`roadbank.vehicle.log_conditions` (of its first minute
    of driving) and, when no car is given, the shipped car fitted to it (:func:`roadbank.vehicle.car_for_log`,
    as ``roadbank estimate`` chooses it); ``({}, None, None)`` without a log; with a car, ``params`` its parameters
    where its rear stiffness is trimmed to the log (:func:`roadbank.vehicle.car_for_log`), else None. A log
    that cannot be read is a one-line error naming the file; the reader's warnings (a line left out, a gap
    repaired) are printed as ``warning: ...``, as ``roadbank estimate`` prints them."""
    if log is None:
        return {}, None, None
    from ..fleet.process import trim_words
    from ..io import LogError, load_log, read_channel_map
    from ..vehicle import car_for_log, log_conditions, undescribed_params

    try:
        cmap = read_channel_map(channels) if channels is not None else None
        read = load_log(log, channels=cmap, format=fmt,
                        params=vehicle.params if vehicle is not None else undescribed_params())
    except (LogError, OSError) as exc:
        raise click.ClickException(f"--log: {exc}") from None
    for w in read.warnings:       # what the reader repaired or left out, as `roadbank estimate` says it
        click.echo(f"warning: {w}", err=True)
    signals = read.signals
    cond = log_conditions(signals)
    idle = not math.isfinite(cond.get("log_ay_noise", math.nan))
    if idle:        # nothing measured: the design is the default one, which the user should know
        with np.errstate(invalid="ignore"):
            moving = int(np.sum(np.asarray(signals.vx, dtype=np.float64) >= 5.0))
        what = ("no driving to design on (the speed stays below 5 m/s)" if not moving else
                f"too little driving to design on ({moving} sample(s) at 5 m/s or more)")
        click.echo(f"warning: --log {log}: {what}; using the default design (the data sheet's sensor noise, "
                   "not the log's)", err=True)
    if vehicle is not None:     # its rear stiffness trimmed to the log, as `roadbank estimate --vehicle` does
        car, design = car_for_log(signals, cond, vehicle=vehicle)
        if "rear_trim" not in design:
            return cond, None, None
        click.echo(f"designed for {log.name}: {vehicle.name}{trim_words(design)}", err=True)
        return cond, car, None
    params, design = car_for_log(signals, cond)
    return cond, params, f"{design['car']} ({'the default design for' if idle else 'fitted to'} {log.name})"
