"""Errors meant for a person: each says where the problem is (file, line, column, field) and what was wanted.

The command line prints a `PegbtError` as one line and exits non-zero; it never shows a traceback for
bad input. Raise it (or a subclass) for anything a user can fix: a malformed tree, a corrupt recording,
an unreachable pose, a silent endpoint.
"""

from __future__ import annotations

from os import PathLike


class PegbtError(Exception):
    """A problem with the user's input or environment, located as precisely as it can be."""

    exit_status = 2  # bad input; a subclass may say otherwise (an endpoint lost is 3)

    def __init__(
        self,
        message: str,
        *,
        file: str | PathLike[str] | None = None,
        line: int | None = None,
        column: int | None = None,
        field: str | None = None,
    ) -> None:
        super().__init__(message)
        self.message = message
        self.file = None if file is None else str(file)
        self.line = line
        self.column = column
        self.field = field

    def location(self) -> str:
        """`FILE:LINE:COLUMN`, with whatever parts are known."""
        parts = [self.file or "<input>"]
        if self.line is not None:
            parts.append(str(self.line))
            if self.column is not None:
                parts.append(str(self.column))
        return ":".join(parts) if (self.file or self.line is not None) else ""

    def __str__(self) -> str:
        prefix = self.location()
        field = f"{self.field}: " if self.field else ""
        return f"{prefix}: {field}{self.message}" if prefix else f"{field}{self.message}"


class PegbtErrors(PegbtError):
    """Several problems found in one pass (a validator reports them all, not just the first)."""

    def __init__(self, errors: list[PegbtError]) -> None:
        if not errors:
            raise ValueError("PegbtErrors needs at least one error")
        super().__init__(f"{len(errors)} error(s)")
        self.errors = list(errors)

    def __str__(self) -> str:
        return "\n".join(str(error) for error in self.errors)


def brief(value: object, limit: int = 40) -> str:
    """`repr(value)` cut to `limit` characters, safe for any value an error may quote.

    Why: Python refuses to print an integer of more than 4,300 digits (a YAML `0xfff…` parses to one),
    so an error message quoting such a value would itself raise; it is described by its size instead."""
    if isinstance(value, int) and not isinstance(value, bool) and value.bit_length() > 1000:
        return f"<an integer of about {int(value.bit_length() * 0.30103) + 1} digits>"
    try:
        shown = repr(value)
    except (ValueError, RecursionError):
        return f"<a {type(value).__name__} too large to show>"
    return shown if len(shown) <= limit else shown[: limit - 3] + "..."
