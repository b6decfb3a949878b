"""The format registry: the log formats roadbank reads, how they group, and the suffixes that name them.

Plain data, no readers: every module that needs a format name or a suffix takes it from here.
"""

from __future__ import annotations

#: files of numeric columns with a time column (CSV, Parquet) or per-channel clocks (MDF4)
TABLE_FORMATS = ("csv", "parquet", "mdf4")
#: public data sets with a fixed layout: a comma2k19 segment directory, a KITTI raw drive
DATASET_FORMATS = ("comma2k19", "kitti-oxts")
#: raw CAN logs decoded with a DBC (roadbank.io.can)
CAN_FORMATS = ("blf", "asc", "trc", "candump", "mdf4-can")
#: ROS bags / MCAP (roadbank.io.ros)
ROS_FORMATS = ("rosbag1", "rosbag2", "mcap")
#: every format name, as ``--format`` takes it
FORMATS = TABLE_FORMATS + DATASET_FORMATS + CAN_FORMATS + ROS_FORMATS
#: file suffix (lower case) -> format
SUFFIXES = {".csv": "csv", ".txt": "csv", ".tsv": "csv", ".parquet": "parquet", ".pq": "parquet",
            ".mf4": "mdf4", ".mdf": "mdf4", ".mf3": "mdf4", ".blf": "blf", ".asc": "asc", ".trc": "trc",
            ".log": "candump", ".bag": "rosbag1", ".mcap": "mcap", ".db3": "rosbag2"}
