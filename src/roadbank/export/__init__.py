"""Export a designed estimator as self-contained C99 code (``roadbank export c``).

>>> from roadbank import estimators
>>> from roadbank.export import export_c
>>> files = export_c(estimators.make("pif-modified"), "out/", rate=100.0)   # doctest: +SKIP

Every estimator whose runtime is a speed-scheduled linear observer (the ``lpv``
kernel: kinematic, UIO, PIO, steady-state PIF, Kalman and any new variant on
that kernel) exports; the others raise :class:`NotExportable` saying why.
:class:`CModule` compiles a generated module and runs it through ctypes;
:func:`measure_c_step_ns` times its step function.
"""

from __future__ import annotations

import dataclasses
import tempfile
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..constants import G
from ..estimators.offsets import OnlineOffsets
from .build import CompilerError, build_driver, compile_c
from .ccode import generate
from .design import ExportDesign, NotExportable, check_exportable, export_design
from .grade_c import add_grade
from .loader import CModule
from .offsets_c import add_offsets

__all__ = ["export_c", "ExportResult", "ExportDesign", "NotExportable", "CompilerError", "CModule",
           "check_exportable", "export_design", "generate", "measure_c_step_ns", "build_driver",
           "compile_c", "synthetic_drive"]


@dataclass(frozen=True)
class ExportResult:
    """Files written by :func:`export_c` and the design they hold.

    ``header``, ``source``, ``readme`` are paths; ``table_bytes`` the flash of the tables.
    """

    header: Path
    source: Path
    readme: Path
    design: ExportDesign
    float32: bool

    @property
    def table_bytes(self) -> int:
        return self.design.table_bytes(self.float32)


def export_c(est, out_dir, *, rate: float, float32: bool = False, module_name: str | None = None,
             discrete: bool | None = None, offsets: Mapping[str, float] | None = None) -> ExportResult:
    """Write ``roadbank_<name>.h/.c`` and ``README_roadbank_<name>.md`` of ``est`` into ``out_dir``.

    Parameters
    ----------
    est : Estimator
        A designed estimator on the ``lpv`` kernel (its tables are exported as they are), or
        one behind the online offset learner (:func:`roadbank.estimators.with_online_offsets`):
        the module then also has ``<prefix>_offsets_*`` and ``<prefix>_step_learning``
        (:mod:`.offsets_c`). The gyro-aided filter (:class:`~roadbank.estimators.gyro.KinematicGyro`) reads the
        roll rate as its first input and, with a grade correction, has ``<prefix>_grade_*`` and
        ``<prefix>_roll_rate`` (:mod:`.grade_c`).
    out_dir : path
        Output directory (created if missing).
    rate : float
        Nominal sample rate (Hz) of the target.
    float32 : bool
        Single precision (tables, state and arithmetic); default double.
    module_name : str, optional
        Module name: files ``roadbank_<module_name>.*`` and symbols ``roadbank_<module_name>_*``
        (non-identifier characters become ``_``); default the estimator's name.
    discrete : bool or None
        Add the fixed-rate tables for ``rate``; None: as the estimator runs in Python
        (see :func:`export_design`).
    offsets : mapping, optional
        Sensor offsets to take off the measured channels in every function that takes them (measured minus true,
        SI): ``{"r": rad/s, "ay": m/s^2, "delta_f": rad}``, as ``roadbank estimate --vehicle`` removes a vehicle
        file's identified offsets (:attr:`roadbank.vehicle.Vehicle.sensor_offsets`); default none.

    Raises
    ------
    NotExportable
        When the estimator's runtime is not a scheduled linear observer.
    """
    learner = None
    if isinstance(est, OnlineOffsets):       # the estimator behind the online offset learner
        learner, est = est._ocfg, est.inner
    design = dataclasses.replace(export_design(est, rate, module_name, discrete=discrete),
                                 offsets={k: float(v) for k, v in (offsets or {}).items()}, learner=learner)
    prefix = f"roadbank_{design.ident}"
    files = generate(design, float32=float32)
    if design.grade is not None:
        files = add_grade(files, prefix, design.grade, rate, float32)
    if learner is not None:
        inputs = "delta_f" if design.first_input == "delta_f" else "p" if design.grade is None else "grade"
        files = add_offsets(files, prefix, learner, float32, inputs)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = {}
    for name, text in files.items():
        path = out / name
        path.write_text(text)
        paths[path.suffix] = path
    return ExportResult(paths[".h"], paths[".c"], paths[".md"], design, float32)


def synthetic_drive(rate: float = 100.0, duration: float = 60.0) -> tuple:
    """A deterministic drive for timing (t, vx, ay, r, delta_f; SI): 15-35 m/s, weaving, banked.

    Every sample is usable, so the timing covers the full observer update.
    """
    t = np.arange(0.0, duration, 1.0 / rate)
    vx = 25.0 + 10.0 * np.sin(2 * np.pi * t / 40.0)
    delta = 0.02 * np.sin(2 * np.pi * 0.3 * t)
    r = vx * delta / 2.8
    ay = vx * r + G * np.sin(np.deg2rad(5.0)) * np.sin(2 * np.pi * t / 25.0)
    return t, vx, ay, r, delta


def measure_c_step_ns(est, signals=None, *, rate: float = 100.0, float32: bool = False,
                      discrete: bool | None = None, repeats: int = 5, min_samples: int = 200_000,
                      opt: str = "-O2") -> float:
    """C step cost of ``est`` exported (ns/sample): best of ``repeats`` timed passes.

    Generates the module into a temporary directory, compiles it with a small
    timing loop (``opt``, strict C99 flags) and runs ``<prefix>_step_dt()`` over
    ``signals`` (a :class:`roadbank.Signals`; default :func:`synthetic_drive` at
    ``rate``) at least ``min_samples`` times in one call. ``discrete``: with or without
    the fixed-rate tables for ``rate`` (default: as the estimator runs, see :func:`export_c`).

    Raises
    ------
    NotExportable
        For an estimator that has no C export.
    CompilerError
        When no C compiler is available or it fails.
    """
    if signals is None:
        cols = synthetic_drive(rate)
    else:
        cols = (signals.t, signals.vx, signals.ay, signals.r, signals.delta_f)
    with tempfile.TemporaryDirectory(prefix="roadbank-cbench-") as tmp:
        res = export_c(est, tmp, rate=rate, float32=float32, discrete=discrete)
        return CModule(res.source, tmp, opt=opt).bench_ns(*cols, min_samples=min_samples,
                                                          repeats=repeats)
