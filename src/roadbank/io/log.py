"""``load_log``: any supported file -> :class:`Log` (validated :class:`~roadbank.Signals`, SI, ISO 8855).

A log read whole is its stream (:func:`~roadbank.io.stream.stream_log`) in one chunk: the same
source and the same assembler (:mod:`roadbank.io.assemble`), so both give the same samples.
"""

from __future__ import annotations

from pathlib import Path

from ..params import VehicleParams
from .assemble import concat_logs
from .channels import ChannelMap
from .stream import log_chunks
from .types import Log


def load_log(path, channels: ChannelMap | str | Path | None = None, format: str | None = None,
             params: VehicleParams | None = None) -> Log:
    """Read one log into SI / ISO 8855 signals on one time base.

    Parameters
    ----------
    path : path-like
        A CSV, Parquet or MDF4 file, a raw CAN log, a ROS bag, a comma2k19 segment directory,
        or a KITTI raw drive (its ``oxts`` folder, the drive folder or a folder holding one drive).
    channels : ChannelMap or path to a TOML channel map, optional
        Default: roadbank's own columns (what ``roadbank simulate`` writes); a CSV, Parquet or MDF4 log named
        otherwise is read with the map guessed from its columns where the guess is sure, and a roll rate, ``ax`` or
        pitch rate under another name is read too, each said in ``Log.warnings`` (:mod:`roadbank.io.mapchoice`).
        Not used for comma2k19 and KITTI (fixed layouts, their own maps).
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
