"""Inputs shared by the commands that read logs (``estimate``, ``map``): the channel map and the log list."""

from __future__ import annotations

import sys

import click


def channel_map_and_logs(channels, logs):
    """``(ChannelMap or None, [Path])`` from ``--channels`` and the LOGS arguments (files, directories, globs).

    A bad channel map or no log found is a one-line error (exit code 1), never a traceback.
    """
    from ..fleet import expand_logs
    from ..io import LogError, read_channel_map

    cmap = None
    if channels is not None:
        try:
            cmap = read_channel_map(channels)
        except LogError as exc:
            click.echo(f"error: {exc}", err=True)
            sys.exit(1)
    paths = expand_logs(logs)
    if not paths:
        click.echo(f"error: no logs found in {', '.join(map(str, logs))}", err=True)
        sys.exit(1)
    return cmap, paths
