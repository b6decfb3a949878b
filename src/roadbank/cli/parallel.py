"""``--workers`` / ``--scheduler`` of the commands that process many logs or drives, and the pool they open."""

from __future__ import annotations

import sys

import click


def _at_least_one(ctx, param, value):
    if value is not None and value < 1:
        raise click.BadParameter("must be >= 1")
    return value


def pool_options(what: str, note: str = ""):
    """The two options, for a command whose ``what`` ("Drives", "Logs") run in parallel; ``note``
    ends the help of ``--workers``."""
    def deco(f):
        f = click.option("--scheduler", default=None, metavar="ADDR",
                         help="Run on the Dask scheduler at ADDR (tcp://host:8786) instead of local workers.")(f)
        return click.option("--workers", type=int, default=1, show_default=True, callback=_at_least_one,
                            help=f"{what} in parallel on N worker processes on this machine "
                                 "(1: in this process)." + (f" {note}" if note else ""))(f)
    return deco


def start_pool(stack, workers: int, scheduler: str | None, warm=None):
    """:func:`roadbank.fleet.cluster.open_pool` entered on ``stack`` (a contextlib.ExitStack); a
    missing Dask or an unreachable scheduler is a one-line error and exit code 1."""
    from ..fleet.cluster import open_pool

    try:
        return stack.enter_context(open_pool(workers, scheduler, warm=warm))
    except (ConnectionError, RuntimeError, OSError) as exc:
        click.echo(f"error: {exc}", err=True)
        sys.exit(1)
