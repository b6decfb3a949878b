"""``roadbank identify``: what driving logs tell about a car -> a vehicle file."""

from __future__ import annotations

import json
import math
import re
import sys
from pathlib import Path
from typing import NoReturn

import click

from ..constants import G
from .options import FiniteRange, PathOption, checked_output, vehicle_option

#: ``--ay-max`` (m/s^2): above the corner threshold (``IdentifySettings.corner_ay``, 1 m/s^2; a lower linear
#: range leaves no corner) and at most 1 g (beyond it no tyre is linear)
AY_MAX_RANGE = (1.0, 10.0)
#: the end of the description of a file ``roadbank identify`` writes (an earlier run's is replaced, not added to)
IDENTIFIED_BY = " identified from logs by roadbank identify"
#: ``--straight-bank`` (deg): below ``IdentifySettings``' limit of 20 deg in magnitude
STRAIGHT_BANK_RANGE = (-20.0, 20.0)

#: display unit per quantity: (label, factor from SI)
_DISPLAY = {
    "Cf": ("kN/rad", 1e-3),
    "Cr": ("kN/rad", 1e-3),
    "Kus": ("deg/g", math.degrees(G)),
    "steering_offset": ("deg road wheel", math.degrees(1.0)),
    "yaw_rate_offset": ("deg/s", math.degrees(1.0)),
    "ay_offset": ("m/s^2", 1.0),
    "roll_gain": ("deg/(m/s^2)", math.degrees(1.0)),
}


def format_result(result) -> list[str]:
    """Lines of the text report: one per quantity (value +- 1 sigma, or REFUSED and why; a refused stiffness
    derived from the understeer gradient for the file also DERIVED, value and from what), one per log."""
    lines = []
    for name, q in result.quantities.items():
        unit, k = _DISPLAY.get(name, (q.unit, 1.0))
        if q.ok:
            lines.append(f"  {name:16s} {q.value * k:11.4g} +- {q.std * k:<9.2g} {unit:15s} ({q.note})")
        else:
            lines.append(f"  {name:16s} REFUSED: {q.refused}")
        d = result.derived.get(name)
        if d is not None:
            lines.append(f"  {name:16s} DERIVED: {d.value * k:.4g} +- {d.std * k:.3g} {unit}, written to the file's "
                         f"[vehicle] {name} ({d.note.split('; refused on its own')[0]})")
    for r in result.logs:
        if r.used:
            s = r.seconds
            lines.append(f"  log {r.source}: {s['usable']:.0f} s usable, {s['straight']:.0f} s straight, "
                         f"{r.n_corners} quasi-steady corners ({s['corners']:.0f} s), "
                         f"{r.speed_range[0]:.1f}-{r.speed_range[1]:.1f} m/s" + (f"; {r.problem}" if r.problem else ""))
        else:
            lines.append(f"  log {r.source}: NOT USED: {r.problem}")
    return lines


def result_json(result, failed) -> dict:
    """JSON-ready summary: quantities (SI, or the refusal), a refused stiffness derived for the file (SI, with
    from what), the warnings about the file's stiffnesses, logs used or not, read failures."""
    return {
        "quantities": {k: ({"value": q.value, "std": q.std, "unit": q.unit, "note": q.note} if q.ok
                           else {"refused": q.refused, "unit": q.unit}) for k, q in result.quantities.items()},
        "derived": {k: q.as_identified() for k, q in result.derived.items()},
        "warnings": list(result.warnings),
        "logs": [{"source": str(r.source), "used": r.used, "problem": r.problem,
                  "seconds": {k: float(v) for k, v in r.seconds.items()}, "n_corners": r.n_corners}
                 for r in result.logs] + [{"source": str(p), "used": False, "problem": why} for p, why in failed],
    }


def _stop(error: str, as_json: bool, failed) -> NoReturn:
    """Exit 1 with ``error`` on stderr and, with ``--json``, the summary's keys on stdout (nothing identified; the
    logs not read or not used, with why), so that a script reads JSON whatever happened."""
    click.echo(f"error: {error}", err=True)
    if as_json:
        click.echo(json.dumps({"quantities": {}, "logs": [{"source": str(p), "used": False, "problem": why}
                                                          for p, why in failed], "error": error}, indent=2))
    sys.exit(1)


def _writable(vehicle):
    """The check :func:`roadbank.identification.identify` runs on a Cf, Cr pair with one stiffness derived from
    the understeer gradient: "" when ``vehicle`` with those params passes the vehicle file's checks (plausible
    ranges, stability), else the reason (without the ``<vehicle NAME>: `` prefix)."""
    from ..vehicle import VehicleFileError

    def check(params) -> str:
        try:
            vehicle.replace(params=params)
        except VehicleFileError as exc:
            # a derived value out of range is no unit mistake: the loader's guess at one is left out
            return re.sub(r"^<vehicle [^>]*>: | \(unit mistake\?\)$", "", str(exc))
        return ""
    return check


@click.command()
@click.argument("logs", nargs=-1, required=True, type=PathOption(path_type=Path))
@vehicle_option("Its m, Iz, Lf, Lr, steering ratio and roll data are taken as known; the output starts from it.",
                none_if_absent=True)
@click.option("--channels", "channels", type=PathOption(path_type=Path), default=None,
              help="Channel map (TOML), as for `roadbank estimate`.")
@click.option("--format", "fmt", default=None,
              help="Input format (csv, parquet, mdf4, comma2k19, ...). Default: from the file suffix.")
@click.option("-o", "--output", required=True, type=PathOption(path_type=Path),
              callback=checked_output(suffixes=(".toml",), what="identify writes a vehicle file"),
              help="Vehicle file (.toml) to write: the base car with the identified Cf, Cr (one of them refused: "
                   "derived from the understeer gradient and the other, said as DERIVED) and an [identified] table.")
@click.option("--straight-bank", type=FiniteRange(*STRAIGHT_BANK_RANGE, min_open=True, max_open=True), default=0.0,
              show_default=True,
              help="Assumed mean bank (deg, left side up) of the straights driven; the ay offset is relative "
                   "to it (a 2 % crown draining to the right is 1.15).")
@click.option("--ay-max", type=FiniteRange(*AY_MAX_RANGE, min_open=True), default=4.0, show_default=True,
              help="Linear range (m/s^2): samples with larger |ay| are left out of the stiffness regression.")
@click.option("--json", "as_json", is_flag=True, help="Print the result as JSON on stdout.")
def identify(logs, vehicle, channels, fmt, output, straight_bank, ay_max, as_json):
    """Identify the car behind LOGS: understeer gradient, axle cornering stiffnesses, steering,
    yaw-rate and ay offsets, and the roll gain when the log has a roll reference.

    \b
    roadbank identify drive1.parquet drive2.parquet --vehicle sedan -o my-sedan.toml
    roadbank identify logs/*.csv --channels map.toml --vehicle base.toml -o car.toml

    Each value comes with a standard uncertainty (block bootstrap). A quantity the
    logs do not excite (straight driving only, too slow, too few corners or yaw
    transients) is REFUSED with the reason, never guessed. A log that cannot be
    read, has no usable driving (too short, too slow), lacks the speed, ay or yaw
    rate, or has a steering angle of the wrong sign or size is reported (NOT USED,
    with what is missing) and the others are used; a log without a steering angle
    gives the yaw-rate and ay offsets only (said on its line). A stiffness
    refused while the understeer gradient and the other stiffness are identified
    is derived from them for the file (DERIVED), so that its Cf, Cr give the
    understeer gradient found; where that value is not plausible the base car's
    pair is kept, with a warning when it contradicts that gradient. The file is
    written when anything was identified; the exit code is 0 only when every
    quantity was identified from every log, else 1. Method: docs/identification.md.
    """
    from ..identification import IdentifySettings, identify as run_identify
    from ..io import LogError, load_log
    from .inputs import channel_map_and_logs

    settings = IdentifySettings(straight_bank=math.radians(straight_bank), ay_max=ay_max)  # options in range
    if vehicle is None:         # said: what the identified values rest on is then not the user's car
        from ..vehicle import load_vehicle
        vehicle = load_vehicle(None)
        click.echo(f"warning: no --vehicle: the base car is {vehicle.name}, whose m, Iz, Lf, Lr and steering ratio "
                   f"({vehicle.params.steering_ratio:g}) are taken as known; the understeer gradient, the axle "
                   "stiffnesses and the steering offset rest on them (a wrong steering ratio scales the understeer "
                   "gradient): give your car's file, or a built-in car near it, with --vehicle", err=True)
    cmap, logs = channel_map_and_logs(channels, logs)
    params = vehicle.params
    loaded, failed = [], []
    for path in logs:
        try:
            loaded.append(load_log(path, channels=cmap, format=fmt, params=params))
        except (LogError, ValueError, OSError) as exc:
            failed.append((path, str(exc)))
        except Exception as exc:  # never a traceback for one bad file
            failed.append((path, f"{type(exc).__name__}: {exc}"))
    for path, why in failed:
        click.echo(f"FAILED {why}" if why.startswith(str(path)) else f"FAILED {path}: {why}", err=True)
    for log in loaded:          # what the reader found suspicious, as estimate, map and export say it
        for w in log.warnings:
            click.echo(f"warning: {w}", err=True)
    if not loaded:
        _stop("no log could be read; nothing identified", as_json, failed)
    try:
        result = run_identify(loaded, params, settings, check=_writable(vehicle))
    except Exception as exc:  # never a traceback from the command line
        _stop(f"identification failed: {type(exc).__name__}: {exc}", as_json, failed)
    if not any(r.used for r in result.logs):
        for r in result.logs:
            click.echo(f"NOT USED {r.source}: {r.problem}", err=True)
        failed += [(r.source, r.problem) for r in result.logs]
        _stop("no usable log; nothing identified", as_json, failed)
    if as_json:
        click.echo(json.dumps(result_json(result, failed), indent=2))
        for name, why in result.refusals().items():
            click.echo(f"REFUSED {name}: {why}", err=True)
        for name, q in result.derived.items():
            click.echo(f"DERIVED {name}: {q.value:.6g} +- {q.std:.2g} {q.unit}, {q.note}", err=True)
    else:
        click.echo(f"identified from {sum(r.used for r in result.logs)} of {len(logs)} log(s), "
                   f"base vehicle {vehicle.name}:")
        click.echo("\n".join(format_result(result)))
        if result.refusals():
            click.echo(f"{len(result.refusals())} quantities refused (see REFUSED above)", err=True)
    for w in result.warnings:
        click.echo(f"warning: {w}", err=True)
    identified = result.identified()
    if not identified:
        click.echo("error: nothing could be identified from these logs; no file written", err=True)
        sys.exit(1)
    used = [str(r.source) for r in result.logs if r.used]
    derived_from = {name: "Cr" if name == "Cf" else "Cf" for name in result.derived}     # the other axle's
    parts = (["Cf, Cr"] if "Cf" in identified and "Cr" in identified else []) + \
        [f"{other} (with {name} derived from Kus and {other})" for name, other in derived_from.items()] + \
        (["k_roll (from the roll gain)"] if result.params.k_roll != vehicle.params.k_roll else [])
    derived = {name: {**q.as_identified(), "derived_from": ["Kus", derived_from[name]]}
               for name, q in result.derived.items()}
    what = " and ".join(parts) or "nothing of the [vehicle] table"
    base = re.sub(f"; [^;]*{IDENTIFIED_BY}$", "", vehicle.description or vehicle.name)    # an earlier run's words
    out = vehicle.replace(
        name=output.stem, params=result.params,
        description=f"{base}; {what}{IDENTIFIED_BY}",
        sources=(*vehicle.sources, f"roadbank identify on {len(used)} log(s): {', '.join(used)}"),
    ).with_identified({**identified, **derived})
    try:
        output.parent.mkdir(parents=True, exist_ok=True)
        out.to_toml(output)
    except OSError as exc:
        click.echo(f"error: cannot write {output}: {exc}", err=True)
        sys.exit(1)
    click.echo(f"wrote {output} ({len(identified)} quantities identified"
               + "".join(f"; {name} derived from Kus and {other}, said in [identified.{name}]"
                         for name, other in derived_from.items()) + ")", err=True)
    sys.exit(0 if result.complete and not failed else 1)
