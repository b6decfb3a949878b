"""The fixed training / validation split of the shared KITTI drives.

Rule, written down before any result was computed on the new drives: the 16 shared
drives (``kitti-oxts`` and ``kitti-oxts-extra``), sorted by name (date, then drive
number), alternate — even positions train, odd positions validate. It splits by
drive (no drive contributes to both), takes no score into account, and puts short
and long, city and rural drives on both sides. Every choice made on real data
(an estimator's cut-off, the default for a car that is not described) is made on
the training drives only; the validation drives are only reported. A drive that is
in neither list (any other KITTI drive) is *unseen*: scored, never used to choose.
"""

from __future__ import annotations

from pathlib import Path

#: the 16 shared drives in name order (the rule's input)
SHARED_DRIVES = (
    "2011_09_26_drive_0009", "2011_09_26_drive_0014", "2011_09_26_drive_0022", "2011_09_26_drive_0028",
    "2011_09_26_drive_0036", "2011_09_26_drive_0056", "2011_09_26_drive_0064", "2011_09_26_drive_0070",
    "2011_09_26_drive_0087", "2011_09_26_drive_0095", "2011_09_26_drive_0104", "2011_09_29_drive_0004",
    "2011_09_30_drive_0018", "2011_09_30_drive_0020", "2011_09_30_drive_0034", "2011_10_03_drive_0047",
)
#: drives that choices are made on (even positions)
KITTI_TRAINING = SHARED_DRIVES[0::2]
#: drives that are only reported (odd positions)
KITTI_VALIDATION = SHARED_DRIVES[1::2]


def drive_name(path) -> str:
    """The KITTI drive name (``YYYY_MM_DD_drive_NNNN``) of a drive folder, its ``oxts`` folder or a
    label that ends in it; the last path part otherwise."""
    p = Path(str(path))
    parts = [q for q in (p.name, p.parent.name) if "_drive_" in q]
    name = parts[0] if parts else p.name
    i = name.find("_drive_")
    return name[max(0, i - 10):i + 11] if i >= 10 else name


def split_of(path) -> str:
    """``"training"``, ``"validation"`` or ``"unseen"`` for a KITTI drive (folder or name)."""
    name = drive_name(path)
    if name in KITTI_TRAINING:
        return "training"
    if name in KITTI_VALIDATION:
        return "validation"
    return "unseen"
