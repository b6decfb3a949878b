"""``load_log``: any supported file -> :class:`Log` (validated :class:`~roadbank.Signals`, SI, ISO 8855).

A log read whole is its stream (:func:`~roadbank.io.stream.stream_log`) in one chunk: the same
source and the same assembler (:mod:`roadbank.io.assemble`), so both give the same samples.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..params import VehicleParams
from ..signals import concat_signals
from .channels import ChannelMap
from .stream import log_chunks
from .timebase import add_counts
from .types import Log


def load_log(path, channels: ChannelMap | str | Path | None = None, format: str | None = None,
             params: VehicleParams | None = None) -> Log:
    """Read one log into SI / ISO 8855 signals on one time base.

    Parameters
    ----------
    path : path-like
        A CSV, Parquet or MDF4 file, a comma2k19 segment directory, or a KITTI raw
        drive (its ``oxts`` folder, the drive folder or a folder holding one drive).
    channels : ChannelMap or path to a TOML channel map, optional
        Default: roadbank's own columns (what ``roadbank simulate`` writes).
        Not used for comma2k19 (fixed layout).
    format : str, optional
        "csv", "parquet", "mdf4", "comma2k19" or "kitti-oxts"; default from the
        suffix or the directory layout.
    params : VehicleParams, optional
        Supplies the steering ratio when the map gives a steering-wheel angle
        and no ``steering_ratio`` of its own.

    Raises
    ------
    LogError
        For every kind of bad input, naming the file, the channel and the problem.
    """
    return concat_logs(list(log_chunks(path, channels, format, params, chunk_rows=None)))


def concat_logs(chunks: list[Log]) -> Log:
    """Consecutive chunks of one log as one :class:`Log` (the first chunk's metadata and map)."""
    if len(chunks) == 1:
        return chunks[0]
    first = chunks[0]

    def joined(get) -> dict:
        return {k: np.concatenate([get(c)[k] for c in chunks]) for k in get(first)}

    repairs: dict = {}
    for c in chunks:
        repairs = add_counts(repairs, c.time_repairs)
    roll = None if first.reference_roll is None else np.concatenate([c.reference_roll for c in chunks])
    return Log(signals=concat_signals([c.signals for c in chunks]), reference_roll=roll, source=first.source,
               format=first.format, metadata=first.metadata, truth=joined(lambda c: c.truth),
               warnings=[w for c in chunks for w in c.warnings], channel_map=first.channel_map,
               extra=joined(lambda c: c.extra), time_repairs=repairs)
