"""Inputs shared by the commands that read logs (``estimate``, ``map``): the channel map and the log list."""

from __future__ import annotations

import glob
import os
import sys
from pathlib import Path

import click

#: suffixes of files that are never logs (documentation, pictures, configuration): skipped when a
#: glob or a folder brings them in, even with --format
NOT_LOG_SUFFIXES = {".md", ".rst", ".pdf", ".png", ".jpg", ".jpeg", ".gif", ".svg", ".html", ".htm", ".json",
                    ".yaml", ".yml", ".toml", ".dbc", ".py", ".sh", ".zip", ".gz", ".tar", ".xml", ".ini",
                    ".cfg", ".doc", ".docx", ".xlsx"}
#: formats whose suffix belongs to them alone: a file of one of these is not a log of another format
_OWN_SUFFIX = ("parquet", "mdf4", "blf", "asc", "trc", "rosbag1", "mcap")


#: a spreadsheet's own files, which roadbank does not read, and what to do with one
SPREADSHEET_SUFFIXES = (".xlsx", ".xls", ".xlsm", ".ods", ".numbers")
SPREADSHEET_HINT = (" (a spreadsheet: save it as CSV; ';' separators, decimal commas and a units row under the "
                    "header are read)")


def not_a_log(path: Path, fmt: str | None) -> str | None:
    """Why ``path`` is not a log to read with ``fmt`` (None: the format from its suffix), or None if it may be.

    Only files are judged; directories and missing paths are left to the readers (their errors
    name the problem). A file inside a log folder (:func:`roadbank.fleet.run.enclosing_log`) that only that
    folder's reader reads (a KITTI drive's frame or ``timestamps.txt``, a comma2k19 segment's ``value``, a ROS 2
    bag's database: no log suffix) is a part of that log, not a log; a CSV put there is still read.
    """
    from ..fleet.run import LOG_SUFFIXES, enclosing_log
    from ..io import LogError, detect_format
    from ..io.files import must_exist

    try:
        if not path.is_file():
            return None
        must_exist(path)
    except (OSError, LogError):  # cannot be looked at or read: the reader says so, as that log's failure
        return None
    suffix = path.suffix.lower()
    try:
        detected = detect_format(path)
    except LogError:
        detected = None
    if fmt is None:
        if (detected in (None, "csv") and suffix not in LOG_SUFFIXES | NOT_LOG_SUFFIXES
                and enclosing_log(path, 4) is not None):
            return "a part of a log, not a log"
        hint = SPREADSHEET_HINT if suffix in SPREADSHEET_SUFFIXES else ""
        return None if detected else f"not a log of a known format: suffix '{path.suffix}'{hint}"
    if suffix in NOT_LOG_SUFFIXES or (detected in _OWN_SUFFIX and detected != fmt
                                      and {detected, fmt} not in ({"mdf4", "mdf4-can"}, {"mcap", "rosbag2"})):
        return f"not a {fmt} log"
    return None


def channel_map_and_logs(channels, logs, fmt: str | None = None):
    """``(ChannelMap or None, [Path])`` from ``--channels`` and the LOGS arguments (files, directories, globs).

    A folder gives every log it holds: each KITTI drive, comma2k19 segment and log file
    (:func:`roadbank.fleet.expand_logs`, the one rule), each log once (:func:`once_each`). Files that are not logs of
    ``fmt`` (or of a format known from their suffix) -- a README.md a glob picked up -- are skipped, each with a
    one-line message. A bad channel map or no log found is a one-line error (exit code 1), never a traceback. When
    no path given exists (a mistyped name), that is a usage error naming each (exit code 2): its format
    is not guessed from a suffix it may not have. A missing path among existing ones is the reader's
    failure of that one log (:func:`roadbank.io.files.not_found`), the others are read.
    """
    from ..fleet import expand_logs
    from ..fleet.run import enclosing_log
    from ..io import LogError, read_channel_map
    from ..io.files import not_found, present

    cmap = None
    if channels is not None:
        try:
            cmap = read_channel_map(channels)
        except LogError as exc:
            click.echo(f"error: {exc}", err=True)
            sys.exit(1)
    left_out: list = []
    paths = expand_logs(logs, left_out)
    if left_out:
        shown = ", ".join(map(str, left_out[:3])) + (f" and {len(left_out) - 3} more" if len(left_out) > 3 else "")
        click.echo(f"note: {len(left_out)} file(s) named as roadbank's own outputs (summary.csv, *.bank.csv, "
                   f"*.bank.parquet) left out: {shown} (give such a file by its name to read it as a log)", err=True)
    if paths and not any(present(p) for p in paths):
        raise click.BadParameter("; ".join(str(not_found(p)) for p in paths), param_hint="LOGS")
    for a in logs if paths else ():          # (nothing at all is the error below)
        empty = _gives_nothing(a, paths)
        if empty:
            click.echo(f"note: {a}: {empty}", err=True)
    kept = []
    for p in once_each(paths):
        why = not_a_log(p, fmt)
        if why is None:
            kept.append(p)
        else:
            click.echo(f"skipped {p} ({why})", err=True)
    if not kept:
        what = "no logs found" if not paths else "no logs left to read"
        hint = " (--format reads a log whose suffix is not its format's)" if paths and fmt is None else ""
        inside = sorted({_shown(e) for a in logs if (e := enclosing_log(Path(a), 4)) is not None})
        if inside:              # a part of a log given for the log: name the log
            hint = f" (parts of the log {', '.join(inside)}: give that folder)"
        click.echo(f"error: {what} in {', '.join(map(str, logs))}{hint}", err=True)
        sys.exit(1)
    return cmap, kept


def _shown(path: Path) -> str:
    """``path`` as a message names it: relative to the working directory where it lies below it, else absolute."""
    rel = os.path.relpath(path)
    return str(path) if rel.startswith("..") else rel


def _gives_nothing(arg, paths: list) -> str | None:
    """Why the LOGS argument ``arg`` added no log to ``paths`` (a pattern that matches no file, a folder without
    logs), or None where it added one or is a path the readers report."""
    from ..io.files import present

    p, text = Path(arg), str(arg)
    if not present(p) and any(ch in text for ch in "*?["):
        return None if glob.glob(text, recursive=True) else "the pattern matches no file"
    try:
        folder = p.is_dir()
    except OSError:
        return None
    if folder and not any(q == p or p in q.parents for q in map(Path, paths)):
        return "a folder without logs"
    return None


def once_each(paths: list) -> list:
    """``paths`` with each log kept once where several name the same file or folder (a link to it, ``a/../a``, a
    KITTI drive and its ``oxts/`` folder: :func:`roadbank.fleet.run.log_identity`): the first, each other said on
    stderr. A log read twice would count its samples twice in each cell of a map, and be written twice by
    ``estimate``."""
    from ..fleet.run import log_identity

    seen: dict = {}
    kept = []
    for p in paths:
        key = log_identity(Path(p))
        if key in seen:
            click.echo(f"warning: {p} is {seen[key]} given again (the same log): read once", err=True)
            continue
        seen[key] = p
        kept.append(p)
    return kept


def check_output(path, option: str, directory: bool = False) -> None:
    """Exit with a one-line error (exit code 1) if ``path``, given as ``option``, cannot be written as a file
    (``directory``: created as a directory), e.g. ``error: -o: cannot write 'a.csv/o.csv': 'a.csv' is a file,
    not a directory`` -- checked before the work (:func:`roadbank.cli.options.output_path_problem`, the check
    every command's output gets; the others' is a usage error, exit code 2)."""
    from .options import output_path_problem

    why = output_path_problem(path, directory=directory)
    if why:
        click.echo(f"error: {option}: {why}", err=True)
        sys.exit(1)
