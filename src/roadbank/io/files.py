"""Opening a log file: the checks and the MDF handle every reader shares."""

from __future__ import annotations

from pathlib import Path

from .errors import LogError


def not_found(path) -> LogError:
    """The error for a log path that does not exist (a file or a folder: its format is not guessed from a
    suffix it may not have): ``"<path>: not found (no such file or folder)"``."""
    return LogError(f"{path}: not found (no such file or folder)")


def must_exist(path) -> Path:
    """``Path(path)``, or :func:`not_found` when nothing is there."""
    p = Path(path)
    if not p.exists():
        raise not_found(p)
    return p


def existing_nonempty(path) -> Path:
    """``Path(path)``, or a :class:`LogError` if the file is missing or empty."""
    p = Path(path)
    if not p.exists():
        raise LogError(f"{p}: file not found")
    if p.stat().st_size == 0:
        raise LogError(f"{p}: file is empty")
    return p


def open_mdf(p: Path, source=None):
    """An asammdf ``MDF`` of file ``p`` (or of the open file object ``source``); LogError if it cannot be opened."""
    from .mdfimport import import_asammdf

    try:
        MDF = import_asammdf().MDF
    except ImportError:
        raise LogError(f"{p}: reading MDF4 needs the optional dependency asammdf "
                       "(pip install 'roadbank[mdf]')") from None
    try:
        return MDF(str(p) if source is None else source)
    except Exception as exc:  # asammdf raises many types for corrupt files
        raise LogError(f"{p}: not a readable MDF file (truncated or corrupt?): {exc}") from None
