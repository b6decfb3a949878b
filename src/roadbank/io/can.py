"""Raw CAN logs decoded with a DBC: Vector BLF/ASC, PEAK TRC, candump and MDF4 bus logging.

The frames are read with python-can (BLF, ASC, TRC, candump ``.log``) or, for
ASAM MDF4 bus-logging files (``CAN_DataFrame`` channel groups), straight from
asammdf as arrays; every format is then decoded the same way with cantools and
the user's DBC, so messages and errors do not depend on the container:

* a channel names its signal by ``signal`` and optionally ``message`` (DBC name
  or frame id such as ``"0x130"``); a signal name alone must be unique in the DBC;
* each signal keeps the time stamps of the frames carrying it (s), so signals
  at different rates and with jitter are resampled like MDF4 channels
  (:mod:`roadbank.io.resample`);
* multiplexed signals are taken from the frames whose multiplexer selects them;
* frames of ids the DBC does not know are skipped and counted in a warning.

Needs the optional extra ``can`` (``pip install 'roadbank[can]'``: python-can,
cantools); MDF4 bus logging also needs ``mdf`` (asammdf).
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .errors import LogError
from .files import existing_nonempty, open_mdf
from .formats import CAN_FORMATS
from .types import RawTable


def _need(module: str, path, extra: str = "can"):
    try:
        return __import__(module)
    except ImportError:
        raise LogError(f"{path}: reading raw CAN logs needs the optional dependency {module} "
                       f"(pip install 'roadbank[{extra}]')") from None


@dataclass
class Frames:
    """Raw CAN data frames of one log, in file order.

    Attributes
    ----------
    t : float64 array
        Time stamps (s).
    ids : int64 array
        Arbitration ids (11 or 29 bit, without the extended flag).
    data : list of bytes
        Payloads.
    warnings : list of str
        What the reading left out and said (an ASC line that could not be read).
    """

    t: np.ndarray
    ids: np.ndarray
    data: list
    warnings: list = field(default_factory=list)


def _check_text_complete(p: Path, fmt: str) -> None:
    """A text log cut while being written ends inside a line (or, for ASC, before ``End TriggerBlock``)."""
    with open(p, "rb") as fh:
        fh.seek(0, 2)
        size = fh.tell()
        fh.seek(max(0, size - 256))
        tail = fh.read()
    if not tail.endswith((b"\n", b"\r")):
        raise LogError(f"{p}: truncated {fmt} file (the last line is incomplete)")
    if fmt == "asc" and b"End TriggerBlock" not in tail:
        raise LogError(f"{p}: truncated ASC file (no 'End TriggerBlock' at the end)")


def read_frames(path, fmt: str) -> Frames:
    """All data frames of a raw CAN log (error and remote frames are skipped).

    Parameters
    ----------
    path : path-like
    fmt : str
        One of :data:`CAN_FORMATS`.

    Raises
    ------
    LogError
        Missing, empty, truncated or corrupt file; missing optional dependency.
    """
    p = existing_nonempty(path)
    if fmt == "mdf4-can":
        return _read_mdf4_frames(p)
    can = _need("can", p)
    readers = {"blf": can.BLFReader, "asc": can.ASCReader, "trc": can.TRCReader,
               "candump": can.CanutilsLogReader}
    if fmt not in readers:
        raise LogError(f"{p}: unknown CAN log format '{fmt}' (known: {', '.join(CAN_FORMATS)})")
    if fmt != "blf":
        _check_text_complete(p, fmt)
    t: list[float] = []
    ids: list[int] = []
    data: list[bytes] = []
    frames = 0           # every frame python-can gave but error frames (remote frames counted)
    try:
        reader = readers[fmt](str(p))
        for m in reader:
            frames += not m.is_error_frame
            if m.is_error_frame or m.is_remote_frame:
                continue
            if m.dlc is not None and len(m.data) != m.dlc and not m.is_fd:
                raise LogError(f"{p}: frame {len(t)} (id 0x{m.arbitration_id:X}) has {len(m.data)} data "
                               f"byte(s) but DLC {m.dlc} (truncated or corrupt file)")
            t.append(m.timestamp)
            ids.append(m.arbitration_id)
            data.append(bytes(m.data))
    except LogError:
        raise
    except Exception as exc:  # python-can raises many types on corrupt input
        raise LogError(f"{p}: not a readable {fmt.upper()} CAN log (truncated or corrupt?): "
                       f"{type(exc).__name__}: {exc}") from None
    if fmt == "blf":
        size = p.stat().st_size
        if reader.file_size and size < reader.file_size:
            raise LogError(f"{p}: truncated BLF file ({size} of {reader.file_size} bytes, "
                           f"{len(t)} of {reader.object_count} objects)")
    if not t:
        raise LogError(f"{p}: no CAN data frames in the file")
    warnings = _unread_asc_lines(p, frames) if fmt == "asc" else []
    return Frames(np.asarray(t, dtype=np.float64), np.asarray(ids, dtype=np.int64), data, warnings)


#: an ASC line that starts as a CAN frame does: time, channel, identifier (hex, ``x`` for an extended one) and then
#: the rest or the line's end; or a CAN FD frame's ``CANFD`` line. Error frames, statistics and events do not
_ASC_FRAME = re.compile(rb"^\s*\d+(\.\d+)?\s+(\d+\s+[0-9A-Fa-f]+x?(\s|$)|CANFD\s)")


def _unread_asc_lines(p: Path, frames: int) -> list[str]:
    """The warning for lines of an ASC file that start like CAN frames but python-can did not read (a line cut in
    the middle: python-can passes over it without a word), given the ``frames`` it read (error frames apart)."""
    with open(p, "rb") as fh:
        shaped = sum(1 for line in fh if _ASC_FRAME.match(line))
    if shaped <= frames:
        return []
    return [f"{p}: {shaped - frames} line(s) that start like CAN frames could not be read (cut or corrupt lines), "
            f"left out: their samples are dropouts"]


def _read_mdf4_frames(p: Path) -> Frames:
    mdf = open_mdf(p)
    try:
        try:    # bus-logging time stamps are relative to the file's start time
            start = float(mdf.header.start_time.timestamp())
        except Exception:
            start = 0.0
        if "CAN_DataFrame.ID" not in mdf.channels_db:
            raise LogError(f"{p}: an MDF4 file without CAN bus logging (no CAN_DataFrame channel); "
                           "for signal MDF4 files leave 'dbc' out of the channel map")
        parts = []
        for group, _ in mdf.channels_db["CAN_DataFrame.ID"]:
            try:
                ids = mdf.get("CAN_DataFrame.ID", group=group)
                raw = mdf.get("CAN_DataFrame.DataBytes", group=group).samples
                n = mdf.get("CAN_DataFrame.DataLength", group=group).samples
            except Exception as exc:
                raise LogError(f"{p}: CAN_DataFrame in group {group} unreadable (truncated or corrupt?): "
                               f"{exc}") from None
            parts.append((start + np.asarray(ids.timestamps, dtype=np.float64), np.asarray(ids.samples, np.int64),
                          np.asarray(raw, dtype=np.uint8).reshape(len(n), -1), np.asarray(n, dtype=np.int64)))
    finally:
        mdf.close()
    t = np.concatenate([x[0] for x in parts]) if parts else np.zeros(0)
    if len(t) == 0:
        raise LogError(f"{p}: no CAN data frames in the file")
    ids = np.concatenate([x[1] for x in parts]) & 0x1FFFFFFF
    data = [bytes(row[:k]) for _, _, raw, n in parts for row, k in zip(raw, n)]
    order = np.argsort(t, kind="stable")
    return Frames(t[order], ids[order], [data[i] for i in order])


def load_dbc(cmap):
    """The channel map's DBC as a cantools database (LogError naming the file if it is unusable)."""
    if cmap.dbc is None:
        raise LogError(f"{cmap.source}: a raw CAN log needs a DBC: add dbc = \"car.dbc\" to the channel map")
    p = Path(cmap.dbc)
    cantools = _need("cantools", p)
    if not p.exists():
        raise LogError(f"{p}: DBC file not found (named by the channel map {cmap.source})")
    try:
        return cantools.database.load_file(str(p), database_format="dbc", strict=False)
    except Exception as exc:
        raise LogError(f"{p}: not a readable DBC file: {type(exc).__name__}: {exc}") from None


def _find_message(db, dbc_path, role: str, spec):
    """The DBC message of a channel (by name, by frame id, or the one holding a unique signal)."""
    label = f"{dbc_path}: channel '{role}' (signal '{spec.signal}'"
    if spec.message is not None:
        key = spec.message.strip()
        try:
            if key.lower().startswith("0x") or key.isdigit():
                return db.get_message_by_frame_id(int(key, 0))
            return db.get_message_by_name(key)
        except (KeyError, ValueError):
            known = ", ".join(f"{m.name} (0x{m.frame_id:X})" for m in db.messages[:20])
            raise LogError(f"{label}, message '{key}'): unknown message -- not in the DBC "
                           f"(it has: {known})") from None
    holders = [m for m in db.messages if any(s.name == spec.signal for s in m.signals)]
    if len(holders) != 1:
        what = "in no message" if not holders else \
            f"in several messages ({', '.join(m.name for m in holders)}); add 'message'"
        raise LogError(f"{label}): signal {what} of the DBC")
    return holders[0]


def read_can(path, cmap, fmt: str) -> tuple[RawTable, list[str]]:
    """Decode the channels of ``cmap`` from a raw CAN log.

    Parameters
    ----------
    path : path-like
    cmap : ChannelMap
        With ``dbc`` set and every channel giving ``signal`` (and optionally ``message``).
    fmt : str
        One of :data:`CAN_FORMATS`.

    Returns
    -------
    table : RawTable
        ``data`` / ``times`` keyed by each channel's column (``message.signal``),
        physical values in the DBC's units (the map's ``unit`` converts them); ``units`` the DBC's unit of each
        signal that states one (a map declaring another is warned about, :func:`roadbank.io.assemble.stated_units`).
    warnings : list of str
        E.g. frames of ids the DBC does not know (skipped).

    Raises
    ------
    LogError
        Naming the file, the message and the signal: unknown message or signal,
        a message that never occurs in the log (wrong DBC or bus), frames whose
        length disagrees with the DBC, a truncated or corrupt file.
    """
    p = Path(path)
    db = load_dbc(cmap)
    wanted: dict[int, tuple] = {}          # frame id -> (message, [(role, spec), ...])
    for role, spec in cmap.channels.items():
        if role == "time":
            continue
        if spec.signal is None:
            raise LogError(f"{cmap.source}: channel '{role}': a raw CAN channel needs 'signal' "
                           "(and optionally 'message'), not 'column'")
        msg = _find_message(db, cmap.dbc, role, spec)
        if spec.signal not in {s.name for s in msg.signals}:
            raise LogError(f"{cmap.dbc}: channel '{role}': signal '{spec.signal}' is not in message "
                           f"'{msg.name}' (0x{msg.frame_id:X}); it has: "
                           f"{', '.join(s.name for s in msg.signals)}")
        wanted.setdefault(msg.frame_id, (msg, []))[1].append((role, spec))
    frames = read_frames(p, fmt)
    known = {m.frame_id for m in db.messages}
    unknown = np.unique(frames.ids[~np.isin(frames.ids, list(known))])
    data, times, warns, units = {}, {}, list(frames.warnings), {}
    for fid, (msg, specs) in wanted.items():
        idx = np.flatnonzero(frames.ids == fid)
        if len(idx) == 0:
            present = ", ".join(f"0x{i:X}" for i in np.unique(frames.ids)[:20])
            roles = ", ".join(f"'{r}' (signal '{s.signal}')" for r, s in specs)
            raise LogError(f"{p}: message '{msg.name}' (id 0x{fid:X}) never occurs in the log, so channel "
                           f"{roles} has no samples -- wrong DBC or bus? (ids in the log: {present})")
        names = [s.signal for _, s in specs]
        vals = {n: np.full(len(idx), np.nan) for n in names}
        for k, i in enumerate(idx):
            payload = frames.data[i]
            if len(payload) != msg.length:
                raise LogError(f"{p}: message '{msg.name}' (id 0x{fid:X}), signal '{names[0]}': frame at "
                               f"t = {frames.t[i]:.6f} s has {len(payload)} data byte(s), the DBC says "
                               f"{msg.length} (wrong DBC, or a truncated/corrupt file)")
            try:
                dec = msg.decode(payload, decode_choices=False, scaling=True)
            except Exception as exc:
                raise LogError(f"{p}: message '{msg.name}' (id 0x{fid:X}), signal '{names[0]}': cannot "
                               f"decode the frame at t = {frames.t[i]:.6f} s with the DBC ({exc})") from None
            for n in names:
                v = dec.get(n)          # absent: a multiplexed signal the frame does not carry
                if v is not None:
                    vals[n][k] = float(v)
        tt = frames.t[idx]
        for role, spec in specs:
            unit = str(msg.get_signal_by_name(spec.signal).unit or "").strip()
            if unit:
                units[spec.column] = unit
            v = vals[spec.signal]
            have = np.isfinite(v)
            if not have.any():
                raise LogError(f"{p}: channel '{role}': signal '{spec.signal}' of message '{msg.name}' "
                               f"(id 0x{fid:X}) is in none of its {len(idx)} frames (a multiplexed "
                               "signal whose multiplexer value never occurs?)")
            data[spec.column], times[spec.column] = v[have], tt[have]
    if len(unknown):
        n = int(np.isin(frames.ids, unknown).sum())
        warns.append(f"{p}: {n} frame(s) with {len(unknown)} id(s) not in the DBC skipped "
                     f"({', '.join(f'0x{i:X}' for i in unknown[:10])})")
    return RawTable(sorted(data), data, times=times, metadata={"dbc": str(cmap.dbc)}, row_label="frame",
                    units=units), warns
