"""The types the log readers share: :class:`RawTable` (the raw columns a format yields),
:class:`RawChunk` (consecutive samples of some of them, what a source gives the assembler) and
:class:`Log` (a log read into SI / ISO 8855 signals)."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..signals import Signals
from .channels import ChannelMap

#: the column under which an MDF4 source read as a table (:meth:`roadbank.io.sources.WholeSource.one_clock`) gives
#: its channel group's time stamps (s)
GROUP_CLOCK = "time"


@dataclass
class RawTable:
    """Columns read from one file.

    Attributes
    ----------
    names : list of str
        Every column / channel name the file has.
    data : dict name -> float64 array
        The requested columns that exist, in stored units.
    times : dict name -> float64 array
        Per-channel time stamps (s) for formats where each channel has its own
        clock (MDF4); empty for tables with a time column.
    metadata : dict
        File-level key/value metadata (Parquet schema metadata, MDF header comment).
    row_label : str
        How rows are counted in messages ("line" for CSV, "row" otherwise).
    rownums : sequence of int or None
        Row number (in that counting) of each data row, for messages (CSV:
        file line numbers, the header being line 1). None for MDF4.
    time_typed : dict name -> str
        Columns whose type carries its own time unit (Parquet ``timestamp`` /
        ``duration``, read as s), with that type, e.g. ``"timestamp[us]"``.
    warnings : list of str
        Suspicious but usable things the reader found (a CSV's last line left out as cut off).
    units : dict name -> str
        The unit the file itself states for a column, as written (a CSV's units row under its header, an MDF4
        channel's unit); empty where it states none (:func:`roadbank.io.assemble.stated_units` reads them).
    groups : dict name -> int
        MDF4: the channel group of each channel read (the channels of one group share its time stamps); empty for
        the other formats.
    """

    names: list[str]
    data: dict[str, np.ndarray]
    times: dict[str, np.ndarray] = field(default_factory=dict)
    metadata: dict[str, str] = field(default_factory=dict)
    row_label: str = "row"
    rownums: object = None
    time_typed: dict[str, str] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)
    units: dict[str, str] = field(default_factory=dict)
    groups: dict[str, int] = field(default_factory=dict)


@dataclass
class RawChunk:
    """Consecutive samples of some channels of one log, in stored units.

    Attributes
    ----------
    data : dict column -> float64 array
        Values as stored.
    times : dict column -> float64 array
        Channel sources: each channel's own stamps (s). Empty for tables.
    rownums : int array or None
        Tables: the number of each row in messages (CSV: its line; Parquet: its row).
    done : tuple of str
        Channel sources: the columns that end with this chunk.
    last : bool
        Tables: the final chunk.
    """

    data: dict
    times: dict = field(default_factory=dict)
    rownums: object = None
    done: tuple = ()
    last: bool = False


@dataclass
class Log:
    """One driving log, ready for the estimators.

    Attributes
    ----------
    signals : Signals
        ``t`` (s), ``vx`` (m/s), ``ay`` (m/s^2), ``r`` (rad/s), ``delta_f`` (rad), ISO 8855.
    reference_roll : array or None
        Reference roll angle (rad, ISO: left side up) on ``signals.t``, if the log has one.
    source : Path
        The file (or segment directory) read.
    format : str
        The format read (a name of :data:`roadbank.io.formats.FORMATS`).
    metadata : dict
        File metadata (e.g. the scenario/condition/seed of a ``roadbank simulate`` Parquet file).
    truth : dict name -> array
        Truth columns (``true_*`` of simulated logs), SI, on ``signals.t``.
    warnings : list of str
        Suspicious but usable things found while reading (e.g. a unit that looks odd).
    channel_map : ChannelMap or None
        The map used (for comma2k19 and kitti-oxts the fixed map of their layout).
    extra : dict name -> array
        Further channels on ``signals.t``, unit in the name (``lat_deg``, ``lon_deg`` for
        maps; kitti-oxts also ``vl_mps``).
    time_repairs : dict kind -> int
        What the time-stamp repair did (:mod:`roadbank.io.timebase`): samples dropped as
        ``missing``, ``duplicate`` or ``out_of_order`` stamps, ``swapped`` pairs reordered,
        ``gaps`` kept, and ``flagged``: samples whose values were set to NaN (the estimators
        flag them not valid). Summed over the channels of a format with per-channel clocks.
    time_repairs_by_channel : dict channel -> dict kind -> int
        The same counts channel by channel: the role of each channel with its own clock (``speed``,
        ``yaw_rate``, ...; the three gyro channels of one file each count its stamps), or ``time`` for
        a table's clock.
    """

    signals: Signals
    reference_roll: np.ndarray | None = None
    source: Path = Path()
    format: str = ""
    metadata: dict = field(default_factory=dict)
    truth: dict = field(default_factory=dict)
    warnings: list = field(default_factory=list)
    channel_map: ChannelMap | None = None
    extra: dict = field(default_factory=dict)
    time_repairs: dict = field(default_factory=dict)
    time_repairs_by_channel: dict = field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.signals)
