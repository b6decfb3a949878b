"""``--workers`` / ``--scheduler`` of the commands that process many logs or drives, and the pool they open.

``scheduler_address`` is the callback of every ``--scheduler`` option: an address Dask cannot parse
(``notanaddress``, a missing port) is a usage error naming the option and the expected form, before
any work; a well-formed address whose scheduler cannot be reached is a one-line error (exit code 1)
when the command connects.
"""

from __future__ import annotations

import functools
import re
import sys

import click

#: Dask's protocols that connect to a host and port (``tcp`` when none is given)
_HOST_PORT_SCHEMES = ("tcp", "tls", "ws", "wss", "ucx")
#: a host name or IPv4 address, or an IPv6 address in brackets; then the port
_HOST_PORT = re.compile(r"(?P<host>[A-Za-z0-9._-]+|\[[0-9A-Fa-f:.]+\]):(?P<port>[0-9]{1,5})")
#: the form the usage error asks for
ADDRESS_FORM = "tcp://host:port or host:port (e.g. tcp://10.0.0.5:8786)"


def _at_least_one(ctx, param, value):
    if value is not None and value < 1:
        raise click.BadParameter("must be >= 1")
    return value


def address_problem(address: str) -> str | None:
    """Why ``address`` is not a Dask scheduler address, or None if it is one.

    Parameters
    ----------
    address : str
        ``[protocol://]host:port`` with protocol tcp (the default), tls, ws, wss or ucx; or
        ``inproc://...``, a scheduler in this process (from Python).

    Returns
    -------
    str or None
        E.g. ``"'notanaddress' has no port"``.
    """
    scheme, sep, location = address.partition("://")
    if not sep:
        scheme, location = "tcp", address
    scheme = scheme.lower()
    if scheme == "inproc":
        return None if location else f"'{address}' names no scheduler"
    if scheme not in _HOST_PORT_SCHEMES:
        return f"'{address}': unknown protocol '{scheme}' (one of {', '.join(_HOST_PORT_SCHEMES)})"
    m = _HOST_PORT.fullmatch(location)
    if m is None:
        why = "has no port" if location.endswith(":") or ":" not in location.strip("[]") else "is not host:port"
        return f"'{address}' {why}"
    if not 1 <= int(m["port"]) <= 65535:
        return f"'{address}': port {m['port']} is not in 1-65535"
    return None


def scheduler_address(ctx, param, value):
    """Click callback of ``--scheduler``: a malformed address is a usage error (exit code 2) naming the
    option and :data:`ADDRESS_FORM`; None (no scheduler) and a well-formed address pass unchanged."""
    if value is not None:
        why = address_problem(value)
        if why:
            raise click.BadParameter(f"{why}: give the Dask scheduler's address as {ADDRESS_FORM}",
                                     ctx=ctx, param=param)
    return value


def scheduler_option(help_text: str = "Run on the Dask scheduler at ADDR (tcp://host:8786) instead of "
                                      "local workers.", metavar: str = "ADDR"):
    """Decorator: ``--scheduler ADDR`` (None when absent), its address checked by :func:`scheduler_address`.

    Parameters
    ----------
    help_text : str
        The option's help.
    metavar : str
        The value's name in the help.
    """
    return click.option("--scheduler", default=None, metavar=metavar, callback=scheduler_address, help=help_text)


def one_pool(f):
    """Decorator of a command with ``--workers`` and ``--scheduler``: both given is a usage error (exit code 2) before
    any work (``--workers`` was ignored in silence: the scheduler's workers run the tasks)."""
    @functools.wraps(f)
    def checked(*args, **kwargs):
        if kwargs.get("scheduler") is not None and (kwargs.get("workers") or 1) != 1:
            raise click.UsageError("give --workers N (processes on this machine) or --scheduler ADDR (the scheduler's "
                                   "workers run the tasks), not both")
        return f(*args, **kwargs)
    return checked


def pool_options(what: str, note: str = ""):
    """The two options, for a command whose ``what`` ("Drives", "Logs") run in parallel; ``note``
    ends the help of ``--workers``; both given is a usage error (:func:`one_pool`)."""
    def deco(f):
        f = scheduler_option()(one_pool(f))
        return click.option("--workers", type=int, default=1, show_default=True, callback=_at_least_one,
                            help=f"{what} in parallel on N worker processes on this machine "
                                 "(1: in this process)." + (f" {note}" if note else ""))(f)
    return deco


def start_pool(stack, workers: int, scheduler: str | None, warm=None):
    """:func:`roadbank.fleet.cluster.open_pool` entered on ``stack`` (a contextlib.ExitStack); a
    missing Dask or an unreachable scheduler is a one-line error and exit code 1.

    So is a well-formed address Dask cannot connect to (TypeError, ValueError: ``tls://`` without a
    TLS configuration, ``ucx://`` without UCX installed), named with the address.
    """
    from ..fleet.cluster import open_pool

    try:
        return stack.enter_context(open_pool(workers, scheduler, warm=warm))
    except (ConnectionError, RuntimeError, OSError) as exc:
        click.echo(f"error: {exc}", err=True)
        sys.exit(1)
    except (TypeError, ValueError) as exc:
        if scheduler is None:
            raise
        click.echo(f"error: cannot connect to the Dask scheduler at {scheduler}: {exc}", err=True)
        sys.exit(1)
