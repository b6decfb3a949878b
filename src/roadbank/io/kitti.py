"""The KITTI raw GNSS/INS ("oxts") layout: one drive -> :class:`~roadbank.io.Log`.

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
12  ay     specific force along the vehicle's left axis (m/s^2)         ``ay``
19  wz     angular rate about the vehicle's up axis (rad/s)             ``r``
==  =====  ==========================================================  ================

There is no steering angle: ``delta_f`` is NaN (the modified-model estimators
do not read it; the others flag every sample not valid). The frames stay on
their own, jittered time stamps (about 10 Hz, 0.06-0.14 s apart): the
estimators take any step (:mod:`roadbank.estimators.base`), so nothing is
resampled. Time is in seconds from the first frame; its UTC stamp is
``metadata["time_origin"]``.

Malformed input (decided per kind, see docs/io.md):

* an unparsable time stamp, a time stamp not later than the previous one, a
  data file with the wrong number of fields or a non-numeric field, a data file
  numbered beyond the time stamps -> :class:`LogError` naming the file and the
  line. These mean a corrupted or edited download; guessing would silently
  misalign the columns or the clock.
* a data file missing from the numbering (a time stamp without its frame) ->
  the frame is dropped and counted (``metadata["dropped_frames"]`` and a
  warning): the remaining frames keep their true time stamps, so a missing
  frame is just a longer step, which the estimators handle.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from ..signals import Signals
from .consistency import check_consistency
from .errors import LogError
from .types import Log

#: fields per oxts frame (dataformat.txt)
N_FIELDS = 30
#: 0-based column of each channel
COLUMNS = {"lat": 0, "lon": 1, "roll": 3, "vf": 8, "vl": 9, "ay": 12, "wz": 19}

_STAMP = re.compile(r"^(\d{4}-\d{2}-\d{2}) (\d{2}:\d{2}:\d{2})(?:\.(\d{1,9}))?$")
_FRAME = re.compile(r"^(\d+)\.txt$")


def is_oxts_dir(p: Path) -> bool:
    """True if ``p`` is an ``oxts`` folder (``timestamps.txt`` and ``data/``)."""
    return (p / "timestamps.txt").is_file() and (p / "data").is_dir()


def find_oxts_dirs(path) -> list[Path]:
    """Every oxts folder at ``path``: the folder itself, a drive folder, or a folder of drives.

    Returns a sorted list (empty if there is none).
    """
    p = Path(path)
    if not p.is_dir():
        return []
    if is_oxts_dir(p):
        return [p]
    if is_oxts_dir(p / "oxts"):
        return [p / "oxts"]
    return sorted(d / "oxts" for d in p.iterdir() if d.is_dir() and is_oxts_dir(d / "oxts"))


def drive_name(oxts: Path) -> str:
    """The drive's name: the folder holding ``oxts/`` (e.g. ``2011_10_03_drive_0047_sync``)."""
    oxts = Path(oxts)
    return oxts.parent.name if oxts.name == "oxts" else oxts.name


def parse_timestamps(path) -> np.ndarray:
    """Read ``timestamps.txt``: seconds since the epoch (UTC, float64, ns resolution kept to ~0.1 us).

    Blank lines at the end are ignored. Raises :class:`LogError` naming the
    file and line for an unparsable or non-increasing time stamp.
    """
    p = Path(path)
    lines = p.read_text(errors="replace").splitlines()
    while lines and not lines[-1].strip():
        lines.pop()
    if not lines:
        raise LogError(f"{p}: no time stamps")
    t = np.empty(len(lines))
    for i, line in enumerate(lines):
        m = _STAMP.match(line.strip())
        try:
            if m is None:
                raise ValueError
            whole = np.datetime64(f"{m.group(1)}T{m.group(2)}", "s")
        except ValueError:
            raise LogError(f"{p}: line {i + 1}: unparsable time stamp {line.strip()!r} "
                           "(expected 'YYYY-MM-DD hh:mm:ss.fffffffff')") from None
        frac = m.group(3) or "0"
        t[i] = whole.astype(np.int64) + int(frac) / 10 ** len(frac)
        if i and t[i] <= t[i - 1]:
            raise LogError(f"{p}: line {i + 1}: time stamp {line.strip()!r} is not later than "
                           f"line {i}'s (time stamps out of order)")
    return t


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
        ``lon_deg``; ``metadata``: dataset, drive, time_origin (UTC),
        dropped_frames.

    Raises
    ------
    LogError
        Not a KITTI drive, several drives, or malformed files (see the module docstring).
    """
    p = Path(path)
    found = find_oxts_dirs(p)
    if not found:
        raise LogError(f"{p}: not a KITTI raw drive (no oxts/timestamps.txt and oxts/data/)")
    if len(found) > 1:
        raise LogError(f"{p}: holds {len(found)} KITTI drives ({', '.join(drive_name(d) for d in found)}); "
                       "give one drive folder")
    oxts = found[0]
    stamps = parse_timestamps(oxts / "timestamps.txt")
    frames = {}
    for f in sorted((oxts / "data").iterdir()):
        m = _FRAME.match(f.name)
        if m is None or not f.is_file():
            continue
        k = int(m.group(1))
        if k >= len(stamps):
            raise LogError(f"{f}: frame {k} has no time stamp ({oxts / 'timestamps.txt'} has "
                           f"{len(stamps)} lines)")
        frames[k] = f
    keep = np.array(sorted(frames), dtype=np.int64)
    dropped = len(stamps) - len(keep)
    if len(keep) < 2:
        raise LogError(f"{oxts / 'data'}: {len(keep)} frame file(s); at least 2 are needed")
    X = np.vstack([parse_frame(frames[k]) for k in keep])
    t_abs = stamps[keep]
    t = t_abs - t_abs[0]
    c = COLUMNS
    try:
        sig = Signals(t, X[:, c["vf"]], X[:, c["ay"]], X[:, c["wz"]], np.full(len(t), np.nan))
    except ValueError as exc:
        raise LogError(f"{oxts}: {exc}") from None
    warns = []
    if dropped:
        missing = sorted(set(range(len(stamps))) - set(keep.tolist()))
        warns.append(f"{oxts / 'data'}: {dropped} frame file(s) missing from the numbering "
                     f"(first: {missing[0]:010d}.txt): dropped, the others keep their time stamps")
    warns += check_consistency(sig, oxts, {"speed": "vf (column 8)", "lateral_acceleration": "ay (column 12)",
                                           "yaw_rate": "wz (column 19)"})
    origin = (oxts / "timestamps.txt").read_text(errors="replace").splitlines()[int(keep[0])].strip()
    meta = {"dataset": "kitti-raw", "drive": drive_name(oxts), "time_origin": f"{origin} UTC",
            "dropped_frames": str(dropped), "frames": str(len(keep))}
    return Log(signals=sig, reference_roll=X[:, c["roll"]].copy(), source=oxts, format="kitti-oxts",
               metadata=meta, warnings=warns,
               extra={"lat_deg": X[:, c["lat"]].copy(), "lon_deg": X[:, c["lon"]].copy(),
                      "vl_mps": X[:, c["vl"]].copy()})
