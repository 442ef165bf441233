"""The designs a design page's tab made from the file open, to step back and forth through
(undo, redo), without the page.

Each entry is the user's edits as they stood (:class:`Edits`, what
:meth:`cadcam.app.state.DesignState.edits` gives) and what designing them gave
(:class:`cadcam.app.state.Outcome`): stepping back shows that design again at once, not a new
solve that might end elsewhere. A new design after a step back drops the designs stepped back
over, as an editor's undo does.
"""
from __future__ import annotations

import copy
from dataclasses import dataclass, field
from typing import Generic, TypeVar

#: The designs a tab keeps to step back through (the oldest are dropped first).
HISTORY_DESIGNS = 50

T = TypeVar("T")


@dataclass(frozen=True)
class Edits:
    """The user's edits at one moment: the fields' values, the springs picked from the papers'
    catalogue and the parts picked in a catalogue table (by spring number), and the table
    targets edited (by key). Copies: a later edit does not change them."""

    overrides: dict = field(default_factory=dict)
    picks: dict = field(default_factory=dict)
    parts: dict = field(default_factory=dict)
    tables: dict = field(default_factory=dict)

    @classmethod
    def of(cls, overrides: dict, picks: dict, parts: dict, tables: dict) -> "Edits":
        return cls(*(copy.deepcopy(d) for d in (overrides, picks, parts, tables)))


@dataclass
class History(Generic[T]):
    """The designs made, oldest first, and the one shown (``at``)."""

    entries: list[tuple[Edits, T]] = field(default_factory=list)
    at: int = -1
    size: int = HISTORY_DESIGNS

    def record(self, edits: Edits, outcome: T) -> None:
        """A new design, shown now: those stepped back over are dropped; an entry of the same
        edits as the one shown replaces it (a design of edits already made, asked again)."""
        del self.entries[self.at + 1:]
        if self.entries and self.entries[-1][0] == edits:
            self.entries.pop()
        self.entries.append((edits, outcome))
        del self.entries[:max(0, len(self.entries) - self.size)]
        self.at = len(self.entries) - 1

    @property
    def can_undo(self) -> bool:
        return self.at > 0

    @property
    def can_redo(self) -> bool:
        return self.at < len(self.entries) - 1

    def undo(self) -> tuple[Edits, T] | None:
        """The design before the one shown, now shown; None where there is none."""
        return self._step(-1) if self.can_undo else None

    def redo(self) -> tuple[Edits, T] | None:
        """The design stepped back from last, now shown; None where there is none."""
        return self._step(1) if self.can_redo else None

    def _step(self, by: int) -> tuple[Edits, T]:
        self.at += by
        return self.entries[self.at]

    def current(self) -> Edits | None:
        """The edits of the design shown, or None before the first."""
        return self.entries[self.at][0] if self.entries else None

    def words(self) -> str:
        """Where the design shown is among those made (``design 3 of 5``)."""
        return f"design {self.at + 1} of {len(self.entries)}" if self.entries else "no design yet"


__all__ = ["Edits", "HISTORY_DESIGNS", "History"]
