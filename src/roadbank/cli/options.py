"""Click options shared by several ``roadbank`` commands.

``vehicle_option`` adds ``--vehicle PATH|NAME``: the value reaching the command is a
:class:`roadbank.vehicle.Vehicle` (the paper's SUV when the option is absent). A
malformed file is a usage error (exit code 2) with the file/key message, no traceback.

``SEED`` is every command's ``--seed`` type; ``FiniteRange`` a float range that refuses NaN too;
``checked_output`` the callback of the output options (``-o``, ``--docs``) that refuses a path that
cannot be written before any work (a usage error naming the option and the path).
"""

from __future__ import annotations

from pathlib import Path

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


def vehicle_offsets(vehicle, removed_from: str) -> dict[str, float]:
    """The sensor offsets identified in ``vehicle``'s file (``{channel: SI value}``, empty without a vehicle or
    offsets), said on stderr with what they are ``removed_from`` ("every log", "the measured channels in C"); a
    malformed one is a usage error of ``--vehicle``."""
    from ..units import describe_offsets

    try:
        offsets = vehicle.sensor_offsets if vehicle is not None else {}
    except ValueError as exc:
        raise click.BadParameter(str(exc), param_hint="--vehicle") from None
    if offsets:
        click.echo(f"removing the sensor offsets identified in the vehicle file from {removed_from}: "
                   f"{describe_offsets(offsets)}", err=True)
    return offsets


class FiniteRange(click.FloatRange):
    """:class:`click.FloatRange` that also refuses NaN (which compares false with both bounds and would pass).

    A value outside the range is a usage error naming the option and the range, e.g. ``Invalid value
    for '--ay-max': 0.0 is not in the range 1<x<=10.``
    """

    def convert(self, value, param, ctx):
        rv = super().convert(value, param, ctx)
        if rv != rv:  # NaN
            self.fail(f"{value!r} is not a number in the range {self._describe_range()}", param, ctx)
        return rv


#: ``--seed`` of every command: what numpy's and scipy's seeding accept everywhere (0 to 2**32 - 1)
SEED = click.IntRange(0, 2**32 - 1)


class PathOption(click.Path):
    """A path given on the command line (:class:`click.Path`), never an empty one: ``-o "$OUT"`` with ``OUT`` unset
    wrote into the current folder, and an empty log path read every log there."""

    def convert(self, value, param, ctx):
        if isinstance(value, str) and not value.strip():
            self.fail("an empty path (an unset shell variable?): give a file or folder", param, ctx)
        return super().convert(value, param, ctx)


def output_path_problem(path, *, directory: bool = False, suffixes: tuple[str, ...] = (),
                        next_to: tuple[str, ...] = (), what: str = "") -> str | None:
    """Why ``path`` cannot be an output, as far as can be told before the work; None if it can be.

    Parameters
    ----------
    path : str or Path
        The output given on the command line.
    directory : bool
        The output is a directory (created if missing) rather than a file.
    suffixes : tuple of str
        The suffixes a file output may end in (lower case, with the dot); empty: any.
    next_to : tuple of str
        Suffixes of the files written next to the output with its stem (``.png``: ``report.png``
        beside ``report.md``); each is checked as a file too.
    what : str
        Why only those suffixes, appended to their message ("tune writes a vehicle file").

    Returns
    -------
    str or None
        A one-line reason naming the path, e.g. ``"cannot write 'a.md/x.md': 'a.md' is a file, not a
        directory"`` (:func:`roadbank.io.writers.output_problem`, the one rule), or
        ``"'t.csv' must end in .toml (tune writes a vehicle file)"``.
    """
    from ..io.writers import output_problem

    p = Path(path)
    if suffixes and p.suffix.lower() not in suffixes:
        return f"'{p}' must end in {' or '.join(suffixes)}" + (f" ({what})" if what else "")
    why = output_problem(p, directory)
    for suffix in () if why else next_to:
        why = output_problem(p.with_suffix(suffix))
        if why:
            break
    return why


def checked_output(*, directory: bool = False, suffixes: tuple[str, ...] = (), next_to: tuple[str, ...] = (),
                   what: str = ""):
    """A click callback refusing an output path that cannot be written, before the command runs.

    The refusal is a usage error (exit code 2) naming the option and the path, e.g.
    ``Invalid value for '-o' / '--output': cannot write 'afile/x.md': 'afile' is a file, not a
    directory``. A missing folder is no problem (the commands create it).

    Parameters
    ----------
    directory, suffixes, next_to, what
        As for :func:`output_path_problem`.

    Returns
    -------
    callable
        ``callback(ctx, param, value)`` for :func:`click.option`; an absent option (None) passes.
    """
    def check(ctx, param, value):
        if value is not None:
            why = output_path_problem(value, directory=directory, suffixes=suffixes, next_to=next_to, what=what)
            if why:
                raise click.BadParameter(why, ctx=ctx, param=param)
        return value
    return check
