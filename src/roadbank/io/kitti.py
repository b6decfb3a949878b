"""The KITTI raw GNSS/INS ("oxts") layout: one drive as a source of raw channels (:class:`DriveSource`).

A KITTI raw drive holds an ``oxts/`` folder recorded by an OXTS RT3003 GNSS/INS::

    oxts/timestamps.txt          one UTC time stamp per frame, "YYYY-MM-DD hh:mm:ss.fffffffff"
    oxts/data/NNNNNNNNNN.txt     frame NNNNNNNNNN (0-based, 10 digits): one line of 30 values
    oxts/dataformat.txt          the column meanings (not needed to read)

Columns used (0-based; the oxts axes are already ISO 8855, x forward, y left,
z up, so no sign changes):

==  =====  ==========================================================  ================
0   lat    latitude (deg)                                               ``Log.extra``
1   lon    longitude (deg)                                              ``Log.extra``
3   roll   roll angle (rad), positive = left side up (bank + body roll)  reference roll
8   vf     forward speed parallel to the ground (m/s)                   ``vx``
9   vl     leftward speed parallel to the ground (m/s)                  ``Log.extra`` (INS check)
11  ax     specific force along the vehicle's forward axis (m/s^2)      ``ax``
12  ay     specific force along the vehicle's left axis (m/s^2)         ``ay``
17  wx     angular rate about the vehicle's forward axis (rad/s)        ``p``
18  wy     angular rate about the vehicle's left axis (rad/s)           ``Log.extra`` (a wrong axis, for checks)
19  wz     angular rate about the vehicle's up axis (rad/s)             ``r``
==  =====  ==========================================================  ================

There is no steering angle: ``delta_f`` is NaN (the modified-model estimators
do not read it; the others flag every sample not valid). The frames stay on
their own, jittered time stamps (about 10 Hz, 0.06-0.14 s apart): the
estimators take any step (:mod:`roadbank.estimators.base`), so nothing is
resampled (the layout's channel map has ``time_base = "clock"``). Time is in
seconds from the first frame; its UTC stamp is ``metadata["time_origin"]``.

The source is a table (one row a frame) with the layout's fixed channel map
(:func:`channel_map`); the assembler (:mod:`roadbank.io.assemble`) does the
rest, as for any table: units, plausibility, the time base, the consistency
check. Streamed, it parses ``chunk_rows`` frame files a chunk.

Malformed input (decided per kind, see docs/io.md):

* an unparsable time stamp, a data file with the wrong number of fields or a
  non-numeric field, more than half of the data files numbered beyond the time
  stamps -> :class:`LogError` naming the file and the line. These mean a
  corrupted or edited download; guessing would silently misalign the columns or
  the clock.
* a time stamp not later than the one before (repeated, swapped) -> repaired by
  the assembler as in every table (:mod:`roadbank.io.timebase`), with a warning
  naming the frame; no increasing time base at all -> :class:`LogError`.
* a data file missing from the numbering (a time stamp without its frame), a
  blank line inside ``timestamps.txt`` or fewer lines than frames (a frame whose
  stamp was lost: KITTI's recordings lost data now and then) -> the frame is
  dropped and counted (``metadata["dropped_frames"]`` and a warning): every
  stamp is absolute, so the remaining frames keep their true time stamps, and a
  missing frame is just a longer step, which the estimators handle.
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from ..params import VehicleParams
from .assemble import read_whole
from .channels import ChannelMap, ChannelSpec
from .errors import LogError
from .files import not_found, present
from .types import RawChunk

#: fields per oxts frame (dataformat.txt)
N_FIELDS = 30
#: 0-based column of each channel
COLUMNS = {"lat": 0, "lon": 1, "roll": 3, "vf": 8, "vl": 9, "ax": 11, "ay": 12, "wx": 17, "wy": 18, "wz": 19}
#: the time column of the table a drive makes (seconds from the first frame)
TIME = "timestamps.txt"
#: the channels a drive gives (oxts column -> stored unit); their column names: :func:`column`
ROLES = {"speed": ("vf", "m/s"), "lateral_acceleration": ("ay", "m/s^2"), "yaw_rate": ("wz", "rad/s"),
         "roll_rate": ("wx", "rad/s"), "longitudinal_acceleration": ("ax", "m/s^2"), "pitch_rate": ("wy", "rad/s"),
         "reference_roll": ("roll", "rad")}
#: columns carried into ``Log.extra`` as they are (name -> oxts column); on the frames' own clock
CARRIED = {"lat_deg": "lat", "lon_deg": "lon", "vl_mps": "vl"}

_STAMP = re.compile(r"^(\d{4}-\d{2}-\d{2}) (\d{2}:\d{2}:\d{2})(?:\.(\d{1,9}))?$")
_FRAME = re.compile(r"^(\d+)\.txt$")


def is_oxts_dir(p: Path) -> bool:
    """True if ``p`` is an ``oxts`` folder (``timestamps.txt`` and ``data/``); False where it cannot be searched."""
    try:
        return (p / "timestamps.txt").is_file() and (p / "data").is_dir()
    except OSError:
        return False


def find_oxts_dirs(path, broken: bool = False) -> list[Path]:
    """Every oxts folder at ``path``: the folder itself, a drive folder, or a folder of drives.

    ``broken``: also every folder named ``oxts`` that lacks ``timestamps.txt`` or ``data/`` but holds
    another of them, ``dataformat.txt`` or nothing (a drive to report as broken, :func:`broken_drive`,
    rather than to pass over). Returns a sorted list (empty if there is none).
    """
    p = Path(path)

    def found(d: Path) -> bool:
        return is_oxts_dir(d) or (broken and d.name == "oxts" and _kitti_like(d))
    try:
        if not p.is_dir():
            return []
        if found(p):
            return [p]
        if found(p / "oxts"):
            return [p / "oxts"]
        return sorted(d / "oxts" for d in p.iterdir() if d.is_dir() and found(d / "oxts"))
    except OSError:             # a folder that cannot be listed holds no drive we can read (the reader says why)
        return []


def _kitti_like(oxts: Path) -> bool:
    """An ``oxts`` folder with a KITTI file or folder in it, or empty (not one that holds other logs)."""
    try:
        return oxts.is_dir() and (any((oxts / n).exists() for n in ("timestamps.txt", "data", "dataformat.txt"))
                                  or not any(oxts.iterdir()))
    except OSError:
        return False


def broken_drive(path) -> str | None:
    """Why ``path``, a drive folder holding an ``oxts/`` folder (or that folder), is not a readable KITTI
    raw drive: ``"<path>: not a KITTI raw drive (no oxts/timestamps.txt and oxts/data/): oxts/timestamps.txt
    missing"``; None if it is a drive or no KITTI folder at all."""
    p = Path(path)
    oxts = p if p.name == "oxts" else p / "oxts"
    if not _kitti_like(oxts) or is_oxts_dir(oxts):
        return None
    missing = [f"oxts/{n}" for n, ok in (("timestamps.txt", (oxts / "timestamps.txt").is_file()),
                                         ("data/", (oxts / "data").is_dir())) if not ok]
    return f"{p}: not a KITTI raw drive (no oxts/timestamps.txt and oxts/data/): {' and '.join(missing)} missing"


def drive_name(oxts: Path) -> str:
    """The drive's name: the folder holding ``oxts/`` (e.g. ``2011_10_03_drive_0047_sync``)."""
    oxts = Path(oxts)
    return oxts.parent.name if oxts.name == "oxts" else oxts.name


def parse_timestamps(path) -> tuple[np.ndarray, list[str]]:
    """Read ``timestamps.txt``: seconds since the epoch (UTC, float64, ns resolution kept to ~0.1 us), and the
    file's lines (their text, for the time origin as written).

    Blank lines at the end are ignored; a blank line before them is a frame whose stamp was lost (KITTI's
    recordings lost data now and then): NaN. Stamps out of order are returned as they are (the assembler repairs
    them as in every log). Raises :class:`LogError` naming the file and line for an unparsable time stamp, and where
    no line holds a stamp.
    """
    p = Path(path)
    lines = [s.strip() for s in p.read_text(errors="replace").splitlines()]
    while lines and not lines[-1]:
        lines.pop()
    if not lines:
        raise LogError(f"{p}: no time stamps")
    t = np.full(len(lines), np.nan)
    for i, line in enumerate(lines):
        if not line:
            continue
        m = _STAMP.match(line)
        try:
            if m is None:
                raise ValueError
            whole = np.datetime64(f"{m.group(1)}T{m.group(2)}", "s")
        except ValueError:
            raise LogError(f"{p}: line {i + 1}: unparsable time stamp {line!r} "
                           "(expected 'YYYY-MM-DD hh:mm:ss.fffffffff')") from None
        frac = m.group(3) or "0"
        t[i] = whole.astype(np.int64) + int(frac) / 10 ** len(frac)
    if not np.isfinite(t).any():
        raise LogError(f"{p}: no time stamps")
    return t, lines


def parse_frame(path) -> np.ndarray:
    """One ``data/NNNNNNNNNN.txt`` frame -> float64 array of :data:`N_FIELDS` values.

    Raises :class:`LogError` naming the file and line for a wrong field count or
    a non-numeric field (``nan`` is accepted as a missing value).
    """
    p = Path(path)
    lines = [(i + 1, s) for i, s in enumerate(p.read_text(errors="replace").splitlines()) if s.strip()]
    if len(lines) != 1:
        raise LogError(f"{p}: expected one line of {N_FIELDS} values, found {len(lines)} non-blank lines")
    lineno, line = lines[0]
    fields = line.split()
    if len(fields) != N_FIELDS:
        raise LogError(f"{p}: line {lineno}: {len(fields)} fields, expected {N_FIELDS}")
    out = np.empty(N_FIELDS)
    for k, s in enumerate(fields):
        try:
            out[k] = float(s)
        except ValueError:
            raise LogError(f"{p}: line {lineno}: field {k} is not a number: {s!r}") from None
    return out


def _cut_last_frame(frames: dict[int, Path]) -> str | None:
    """Where the last frame file of ``frames`` (frame number -> file) holds one line of fewer than :data:`N_FIELDS`
    fields (cut off while the drive was written, as a CSV's last line may be), it is taken out of ``frames`` and the
    warning saying so returned; None otherwise (any other damage is :func:`parse_frame`'s error when it is read)."""
    if not frames:
        return None
    last = max(frames)
    lines = [s for s in frames[last].read_text(errors="replace").splitlines() if s.strip()]
    if len(lines) != 1 or len(lines[0].split()) >= N_FIELDS:
        return None
    return (f"{frames.pop(last)}: the last frame holds {len(lines[0].split())} of its {N_FIELDS} fields (cut off "
            "while written): left out")


def column(name: str) -> str:
    """The column name of oxts field ``name`` in messages, e.g. ``"vf (column 8)"``."""
    return f"{name} (column {COLUMNS[name]})"


def channel_map() -> ChannelMap:
    """The fixed channel map of a KITTI drive: SI and ISO 8855 as stored, no steering, the frames' own clock; its
    roll rate, ``ax`` and pitch rate free of offset (``Signals.unbiased``: the RT3003 INS applies its Kalman filter's
    gyro and accelerometer bias corrections to the rates and accelerations it outputs, its manual)."""
    ch = {"time": ChannelSpec("time", TIME, "s")}
    for role, (name, unit) in ROLES.items():
        ch[role] = ChannelSpec(role, column(name), unit)
    return ChannelMap(ch, time_base="clock", no_steering=True, source="KITTI raw oxts layout",
                      fixed_layout=True, unbiased=frozenset({"p", "ax", "q"}))


def find_drive(path) -> Path:
    """The one ``oxts`` folder at ``path`` (see :func:`find_oxts_dirs`); LogError for none or several."""
    p = Path(path)
    found = find_oxts_dirs(p)
    if not found and not present(p):
        raise not_found(p)
    if not found:
        raise LogError(broken_drive(p) or f"{p}: not a KITTI raw drive (no oxts/timestamps.txt and oxts/data/)")
    if len(found) > 1:
        raise LogError(f"{p}: holds {len(found)} KITTI drives ({', '.join(drive_name(d) for d in found)}); "
                       "give one drive folder")
    return found[0]


class DriveSource:
    """One KITTI raw drive as a table source (:mod:`roadbank.io.sources`): a row per frame file, the
    columns of :data:`ROLES` and :data:`CARRIED` in their stored units, the time column :data:`TIME`
    (s from the first frame).

    Opening it reads ``timestamps.txt`` and lists ``data/`` (the errors of the module docstring about
    them, the warning for a missing frame); :meth:`chunks` parses the frame files, ``chunk_rows`` a
    chunk (None: all in one).
    """

    shared_clock = True
    row_label = "frame"
    time_typed: dict[str, str] = {}      # text files: no column's type carries a time unit
    units: dict[str, str] = {}           # the data set's units are its reader's

    def __init__(self, path, chunk_rows: int | None = None):
        oxts = find_drive(path)
        stamps, lines = parse_timestamps(oxts / "timestamps.txt")
        frames = {}
        for f in sorted((oxts / "data").iterdir()):
            m = _FRAME.match(f.name)
            if m is None or not f.is_file():
                continue
            frames[int(m.group(1))] = f
        beyond = sorted(k for k in frames if k >= len(stamps))       # numbered past the stamps: their lines lost
        if beyond and 2 * len(beyond) > len(frames):
            raise LogError(f"{frames[beyond[0]]}: frame {beyond[0]} has no time stamp ({oxts / 'timestamps.txt'} has "
                           f"{len(stamps)} lines for {len(frames)} frame files: not this drive's time stamps?)")
        for k in beyond:
            del frames[k]
        blank = [k for k in range(len(stamps)) if not np.isfinite(stamps[k])]      # stamps lost: frames dropped
        missing = [k for k in range(len(stamps)) if k not in frames and np.isfinite(stamps[k])]
        cut = _cut_last_frame(frames)
        for k in blank:
            frames.pop(k, None)
        keep = np.array(sorted(frames), dtype=np.int64)
        dropped = len(stamps) - len(keep) + len(beyond)
        if len(keep) < 2:
            raise LogError(f"{oxts / 'data'}: {len(keep)} frame file(s); at least 2 are needed")
        self.path, self.frames, self.keep = oxts, frames, keep
        t_abs = stamps[keep]
        self.t = t_abs - t_abs[0]
        self.chunk_rows = chunk_rows
        self.whole = chunk_rows is None
        self.channel_map = channel_map()
        self.names = [TIME] + [column(n) for n, _ in ROLES.values()] + list(CARRIED)
        # (never interpolated: on the frames' clock; the gap would apply on another time base)
        self.carried = dict.fromkeys(CARRIED, self.channel_map.max_gap_s)
        self.warnings = []
        if cut:
            self.warnings.append(cut)
        if missing:
            self.warnings.append(f"{oxts / 'data'}: {len(missing)} frame file(s) missing from the numbering "
                                 f"(first: {missing[0]:010d}.txt): dropped, the others keep their time stamps")
        if blank:
            self.warnings.append(f"{oxts / 'timestamps.txt'}: {len(blank)} blank line(s) (first: line "
                                 f"{blank[0] + 1}): their frames have no time stamp and are dropped, the others "
                                 "keep theirs")
        if beyond:
            self.warnings.append(f"{oxts / 'timestamps.txt'} has {len(stamps)} lines: {len(beyond)} frame file(s) "
                                 f"after them (first: {beyond[0]:010d}.txt) have no time stamp and are dropped")
        self.metadata = {"dataset": "kitti-raw", "drive": drive_name(oxts), "time_origin": f"{lines[keep[0]]} UTC",
                         "dropped_frames": str(dropped), "frames": str(len(keep))}

    def close(self) -> None:
        """Nothing to close: each frame file is read and closed in turn."""

    def chunks(self, wanted: dict[str, str] | None = None, prefix: str | None = None) -> Iterator[RawChunk]:
        """The frames, ``chunk_rows`` a chunk, every column (``wanted`` and ``prefix`` are not used: the
        layout is fixed); row numbers are the frame numbers."""
        n = len(self.keep)
        step = self.chunk_rows or n
        for i in range(0, n, step):
            ks = self.keep[i:i + step]
            X = np.vstack([parse_frame(self.frames[int(k)]) for k in ks])
            data = {TIME: self.t[i:i + step]}
            data.update({column(name): X[:, COLUMNS[name]] for name, _ in ROLES.values()})
            data.update({key: X[:, COLUMNS[name]] for key, name in CARRIED.items()})
            yield RawChunk(data, rownums=ks, last=i + step >= n)


def load_kitti_oxts(path):
    """Read one KITTI raw drive into a :class:`~roadbank.io.Log` with the INS roll as reference.

    Parameters
    ----------
    path : path-like
        The ``oxts`` folder, the drive folder holding it, or a folder holding
        exactly one drive folder.

    Returns
    -------
    Log
        ``signals``: t (s from the first frame), vx (m/s), ay (m/s^2), r (rad/s),
        delta_f NaN; ``reference_roll`` (rad, ISO); ``extra``: ``lat_deg``,
        ``lon_deg`` (deg), ``vl_mps`` (m/s, leftward speed); ``metadata``: dataset,
        drive, time_origin (UTC), dropped_frames, frames.

    Raises
    ------
    LogError
        Not a KITTI drive, several drives, malformed files (see the module docstring),
        or values implausible in their unit.
    """
    src = DriveSource(path)
    return read_whole(src, src.channel_map, VehicleParams(), "kitti-oxts")
