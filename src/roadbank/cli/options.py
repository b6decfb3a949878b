"""Click options shared by several ``roadbank`` commands.

``vehicle_option`` adds ``--vehicle PATH|NAME``: the value reaching the command is a
:class:`roadbank.vehicle.Vehicle` (the paper's SUV when the option is absent). A
malformed file is a usage error (exit code 2) with the file/key message, no traceback.
"""

from __future__ import annotations

import click

#: shipped cars, listed in the help text (kept in sync with src/roadbank/vehicles/*.toml by a test)
_BUILTIN_HELP = "suv-paper, compact, sedan, van"


def _to_vehicle(ctx, param, value):
    from ..vehicle import VehicleFileError, load_vehicle

    if value is None and getattr(param, "none_if_absent", False):
        return None
    try:
        vehicle = load_vehicle(value)
        if value is not None:
            vehicle.check()  # every [tuning.<estimator>] table designs
    except VehicleFileError as exc:
        raise click.BadParameter(str(exc), ctx=ctx, param=param) from None
    return vehicle


class _VehicleOption(click.Option):
    def __init__(self, *args, none_if_absent: bool = False, **kwargs):
        super().__init__(*args, **kwargs)
        self.none_if_absent = none_if_absent


def vehicle_option(help_extra: str = "", *, default_help: str = "the paper's SUV",
                   none_if_absent: bool = False):
    """Decorator: ``--vehicle PATH|NAME`` giving the command a ``vehicle`` argument (a Vehicle).

    Parameters
    ----------
    help_extra : str
        Appended to the help text (what the command does with the car).
    default_help : str
        What the command uses without ``--vehicle`` (for the help text).
    none_if_absent : bool
        Without ``--vehicle`` the argument is None (the command keeps its own default car)
        instead of the paper's SUV.
    """
    text = (f"Vehicle file (.toml, see docs/vehicles.md) or a built-in car: {_BUILTIN_HELP}. "
            f"Default: {default_help}." + (f" {help_extra}" if help_extra else ""))
    return click.option("--vehicle", "vehicle", cls=_VehicleOption, default=None, metavar="PATH|NAME",
                        callback=_to_vehicle, none_if_absent=none_if_absent, help=text)
