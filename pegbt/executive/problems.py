"""Collects every problem found in a tree file so that one `pegbt tree check` run reports them all."""

from __future__ import annotations

import difflib
from collections.abc import Iterable

from pegbt.errors import PegbtError, PegbtErrors
from pegbt.yamlfile import Mark


def did_you_mean(word: str, choices: Iterable[str]) -> str:
    """` (did you mean 'x'?)` for the closest choice, or an empty string."""
    close = difflib.get_close_matches(word, list(choices), n=1, cutoff=0.6)
    return f" (did you mean {close[0]!r}?)" if close else ""


class Problems:
    """An ordered, de-duplicated list of located errors (a subtree used twice reports its faults once)."""

    def __init__(self) -> None:
        self._errors: list[PegbtError] = []
        self._seen: set[tuple[object, ...]] = set()

    def add(
        self, message: str, mark: Mark | None, *, path: str | None = None, field: str | None = None
    ) -> None:
        """Record one problem at `mark`; `path` is the node's path in the tree, `field` the offending key."""
        text = f"{path}: {message}" if path else message
        identity = (mark, field, message)  # not the path: a subtree used twice has one fault, in one place
        if identity in self._seen:
            return
        self._seen.add(identity)
        if mark is None:
            self._errors.append(PegbtError(text, field=field))
        else:
            self._errors.append(
                PegbtError(text, file=mark.file, line=mark.line, column=mark.column, field=field)
            )

    def add_error(self, error: PegbtError) -> None:
        """Record an error raised elsewhere (a YAML syntax error in an included file, say)."""
        identity = (error.file, error.line, error.column, error.field, error.message)
        if identity not in self._seen:
            self._seen.add(identity)
            self._errors.append(error)

    def __bool__(self) -> bool:
        return bool(self._errors)

    def raise_if_any(self) -> None:
        """Raise all recorded problems at once, in file and line order."""
        if self._errors:
            ordered = sorted(self._errors, key=lambda e: (e.file or "", e.line or 0, e.column or 0))
            raise ordered[0] if len(ordered) == 1 else PegbtErrors(ordered)
