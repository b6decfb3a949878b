"""The vehicle file format: :class:`Vehicle` read from and written to TOML, and the shipped cars.

The format (``docs/vehicles.md``): tables ``[meta]``, ``[vehicle]`` (SI numbers or ``"value
unit"`` strings), ``[sensors]``, ``[plant]``, ``[tuning.<estimator>]``, ``[scores.<estimator>]``,
``[identified.<quantity>]``. Every problem in a file raises :class:`VehicleFileError` naming the
file and the key (the value checks: :mod:`roadbank.vehicle.plausibility`).
``load_vehicle(None)`` is the paper's SUV; ``load_vehicle("sedan")`` a shipped car
(:data:`BUILTINS`); ``load_vehicle("car.toml")`` a file.
"""

from __future__ import annotations

import dataclasses
import difflib
import math
import re
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

from ..params import VehicleParams
from .conditions import make_estimator
from .errors import VehicleFileError
from .plausibility import (PLANT_FIELDS, PLAUSIBLE, SENSOR_FIELDS, check_document, check_table_entry, checked_value,
                           unknown_key)
from .sensors import SensorSpec
from .tomltext import fmt_options, fmt_value, is_scalar, toml_key, toml_type, toml_value

# roadbank.estimators and roadbank.sim (numba) are imported inside the functions that use
# them: loading a car (load_vehicle, --vehicle) loads neither

__all__ = ["Vehicle", "load_vehicle", "builtin_names", "BUILTINS", "DEFAULT_VEHICLE", "OFFSET_CHANNELS",
           "tuning_of"]


TABLES = ("meta", "vehicle", "sensors", "plant", "tuning", "scores", "identified")
META_KEYS = ("name", "description", "sources")

#: the roll and geometry data a file may leave out: the SUV's value, scaled by m / m_SUV
#: where marked (keeps the SUV's roll gradient, roll frequency and damping ratio)
_SUV = VehicleParams()
_SCALED_WITH_MASS = ("ms", "Ixx", "k_roll", "c_roll")
REQUIRED_VEHICLE_KEYS = ("m", "Iz", "Lf", "Lr", "Cf", "Cr")


#: ``[identified.<quantity>]`` sensor offsets (measured minus true) -> the Signals channel they
#: are removed from by :meth:`Vehicle.correct`, and their unit (what ``roadbank identify`` writes)
OFFSET_CHANNELS = {"yaw_rate_offset": ("r", "rad/s"), "ay_offset": ("ay", "m/s^2"),
                   "steering_offset": ("delta_f", "rad")}


def _py(v):
    """numpy scalars/arrays and tuples -> Python scalars and lists (what TOML holds)."""
    if hasattr(v, "tolist") and not isinstance(v, (str, bytes)):  # numpy scalar or array
        v = v.tolist()
    if isinstance(v, (list, tuple)):
        return [_py(x) for x in v]
    return v


def _plain(mapping, depth: int):
    """Deep copy of nested mappings into plain dicts of Python values (picklable, comparable)."""
    if not isinstance(mapping, Mapping):
        return mapping  # reported by the checks
    if depth == 0:
        return {str(k): _py(v) for k, v in mapping.items()}
    return {str(k): _plain(v, depth - 1) for k, v in mapping.items()}


def tuning_of(tuning: Mapping, name: str) -> dict:
    """The options the estimator ``name`` is built with from a car's ``[tuning]`` tables ``tuning`` (estimator name ->
    options, :attr:`Vehicle.tuning`): its own table's over that of the estimator whose filter it runs
    (:data:`roadbank.estimators.TUNED_AS`: ``pif-smoother``, ``pif-gated`` and ``kinematic-pif`` run ``pif-modified``);
    {} where neither has one. What :meth:`Vehicle.make`, the rear trim's trial designs and the validations read."""
    from ..estimators import TUNED_AS
    # an estimator tuned as itself looks up None: no table
    return {**tuning.get(TUNED_AS.get(name), {}), **tuning.get(name, {})}


@dataclass(frozen=True, eq=True)
class Vehicle:
    """One car: parameters, sensors, estimator tuning and tool results (see module docstring).

    Parameters
    ----------
    name : str
        Short name (a built-in's name is its file stem, e.g. ``"sedan"``).
    description : str
    sources : tuple of str
        Where the numbers come from.
    params : VehicleParams
        SI parameters of the models, estimators and simulator.
    sensors : SensorSpec
    tuning : mapping
        Estimator name -> keyword options for :func:`roadbank.estimators.make`.
    scores : mapping
        Estimator name -> {metric: value} (written by ``roadbank tune``).
    identified : mapping
        Quantity -> {"value", "std", "unit", "note", ...} (written by ``roadbank identify``).
    plant : mapping
        Simulator-only :class:`roadbank.sim.PlantParams` fields (``drive_power_max``, ``CdA``, ...);
        missing ones take the PlantParams defaults.
    source : str
        The file it was read from ("" if built in code); names it in :meth:`check` errors.
        Not part of equality or of the written file.
    """

    name: str = "suv-paper"
    description: str = ""
    sources: tuple[str, ...] = ()
    params: VehicleParams = field(default_factory=VehicleParams)
    sensors: SensorSpec = field(default_factory=SensorSpec)
    tuning: Mapping[str, Mapping[str, object]] = field(default_factory=dict)
    scores: Mapping[str, Mapping[str, object]] = field(default_factory=dict)
    identified: Mapping[str, Mapping[str, object]] = field(default_factory=dict)
    plant: Mapping[str, float] = field(default_factory=dict)
    source: str = field(default="", compare=False, repr=False)

    __hash__ = None  # type: ignore[assignment]  # holds dicts: not hashable

    def __post_init__(self) -> None:
        if not isinstance(self.params, VehicleParams):
            raise TypeError("Vehicle.params must be a VehicleParams")
        if not isinstance(self.sensors, SensorSpec):
            raise TypeError("Vehicle.sensors must be a SensorSpec")
        set_ = object.__setattr__
        set_(self, "name", str(self.name))
        set_(self, "description", str(self.description))
        set_(self, "sources", tuple(str(s) for s in self.sources))
        set_(self, "tuning", _plain(self.tuning, 1))
        set_(self, "scores", _plain(self.scores, 1))
        set_(self, "identified", _plain(self.identified, 1))
        set_(self, "plant", _plain(self.plant, 0))
        # the same checks as a file gets, with "<vehicle NAME>" as the file
        check_document(self._document(), f"<vehicle {self.name}>")

    # ---- reading and writing -------------------------------------------------------------
    @classmethod
    def from_toml(cls, path: str | Path) -> "Vehicle":
        """Read a vehicle file.

        Raises
        ------
        VehicleFileError
            File missing/unreadable or any problem in it (message names file and key).
        """
        path = Path(path)
        try:
            text = path.read_text(encoding="utf-8")
        except FileNotFoundError:
            raise VehicleFileError(f"{path}: no such vehicle file") from None
        except (OSError, UnicodeDecodeError) as exc:
            raise VehicleFileError(f"{path}: cannot read ({exc})") from None
        return dataclasses.replace(cls.loads(text, source=str(path), default_name=path.stem), source=str(path))

    @classmethod
    def loads(cls, text: str, source: str = "<string>", default_name: str = "vehicle") -> "Vehicle":
        """Parse vehicle-file text; ``source`` names it in error messages."""
        try:
            doc = tomllib.loads(text)
        except tomllib.TOMLDecodeError as exc:
            raise VehicleFileError(f"{source}: TOML syntax error: {exc}") from None
        return _from_document(doc, source, default_name)

    def dumps(self) -> str:
        """The vehicle as TOML text (every field explicit, SI, floats exact via ``repr``)."""
        return _dump_document(self._document(), header=f"roadbank vehicle file: {self.name} (SI units; "
                                                       "format: docs/vehicles.md)")

    def to_toml(self, path: str | Path) -> None:
        """Write :meth:`dumps` to ``path``."""
        Path(path).write_text(self.dumps(), encoding="utf-8")

    def _document(self) -> dict:
        return {
            "meta": {"name": self.name, "description": self.description, "sources": list(self.sources)},
            "vehicle": {f.name: getattr(self.params, f.name) for f in dataclasses.fields(self.params)},
            "sensors": {f.name: getattr(self.sensors, f.name) for f in dataclasses.fields(self.sensors)},
            "plant": dict(self.plant),
            "tuning": {k: dict(v) for k, v in self.tuning.items()},
            "scores": {k: dict(v) for k, v in self.scores.items()},
            "identified": {k: dict(v) for k, v in self.identified.items()},
        }

    # ---- use --------------------------------------------------------------------------------
    def make(self, estimator_name: str, *, log_rate: float | None = None, log_ay_noise: float | None = None,
             log_r_noise: float | None = None, log_ay_floor: float | None = None,
             log_diff_noise: float | None = None, log_roll_rate: float | None = None, log_ax: float | None = None,
             log_gyro_unbiased: float | None = None, log_pitch_rate: float | None = None, **overrides):
        """Build an estimator for this car: its params, sensors and ``[tuning.<name>]`` options.

        :func:`make_estimator` ``(name, self.params, sensors=self.sensors, log_rate=log_rate,
        log_ay_noise=log_ay_noise, **{**tuning, **overrides})``, ``tuning`` the car's
        ``[tuning.<name>]`` table; for an estimator that runs another's filter
        (:data:`roadbank.estimators.TUNED_AS`: ``pif-smoother`` and ``pif-gated`` run
        ``pif-modified``) that one's table with its own table's keys over it. A default-tuned
        PIF without an ``R`` gets the noise densities of this car's sensors at the log's
        conditions: its rate ``log_rate`` (Hz; default the sensor's ``rate``) and the road noise
        of its ``ay`` (``log_ay_noise``, m/s^2) and yaw rate (``log_r_noise``, rad/s), by
        :func:`~roadbank.vehicle.conditions.noise_densities`. ``kinematic-pif`` and
        ``kinematic-smoother`` take the car's model on a quiet log
        (:func:`~roadbank.vehicle.conditions.is_quiet` of the ``ay`` noise floor ``log_ay_floor``,
        m/s^2), this car's sensors giving the data sheet; the blend's low-pass follows the running noise of
        the kinematic acceleration relative to ``log_diff_noise`` (m/s^2), and a loud log with a roll rate
        (``log_roll_rate``) gets the gyro-aided filter (:data:`~roadbank.vehicle.conditions.GYRO_FILTER`), corrected
        for the grade where its longitudinal acceleration follows its speed (``log_ax``), with its own constants
        where that roll rate is documented free of offset (``log_gyro_unbiased``), its pitch from the pitch rate where
        one documented free of offset follows the pitch (``log_pitch_rate``).
        """
        tuning = tuning_of(self.tuning, estimator_name)
        return make_estimator(estimator_name, self.params, sensors=self.sensors, log_rate=log_rate,
                              log_ay_noise=log_ay_noise, log_r_noise=log_r_noise, log_ay_floor=log_ay_floor,
                              log_diff_noise=log_diff_noise, log_roll_rate=log_roll_rate, log_ax=log_ax,
                              log_gyro_unbiased=log_gyro_unbiased, log_pitch_rate=log_pitch_rate,
                              **{**tuning, **overrides})

    @property
    def rear_measured(self) -> bool:
        """Whether the rear cornering stiffness ``params.Cr`` (N/rad) was measured on this car: the file has an
        ``[identified.Cr]`` table (what ``roadbank identify`` writes, or your own) whose ``value`` is that ``Cr``
        within 0.1 %. Such a ``Cr`` is used as it is; any other is trimmed to each log where a softer axle fits it
        clearly better (:func:`roadbank.vehicle.described_car`)."""
        entry = self.identified.get("Cr")
        value = entry.get("value") if isinstance(entry, Mapping) else None
        return (isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)
                and abs(value - self.params.Cr) <= 1e-3 * abs(self.params.Cr))

    @property
    def sensor_offsets(self) -> dict[str, float]:
        """The identified sensor offsets (measured minus true, SI) by :class:`~roadbank.Signals` channel.

        From the ``[identified]`` tables ``roadbank identify`` writes (:data:`OFFSET_CHANNELS`):
        ``{"r": yaw_rate_offset (rad/s), "ay": ay_offset (m/s^2), "delta_f": steering_offset
        (rad, road-wheel angle)}``, only those the vehicle has.

        Raises
        ------
        VehicleFileError
            An offset that is not a finite number or is in another unit than the one above.
        """
        out = {}
        for quantity, (channel, unit) in OFFSET_CHANNELS.items():
            entry = self.identified.get(quantity)
            if entry is None:
                continue
            where = f"{self.source or f'<vehicle {self.name}>'}: [identified.{quantity}]"
            value = entry.get("value")
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
                raise VehicleFileError(f"{where} value = {fmt_value(value)}: need a finite number ({unit})")
            if entry.get("unit", unit) != unit:
                raise VehicleFileError(f"{where} unit = {fmt_value(entry['unit'])}: the offset must be in {unit} "
                                       "(as roadbank identify writes it)")
            out[channel] = float(value)
        return out

    def correct(self, signals):
        """``signals`` with this car's identified sensor offsets subtracted (:attr:`sensor_offsets`).

        What ``roadbank estimate`` / ``roadbank map`` do to every log before estimating when
        given ``--vehicle`` (docs/identification.md). Returns ``signals`` itself when the car
        has no identified offset.

        Parameters
        ----------
        signals : roadbank.Signals
            Measured ESP signals (SI, ISO 8855).

        Returns
        -------
        roadbank.Signals
            ``r - yaw_rate_offset`` (rad/s), ``ay - ay_offset`` (m/s^2), ``delta_f -
            steering_offset`` (rad); ``t`` and ``vx`` unchanged.
        """
        offsets = self.sensor_offsets
        if not offsets:
            return signals

        return dataclasses.replace(signals, **{c: getattr(signals, c) - offsets[c] for c in offsets})

    def check(self) -> "Vehicle":
        """Build every tuned estimator once; a failing design raises :class:`VehicleFileError`.

        Returns ``self`` (chainable). Costs a design per ``[tuning]`` table (~0.2-0.4 s each).
        """
        from ..estimators import NoStabilisingSolution

        for name, options in self.tuning.items():
            try:
                self.make(name)
            except (ValueError, TypeError, NoStabilisingSolution) as exc:
                where = f"{self.source or f'<vehicle {self.name}>'}: [tuning.{name}]"
                key = None if isinstance(exc, NoStabilisingSolution) else self._array_option_at_fault(name, options)
                if key is not None:
                    raise VehicleFileError(f"{where} {key} = {fmt_value(options[key])}: {name} cannot take this "
                                           f"array for {key} (it takes a number, or an array of another "
                                           f"shape)") from None
                raise VehicleFileError(f"{where} {fmt_options(options)}: {exc}") from None
        return self

    def _array_option_at_fault(self, name: str, options: Mapping[str, object]) -> str | None:
        """The first array-valued option of ``[tuning.<name>]`` that fails the design on its own (with the
        table's other, non-array options), where the design builds without the arrays; None: none such.
        An array given where the estimator takes a number fails inside its design with a type error that
        names neither the option nor the table."""
        arrays = [k for k, v in options.items() if isinstance(v, list)]
        base = {k: v for k, v in options.items() if k not in arrays}

        def builds(opts) -> bool:
            try:
                self.with_tuning(name, opts).make(name)
            except (ValueError, TypeError, ArithmeticError):
                return False
            return True

        if not arrays or not builds(base):
            return None
        return next((k for k in arrays if not builds({**base, k: options[k]})), None)

    def to_plant(self, **changes):
        """The simulator's :class:`roadbank.sim.PlantParams` for this car.

        The plant's tyres have the axle cornering stiffnesses ``Cf``, ``Cr`` at static load;
        ``[plant]`` values and then ``changes`` override the PlantParams defaults.
        """
        from ..sim.params import PlantParams

        return PlantParams(vehicle=self.params, **{**self.plant, **changes})

    def simulate(self, scenario: str, condition: str = "nominal", seed: int = 0, **plant_changes):
        """Run a built-in scenario (``roadbank.sim.SCENARIOS``) with this car as plant and sensors.

        Returns
        -------
        roadbank.sim.SimResult
        """
        from ..sim import run_scenario

        return run_scenario(scenario, condition=condition, seed=seed, plant=self.to_plant(**plant_changes),
                            sensors=self.sensors.to_sim())

    # ---- copies -------------------------------------------------------------------------------
    def with_tuning(self, name: str, options: Mapping[str, object],
                    scores: Mapping[str, object] | None = None) -> "Vehicle":
        """Copy with ``tuning[name] = options`` (replaced, not merged) and, if given, ``scores[name]``."""
        tuning = {**self.tuning, name: dict(options)}
        new_scores = {**self.scores, name: dict(scores)} if scores is not None else self.scores
        return dataclasses.replace(self, tuning=tuning, scores=new_scores, source="")

    def with_params(self, **changes: float) -> "Vehicle":
        """Copy with :class:`VehicleParams` fields changed (validated)."""
        return dataclasses.replace(self, params=self.params.replace(**changes), source="")

    def with_sensors(self, **changes: float) -> "Vehicle":
        """Copy with :class:`SensorSpec` fields changed (validated)."""
        return dataclasses.replace(self, sensors=self.sensors.replace(**changes), source="")

    def with_identified(self, identified: Mapping[str, Mapping[str, object]]) -> "Vehicle":
        """Copy with the given ``identified`` quantities added (a quantity present is replaced)."""
        return dataclasses.replace(self, identified={**self.identified, **identified}, source="")

    def replace(self, **changes) -> "Vehicle":
        """Copy with :class:`Vehicle` fields changed (``name``, ``description``, ``sensors`` ...)."""
        return dataclasses.replace(self, **{"source": "", **changes})


def _params_error(source: str, table: str, raw: dict, exc: Exception) -> VehicleFileError:
    """Turn a VehicleParams/SensorSpec validation error into one naming the file and the key:
    the first key of the file the message mentions (else the table)."""
    msg = str(exc)
    text = re.sub(r"\b(?:VehicleParams|SensorSpec)(?:\.|: )", "", msg)
    mentioned = sorted((m.start(), m.group(0)) for key in raw
                       for m in [re.search(rf"\b{re.escape(key)}\b", msg)] if m)
    if mentioned:
        key = mentioned[0][1]
        return VehicleFileError(f"{source}: [{table}] {key} = {fmt_value(raw[key])}: {text}")
    return VehicleFileError(f"{source}: [{table}]: {msg}")


def _from_document(doc: dict, source: str, default_name: str) -> Vehicle:
    for table, value in doc.items():
        if not isinstance(value, dict):
            raise VehicleFileError(f"{source}: {table} = {fmt_value(value) if is_scalar(value) else '...'}: "
                                   f"a key outside any table; keys belong in one of "
                                   f"[{'], ['.join(TABLES[:4])}]")
        if table not in TABLES:
            raise VehicleFileError(f"{source}: [{table}]: {unknown_key(table, TABLES, 'table')}")
    meta = doc.get("meta", {})
    for key in meta:
        if key not in META_KEYS:
            raise VehicleFileError(f"{source}: [meta] {key}: {unknown_key(key, META_KEYS, 'key')}")
    for key in ("name", "description"):
        if key in meta and not isinstance(meta[key], str):
            raise VehicleFileError(f"{source}: [meta] {key} = {fmt_value(meta[key]) if is_scalar(meta[key]) else '...'}"
                                   f": expected a string, got {toml_type(meta[key])}")
    sources = meta.get("sources", [])
    if isinstance(sources, str):
        sources = [sources]
    if not isinstance(sources, list) or not all(isinstance(s, str) for s in sources):
        raise VehicleFileError(f"{source}: [meta] sources: expected an array of strings")

    # [vehicle]: required bicycle-model keys, optional roll data and geometry
    veh_raw = doc.get("vehicle")
    if veh_raw is None:
        raise VehicleFileError(f"{source}: missing table [vehicle] (needs at least "
                               f"{', '.join(REQUIRED_VEHICLE_KEYS)})")
    for key in veh_raw:
        if key not in PLAUSIBLE:
            raise VehicleFileError(f"{source}: [vehicle] {key}: {unknown_key(key, PLAUSIBLE, 'key')}")
    missing = [k for k in REQUIRED_VEHICLE_KEYS if k not in veh_raw]
    if missing:
        raise VehicleFileError(f"{source}: [vehicle] {', '.join(missing)}: missing (required: "
                               f"{', '.join(REQUIRED_VEHICLE_KEYS)})")
    values = {k: checked_value(source, "vehicle", k, v, *PLAUSIBLE[k]) for k, v in veh_raw.items()}
    for key in _SCALED_WITH_MASS:
        values.setdefault(key, getattr(_SUV, key) * values["m"] / _SUV.m)
    try:
        params = VehicleParams(**values)
    except (ValueError, TypeError) as exc:
        raise _params_error(source, "vehicle", veh_raw, exc) from None

    sens_raw = doc.get("sensors", {})
    for key in sens_raw:
        if key not in SENSOR_FIELDS:
            raise VehicleFileError(f"{source}: [sensors] {key}: {unknown_key(key, SENSOR_FIELDS, 'key')}")
    sens_values = {k: checked_value(source, "sensors", k, v, *SENSOR_FIELDS[k]) for k, v in sens_raw.items()}
    try:  # the values' own errors name file, table and key already: only SensorSpec's are re-labelled
        sensors = SensorSpec(**sens_values)
    except (ValueError, TypeError) as exc:
        raise _params_error(source, "sensors", sens_raw, exc) from None

    plant_raw = doc.get("plant", {})
    plant = {}
    for key, value in plant_raw.items():
        if key not in PLANT_FIELDS:
            raise VehicleFileError(f"{source}: [plant] {key}: {unknown_key(key, PLANT_FIELDS, 'key')}")
        plant[key] = checked_value(source, "plant", key, value, *PLANT_FIELDS[key])

    for table in ("tuning", "scores", "identified"):
        for sub, values_ in doc.get(table, {}).items():
            check_table_entry(source, table, sub, values_)
    try:
        return Vehicle(name=meta.get("name", default_name), description=meta.get("description", ""),
                       sources=tuple(sources), params=params, sensors=sensors,
                       tuning=doc.get("tuning", {}), scores=doc.get("scores", {}),
                       identified=doc.get("identified", {}), plant=plant)
    except VehicleFileError as exc:  # cross-field plausibility: re-label with the file
        raise VehicleFileError(re.sub(r"^<vehicle [^>]*>", source, str(exc))) from None


def _dump_document(doc: dict, header: str = "") -> str:
    lines = [f"# {header}", ""] if header else []

    def table(title: str, values: Mapping) -> None:
        lines.append(f"[{title}]")
        lines.extend(f"{toml_key(k)} = {toml_value(v)}" for k, v in values.items())
        lines.append("")

    for name in ("meta", "vehicle", "sensors"):
        table(name, doc[name])
    if doc["plant"]:
        table("plant", doc["plant"])
    for name in ("tuning", "scores", "identified"):
        for sub, values in doc[name].items():
            table(f"{name}.{toml_key(sub)}", values)
    return "\n".join(lines)


# ---------------------------------------------------------------------------------------------
# built-in cars

_BUILTIN_DIR = Path(__file__).resolve().parent.parent / "vehicles"
#: the default car
DEFAULT_VEHICLE = "suv-paper"


def builtin_names() -> tuple[str, ...]:
    """Names of the shipped cars (``src/roadbank/vehicles/*.toml``), default first."""
    names = sorted(p.stem for p in _BUILTIN_DIR.glob("*.toml"))
    return tuple(sorted(names, key=lambda n: n != DEFAULT_VEHICLE))


BUILTINS = builtin_names()


def load_vehicle(spec: "str | Path | Vehicle | None" = None) -> Vehicle:
    """The car ``spec`` names: None = the paper's SUV, a built-in name, or a path to a .toml file.

    Parameters
    ----------
    spec : str, Path, Vehicle or None
        ``None`` -> ``"suv-paper"``; a name from :func:`builtin_names`; a file path.

    Raises
    ------
    VehicleFileError
        Unknown name / missing file, or a malformed file.
    """
    if isinstance(spec, Vehicle):
        return spec
    if spec is None:
        spec = DEFAULT_VEHICLE
    text = str(spec)
    path = Path(spec)
    if isinstance(spec, str) and text in builtin_names() and not path.suffix:
        return Vehicle.from_toml(_BUILTIN_DIR / f"{text}.toml")
    if path.suffix.lower() == ".toml" or path.exists() or "/" in text or "\\" in text:
        return Vehicle.from_toml(path)
    close = difflib.get_close_matches(text, builtin_names(), n=1)
    hint = f"; did you mean '{close[0]}'?" if close else ""
    raise VehicleFileError(f"{text}: not a vehicle file and not a built-in car "
                           f"(built-in: {', '.join(builtin_names())}){hint}")
