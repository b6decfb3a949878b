"""The one exception the log readers raise for bad input."""

from __future__ import annotations


class LogError(ValueError):
    """A log file cannot be read or does not make sense.

    The message always names the file and, where it applies, the channel
    (its role and its column) and the problem, e.g.
    ``log.csv: channel 'yaw_rate' (column 'gyro_z'): non-numeric value 'abc' at line 18``.
    It is a :class:`ValueError`, so callers that catch ``ValueError`` keep working.
    """


def channel_text(source, role: str, column: str | None, problem: str) -> str:
    """``<source>: channel '<role>' (column '<column>'): <problem>``: how a message names one channel of one file
    (an error's, :func:`channel_error`, or a warning's)."""
    col = f" (column '{column}')" if column else ""
    return f"{source}: channel '{role}'{col}: {problem}"


def channel_error(source, role: str, column: str | None, problem: str) -> LogError:
    """Build a :class:`LogError` for one channel of one file."""
    return LogError(channel_text(source, role, column, problem))
