"""Reading real logs: CSV, Parquet, MDF4, CAN, ROS, comma2k19 and KITTI raw -> :class:`Log` (SI, ISO 8855).

Entry points: :func:`load_log` (a log whole) and :func:`roadbank.io.stream.stream_log` (the same
log in chunks; :func:`load_log` is that stream in one chunk). Each format is a source of raw
channels (:mod:`roadbank.io.sources`); one assembler (:mod:`roadbank.io.assemble`) makes them a
:class:`Log`. Channel maps (TOML) name the columns and their units / sign convention
(:mod:`roadbank.io.channels`); channels at different rates are put on one time base
(:mod:`roadbank.io.resample`). Every bad input raises :class:`LogError` naming the file, the
channel and the problem.
"""

from .channels import ChannelMap, ChannelSpec, default_channel_map, read_channel_map
from .consistency import check_consistency
from .errors import LogError
from .log import Log, load_log
from .readers import FORMATS, detect_format

__all__ = ["load_log", "Log", "LogError", "ChannelMap", "ChannelSpec", "default_channel_map",
           "read_channel_map", "FORMATS", "detect_format", "check_consistency"]
