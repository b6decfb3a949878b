"""Opening a log file: the checks and the MDF handle every reader shares."""

from __future__ import annotations

import os
import stat
from pathlib import Path

from .errors import LogError


def not_found(path) -> LogError:
    """The error for a log path that does not exist (a file or a folder: its format is not guessed from a
    suffix it may not have): ``"<path>: not found (no such file or folder)"``."""
    return LogError(f"{path}: not found (no such file or folder)")


def present(path) -> bool:
    """Whether something is at ``path``: True also where it cannot be looked at (a folder on the way that cannot be
    searched; the reader then says so, :func:`must_exist`), unlike :meth:`pathlib.Path.exists`, which raises there."""
    try:
        Path(path).stat()
    except (FileNotFoundError, NotADirectoryError):
        return False
    except OSError:
        return True
    return True


def must_exist(path) -> Path:
    """``Path(path)``; :func:`not_found` when nothing is there, a :class:`LogError` saying so when it is neither a
    regular file nor a folder (a FIFO, a socket, a device: reading one could wait for ever) or cannot be read."""
    p = Path(path)
    try:
        st = p.stat()
    except FileNotFoundError:
        raise not_found(p) from None
    except OSError as exc:           # a folder on the way that cannot be searched, a link loop, ...
        raise LogError(f"{p}: cannot be read ({exc.strerror or exc})") from None
    if stat.S_ISDIR(st.st_mode):
        if not os.access(p, os.R_OK | os.X_OK):
            raise LogError(f"{p}: a folder that cannot be read (permission denied)")
    elif not stat.S_ISREG(st.st_mode):
        raise LogError(f"{p}: neither a file nor a folder (a FIFO, a socket or a device): roadbank reads log files "
                       "and folders")
    elif not os.access(p, os.R_OK):
        raise LogError(f"{p}: a file that cannot be read (permission denied)")
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
