"""What a vehicle's values must be: the keys of each table, their dimension and plausible range.

:func:`check_document` checks a document of SI values (read from a file or built from a
:class:`~roadbank.vehicle.Vehicle`): every number finite and within the range of a road vehicle
(passenger car to light van; it catches unit mistakes), the wheelbase, the ``[plant]`` keys, the
``[tuning]`` tables against the options each estimator accepts and the free-form ``[scores]`` /
``[identified]`` tables. Every problem raises :class:`~roadbank.vehicle.VehicleFileError` naming
the source and the key.
"""

from __future__ import annotations

import difflib
import inspect
import math

from ..constants import G, STEERING_RATIO_RANGE
from ..units import SI_UNIT, parse_quantity
from .errors import VehicleFileError
from .tomltext import fmt_value, is_scalar, toml_type

# roadbank.estimators and roadbank.sim (numba) are imported inside the functions that use
# them: loading a car (load_vehicle, --vehicle) loads neither

__all__ = ["PLAUSIBLE", "WHEELBASE_RANGE", "SENSOR_FIELDS", "PLANT_FIELDS", "IDENTIFIED_OFFSETS",
           "IDENTIFIED_QUANTITIES", "checked_value",
           "check_document", "check_identified_offset", "check_table_entry", "check_tuning", "check_tuning_value",
           "check_free_table", "estimator_options", "estimator_option_defaults", "unknown_key"]

#: [vehicle] keys: dimension and plausible range for a road vehicle (passenger car to light
#: van, SI). Outside the range is an error: it catches unit mistakes (mass in tonnes, Cf in
#: N/deg, heights in mm, ...). ``None`` = only VehicleParams' own checks.
PLAUSIBLE: dict[str, tuple[str, tuple[float, float] | None]] = {
    "m": ("mass", (500.0, 5000.0)),
    "Iz": ("inertia", (200.0, 20_000.0)),
    "Lf": ("length", (0.5, 3.0)),
    "Lr": ("length", (0.5, 3.0)),
    "Cf": ("cornering stiffness", (10e3, 1.5e6)),
    "Cr": ("cornering stiffness", (10e3, 1.5e6)),
    "steering_ratio": ("dimensionless", STEERING_RATIO_RANGE),
    "h_cg": ("length", (0.2, 1.6)),
    "h_roll": ("length", (0.0, 1.6)),
    "ms": ("mass", (400.0, 5000.0)),
    "Ixx": ("inertia", (50.0, 6000.0)),
    "k_roll": ("roll stiffness", (5e3, 1e6)),
    "c_roll": ("roll damping", (0.0, 1e5)),
    "roll_stiffness_front_share": ("dimensionless", (0.0, 1.0)),
    "track_f": ("length", (1.0, 2.5)),
    "track_r": ("length", (1.0, 2.5)),
    "wheel_radius": ("length", (0.2, 0.6)),
    "wheel_inertia": ("inertia", (0.1, 20.0)),
    "g": ("acceleration", (9.7, 9.9)),
}
#: plausible wheelbase Lf + Lr (m)
WHEELBASE_RANGE = (1.8, 4.5)
#: the lowest speed (m/s, 180 km/h) at which a vehicle file's car may become unstable by oversteer
#: (:func:`check_critical_speed`); the shipped cars understeer
MIN_CRITICAL_SPEED = 50.0

#: [sensors] keys: dimension, plausible range (SI)
SENSOR_FIELDS: dict[str, tuple[str, tuple[float, float] | None]] = {
    "rate": ("frequency", (10.0, 2000.0)),
    "latency": ("time", (0.0, 0.5)),
    "dropout_prob": ("dimensionless", (0.0, 0.5)),
    "ay_noise": ("acceleration", (0.0, 2.0)),
    "ay_resolution": ("acceleration", (0.0, 0.5)),
    "ay_range": ("acceleration", (0.5 * G, 20.0 * G)),
    "ay_bias": ("acceleration", (-2.0, 2.0)),
    "ay_misalignment": ("angle", (-math.radians(45.0), math.radians(45.0))),
    "r_noise": ("angular rate", (0.0, 0.1)),
    "r_resolution": ("angular rate", (0.0, 0.05)),
    "r_range": ("angular rate", (0.5, 10.0)),
    "r_bias": ("angular rate", (-0.1, 0.1)),
    "speed_noise": ("speed", (0.0, 2.0)),
    "speed_resolution": ("speed", (0.0, 1.0)),
    "steering_noise": ("angle", (0.0, 0.1)),
    "steering_resolution": ("angle", (0.0, 0.1)),
    "steering_range": ("angle", (math.radians(90.0), math.radians(1800.0))),
}

#: [plant] keys (simulator only, :class:`roadbank.sim.PlantParams`): dimension, plausible range
PLANT_FIELDS: dict[str, tuple[str, tuple[float, float] | None]] = {
    "mu": ("dimensionless", (0.05, 1.5)),
    "cornering_scale_front": ("dimensionless", (0.1, 5.0)),
    "cornering_scale_rear": ("dimensionless", (0.1, 5.0)),
    "drive_torque_max": ("torque", (100.0, 20_000.0)),
    "drive_power_max": ("power", (10e3, 1e6)),
    "brake_torque_max": ("torque", (500.0, 50_000.0)),
    "brake_front_share": ("dimensionless", (0.0, 1.0)),
    "CdA": ("area", (0.0, 10.0)),
    "air_density": ("density", (0.0, 2.0)),
    "accel_height": ("length", (-1.0, 1.5)),
    "load_transfer_lag": ("time", (1e-3, 1.0)),
}

#: ``[identified.<offset>]`` tables (sensor offsets, measured minus true, what ``roadbank identify``
#: writes and :meth:`~roadbank.vehicle.Vehicle.correct` removes from every log): the SI unit of their
#: ``value`` and ``std``, the largest plausible ``|value|`` in it and what the offset is (for messages).
#: The limits are those of the sensor biases of ``[sensors]`` (``r_bias``, ``ay_bias``): 0.1 rad/s
#: (5.7 deg/s) of yaw rate, 2 m/s^2 (0.2 g) of ay, and 0.1 rad (5.7 deg) of road-wheel angle, about
#: 90 deg at the steering wheel; a larger value is a unit mistake or a file edited by hand, and would
#: be subtracted from every sample of every log.
IDENTIFIED_OFFSETS: dict[str, tuple[str, float, str]] = {
    "yaw_rate_offset": ("rad/s", 0.1, "yaw-rate sensor offset"),
    "ay_offset": ("m/s^2", 2.0, "lateral-acceleration sensor offset"),
    "steering_offset": ("rad", 0.1, "steering offset (road-wheel angle)"),
}


#: the ``[identified.<quantity>]`` tables ``roadbank identify`` writes (its ``ORDER``). Other tables are the user's
#: own notes, kept as they are, except a name that reads as an offset (``..._offset``, or close to one of
#: :data:`IDENTIFIED_OFFSETS`): a typo there (``yaw_rate_ofset``, ``r_offset``) would leave the offset on every
#: sample, in silence
IDENTIFIED_QUANTITIES = ("Cf", "Cr", "Kus", "steering_offset", "yaw_rate_offset", "ay_offset", "roll_gain")


def check_identified_offset(source: str, quantity: str, entry) -> None:
    """An ``[identified.<offset>]`` table (:data:`IDENTIFIED_OFFSETS`): ``value`` a finite number within
    the plausible range of its SI unit, ``std`` (if given) a finite number >= 0, ``unit`` (if given) that
    unit. Every problem raises :class:`VehicleFileError` naming the source, the table, the key and the
    allowed range or type."""
    unit, limit, what = IDENTIFIED_OFFSETS[quantity]
    where = f"{source}: [identified.{quantity}]"
    if "value" not in entry:
        raise VehicleFileError(f"{where} value: missing (the {what} in {unit})")
    for key in ("value", "std"):
        if key not in entry:
            continue
        v = entry[key]
        shown = f"{where} {key} = {fmt_value(v) if is_scalar(v) else '...'}"
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise VehicleFileError(f"{shown}: expected a number ({unit}), got {toml_type(v)}")
        if not math.isfinite(v):
            raise VehicleFileError(f"{shown}: must be a finite number ({unit})")
        if key == "std" and v < 0:
            raise VehicleFileError(f"{shown}: must be >= 0 {unit}")
        if key == "value" and abs(v) > limit:
            raise VehicleFileError(f"{shown}: outside the plausible range {-limit:g} .. {limit:g} {unit} "
                                   f"for a {what} (unit mistake?)")
    if "unit" in entry and entry["unit"] != unit:
        raise VehicleFileError(f"{where} unit = {fmt_value(entry['unit']) if is_scalar(entry['unit']) else '...'}: "
                               f"the offset must be in {unit} (as roadbank identify writes it)")


def unknown_key(key: str, known, what: str) -> str:
    """The message for an unknown ``key`` among ``known``, with the close match when there is one."""
    close = difflib.get_close_matches(key, list(known), n=1, cutoff=0.6)
    if not close:
        close = [k for k in known if k.lower() == key.lower()][:1]
    hint = f"; did you mean '{close[0]}'?" if close else ""
    return f"unknown {what}{hint} (known: {', '.join(known)})"


def checked_value(source: str, table: str, key: str, raw, dimension: str,
                  rng: tuple[float, float] | None) -> float:
    """One numeric value of a file: number or "value unit" string -> SI float (the SI unit of
    ``dimension``), range-checked against ``rng`` (SI; None: finite only)."""
    where = f"{source}: [{table}] {key} = {fmt_value(raw)}"
    if isinstance(raw, bool) or not isinstance(raw, (int, float, str)):
        raise VehicleFileError(f"{where}: expected a number or a \"value unit\" string, "
                               f"got {toml_type(raw)}")
    if isinstance(raw, str):
        try:
            value = parse_quantity(raw, dimension)
        except ValueError as exc:
            raise VehicleFileError(f"{where}: {exc}") from None
    else:
        value = float(raw)
    if not math.isfinite(value):
        raise VehicleFileError(f"{where}: must be finite")
    unit = SI_UNIT[dimension]
    shown = "" if unit == "-" else f" {unit}"
    if rng is not None and rng[0] > 0 and value <= 0:
        raise VehicleFileError(f"{where}: must be > 0{shown}")
    if rng is not None and rng[0] == 0 and value < 0:
        raise VehicleFileError(f"{where}: must be >= 0{shown}")
    if rng is not None and not rng[0] <= value <= rng[1]:
        si = "" if isinstance(raw, (int, float)) and not isinstance(raw, bool) else f" (= {value:.6g}{shown})"
        raise VehicleFileError(f"{where}{si}: outside the plausible range {rng[0]:g} .. {rng[1]:g}{shown} "
                               f"for a road vehicle (unit mistake?)")
    return value


def check_free_table(source: str, table: str, sub: str, values) -> None:
    """scores/identified/tuning entries: TOML scalars or (nested) arrays of scalars."""
    if not isinstance(values, dict):
        raise VehicleFileError(f"{source}: [{table}.{sub}] must be a table, got {toml_type(values)}")

    def ok(v):
        return is_scalar(v) or (isinstance(v, (list, tuple)) and all(ok(x) for x in v))

    for k, v in values.items():
        if not ok(v):
            raise VehicleFileError(f"{source}: [{table}.{sub}] {k}: expected a number, string, boolean "
                                   f"or array of them, got {toml_type(v)}")


def estimator_option_defaults(name: str) -> dict[str, object] | None:
    """Keyword options ``estimators.make(name, ...)`` accepts and their defaults (None: cannot tell, accept any)."""
    from .. import estimators

    factory = getattr(estimators, "_FACTORIES", {}).get(name)
    if factory is None:
        return None
    fixed = set(getattr(factory, "keywords", None) or ())
    cls = getattr(factory, "func", factory)
    defaults: dict[str, object] = {}
    for klass in (inspect.getmro(cls) if inspect.isclass(cls) else (cls,)):
        init = vars(klass).get("__init__") if inspect.isclass(klass) else klass
        if init is None:            # a mixin without its own __init__: look further up
            continue
        if init is object.__init__:
            break
        try:
            sig = inspect.signature(init)
        except (TypeError, ValueError):
            return None
        for p in sig.parameters.values():
            if (p.kind in (p.KEYWORD_ONLY, p.POSITIONAL_OR_KEYWORD) and p.name not in ("self", "params")
                    and p.name not in fixed):
                defaults.setdefault(p.name, p.default)
        if not any(p.kind is p.VAR_KEYWORD for p in sig.parameters.values()):
            break
    return defaults


def estimator_options(name: str) -> set[str] | None:
    """Keyword options ``estimators.make(name, ...)`` accepts (None: cannot tell, accept any)."""
    defaults = estimator_option_defaults(name)
    return None if defaults is None else set(defaults)


#: tuning options whose default is None that are not numbers: a preset's name (``tuning = "paper"``) and a
#: flag (``adapt_th = true``); every other option defaulting to None takes a number or an array of numbers
NON_NUMERIC_OPTIONS = ("tuning", "adapt_th")


def _is_number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _option_kind(default, key: str) -> str:
    """What an option takes, from its default: ``"number"`` (a number or an array of numbers), ``"flag"``
    (a boolean) or ``"any"`` (a string option such as ``variant``, checked by the estimator)."""
    if isinstance(default, bool):
        return "flag"
    if isinstance(default, str) or key in NON_NUMERIC_OPTIONS:
        return "any"
    if default is None or _is_number(default) or hasattr(default, "dtype") or isinstance(default, (tuple, list)):
        return "number"
    return "any"


def _array_problem(v) -> str | None:
    """Why a (nested) array is not a rectangular array of finite numbers; None if it is one."""
    if not v:
        return "expected a number or an array of numbers, got an empty array"
    if all(isinstance(x, list) for x in v):
        lengths = {len(x) for x in v}
        if len(lengths) > 1:
            return f"its rows differ in length ({', '.join(str(len(x)) for x in v)}); an array must be rectangular"
        for x in v:
            why = _array_problem(x)
            if why:
                return why
        return None
    for x in v:
        if not _is_number(x):
            return f"its elements must all be numbers, one is {toml_type(x)}"
        if not math.isfinite(x):
            return f"its elements must be finite, one is {fmt_value(x)}"
    return None


def _shape(v) -> tuple[int, ...]:
    """Shape of a rectangular (nested) list."""
    return (len(v), *_shape(v[0])) if isinstance(v, (list, tuple)) and v else ((0,) if isinstance(v, list) else ())


def _fmt_default(v) -> str:
    """A default tuple (of tuples) of numbers as TOML-like text with 6 significant digits, for messages."""
    return "[" + ", ".join(map(_fmt_default, v)) + "]" if isinstance(v, (list, tuple)) else f"{float(v):.6g}"


def check_tuning_value(source: str, name: str, key: str, value, default=None) -> None:
    """One ``[tuning.<name>]`` value: every number finite (arrays included), arrays rectangular arrays of
    numbers; an option that takes a number (its default a number or None, :func:`_option_kind`) a number or
    an array, never a string or a boolean; a flag a boolean. Raises :class:`VehicleFileError` naming the
    source, the table and the key; the estimator's own checks (ranges, a design) run when it is built."""
    kind = _option_kind(default, key)
    where = f"{source}: [tuning.{name}] {key} = {fmt_value(value)}"
    if isinstance(value, list):
        why = _array_problem(value)
        if why:
            raise VehicleFileError(f"{where}: {why}")
        if kind == "flag":
            raise VehicleFileError(f"{where}: expected a boolean (true or false), got an array")
        if _is_number(default) or hasattr(default, "dtype") and getattr(default, "ndim", 1) == 0:
            raise VehicleFileError(f"{where}: expected a number, got an array")
        if isinstance(default, (tuple, list)) and _shape(value) != _shape(list(default)):
            raise VehicleFileError(f"{where}: expected an array of shape {_shape(list(default))} (as the default "
                                   f"{_fmt_default(default)}), got shape {_shape(value)}")
        return
    if _is_number(value) and not math.isfinite(value):
        raise VehicleFileError(f"{where}: must be a finite number")
    if kind == "number" and not _is_number(value):
        raise VehicleFileError(f"{where}: expected a number or an array of numbers, got {toml_type(value)}")
    if isinstance(default, (tuple, list)) and _is_number(value):
        raise VehicleFileError(f"{where}: expected an array of shape {_shape(list(default))} (as the default "
                               f"{_fmt_default(default)}), got a number")
    if kind == "flag" and not isinstance(value, bool):
        raise VehicleFileError(f"{where}: expected a boolean (true or false), got {toml_type(value)}")


def check_tuning(source: str, name: str, options) -> None:
    """A ``[tuning.<name>]`` table: a known estimator, TOML values, options its ``make`` accepts, values of
    the type each option takes (:func:`check_tuning_value`)."""
    from .. import estimators

    if name not in estimators.NAMES:
        raise VehicleFileError(f"{source}: [tuning.{name}]: {unknown_key(name, estimators.NAMES, 'estimator')}")
    check_free_table(source, "tuning", name, options)
    defaults = estimator_option_defaults(name)
    for key, value in options.items():
        if defaults is not None and key not in defaults:
            raise VehicleFileError(f"{source}: [tuning.{name}] {key}: "
                                   f"{unknown_key(key, sorted(defaults), f'option of {name}')}")
        check_tuning_value(source, name, key, value, None if defaults is None else defaults[key])


def check_document(doc: dict, source: str) -> None:
    """Plausibility and cross-field checks on a document of SI values (from a file or a Vehicle)."""
    veh = doc["vehicle"]
    for key, (dim, rng) in PLAUSIBLE.items():
        checked_value(source, "vehicle", key, veh[key], dim, rng)
    L = veh["Lf"] + veh["Lr"]
    if not WHEELBASE_RANGE[0] <= L <= WHEELBASE_RANGE[1]:
        raise VehicleFileError(f"{source}: [vehicle] Lf + Lr = {L:.6g} m: wheelbase outside the plausible "
                               f"range {WHEELBASE_RANGE[0]:g} .. {WHEELBASE_RANGE[1]:g} m")
    check_critical_speed(source, veh)
    for key, (dim, rng) in SENSOR_FIELDS.items():
        checked_value(source, "sensors", key, doc["sensors"][key], dim, rng)
    for key, value in doc["plant"].items():
        if key not in PLANT_FIELDS:
            raise VehicleFileError(f"{source}: [plant] {key}: {unknown_key(key, PLANT_FIELDS, 'key')}")
        checked_value(source, "plant", key, value, *PLANT_FIELDS[key])
    for table in ("tuning", "scores", "identified"):
        for sub, values in doc[table].items():
            check_table_entry(source, table, sub, values)


def check_critical_speed(source: str, veh: dict) -> None:
    r"""VehicleFileError for a car whose linear bicycle model oversteers so much that it is unstable below
    :data:`MIN_CRITICAL_SPEED`: with :math:`L_f C_f > L_r C_r` the yaw motion diverges above
    :math:`v_c = L \sqrt{C_f C_r / (m (L_f C_f - L_r C_r))}` (SI values of ``veh``, the ``[vehicle]`` table). Each
    value may be plausible alone (Cf 1.5 MN/rad with Cr 10 kN/rad: 6.4 m/s); road cars understeer."""
    margin = veh["Lf"] * veh["Cf"] - veh["Lr"] * veh["Cr"]
    if margin <= 0:
        return
    L = veh["Lf"] + veh["Lr"]
    v_crit = L * math.sqrt(veh["Cf"] * veh["Cr"] / (veh["m"] * margin))
    if v_crit < MIN_CRITICAL_SPEED:
        raise VehicleFileError(f"{source}: [vehicle] Cf, Cr, Lf, Lr, m: the car oversteers (Lf Cf = "
                               f"{veh['Lf'] * veh['Cf']:.4g} > Lr Cr = {veh['Lr'] * veh['Cr']:.4g} N m/rad) and is "
                               f"unstable above {v_crit:.3g} m/s ({3.6 * v_crit:.0f} km/h); a road car understeers: "
                               "check the cornering stiffnesses and the axle distances (front and rear swapped?)")


def _reads_as_offset(name: str) -> bool:
    """Whether an ``[identified.<name>]`` table's name reads as a sensor offset (see :data:`IDENTIFIED_QUANTITIES`)."""
    low = name.lower()
    return low.endswith(("offset", "ofset", "offs")) or bool(difflib.get_close_matches(low, list(IDENTIFIED_OFFSETS),
                                                                                       n=1, cutoff=0.8))


def check_table_entry(source: str, table: str, sub: str, values) -> None:
    """One ``[tuning.<sub>]``, ``[scores.<sub>]`` or ``[identified.<sub>]`` table, by the check of its kind:
    :func:`check_tuning`, or :func:`check_free_table` (an ``identified`` one that reads as an offset must be one of
    :data:`IDENTIFIED_OFFSETS`) and for a sensor offset :func:`check_identified_offset`."""
    if table == "tuning":
        check_tuning(source, sub, values)
        return
    if table == "identified" and sub not in IDENTIFIED_QUANTITIES and _reads_as_offset(sub):
        raise VehicleFileError(f"{source}: [identified.{sub}]: not an offset roadbank removes: "
                               f"{unknown_key(sub, IDENTIFIED_OFFSETS, 'offset')}")
    check_free_table(source, table, sub, values)
    if table == "identified" and sub in IDENTIFIED_OFFSETS:
        check_identified_offset(source, sub, values)
