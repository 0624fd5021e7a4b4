"""Numbers a person gives (command-line options, call arguments): finite and within bounds, or a `PegbtError`.

Why a module of its own: `float("nan")` parses, and NaN passes every `x <= 0` test, so a range check
alone lets it through and it fails later, far from the option that caused it (a tick period of NaN
crashes the runner). `checked_number` is the one check; `NumberOption` applies it to an argparse
option, so every command refuses a bad number in one line naming the option.
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Sequence
from typing import Any

from pegbt.errors import PegbtError


def checked_number(
    value: float,
    field: str,
    *,
    above: float | None = None,
    at_least: float | None = None,
    at_most: float | None = None,
    below: float | None = None,
) -> float:
    """`value` as a float if it is finite and within the given bounds; else a `PegbtError` naming `field`."""
    bounds = [
        f"> {above:g}" if above is not None else "",
        f">= {at_least:g}" if at_least is not None else "",
        f"<= {at_most:g}" if at_most is not None else "",
        f"< {below:g}" if below is not None else "",
    ]
    wanted = " and ".join(bound for bound in bounds if bound)
    number = float(value)
    if (
        not math.isfinite(number)
        or (above is not None and not number > above)
        or (at_least is not None and not number >= at_least)
        or (at_most is not None and not number <= at_most)
        or (below is not None and not number < below)
    ):
        raise PegbtError(
            f"must be a finite number{' ' + wanted if wanted else ''}, got {number:g}", field=field
        )
    return number


class NumberOption(argparse.Action):
    """An argparse option holding one number (`type=float` unless given) that `checked_number` accepts.

    `parser.add_argument("--period", action=NumberOption, above=0.0, default=0.02)`; a bad value raises a
    `PegbtError` naming the option, which `pegbt.cli.main` prints as one line.
    """

    def __init__(
        self,
        option_strings: Sequence[str],
        dest: str,
        *,
        above: float | None = None,
        at_least: float | None = None,
        at_most: float | None = None,
        below: float | None = None,
        **kwargs: Any,
    ) -> None:
        kwargs.setdefault("type", float)
        super().__init__(option_strings, dest, **kwargs)
        self.bounds = {"above": above, "at_least": at_least, "at_most": at_most, "below": below}

    def __call__(
        self,
        parser: argparse.ArgumentParser,
        namespace: argparse.Namespace,
        values: Any,
        option_string: str | None = None,
    ) -> None:
        number = checked_number(values, option_string or self.dest, **self.bounds)
        setattr(namespace, self.dest, values if self.type is int else number)
