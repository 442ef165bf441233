"""Requests that come faster than they are served, served one at a time and, of those that came
meanwhile, only the newest: a slider dragged asks for a design at every step, and a design takes
longer than a step; the designs of the steps passed would only delay the one the slider stops at.
"""
from __future__ import annotations

import asyncio
from typing import Awaitable, Callable


class Latest:
    """Serve requests by ``serve`` (a coroutine function of no argument, which reads what is
    asked where it is kept when it starts): one at a time; a request made while one is served
    waits, and replaces any request still waiting.

    Attributes
    ----------
    served, dropped : int
        How many requests were served, and how many were replaced before their turn.
    """

    def __init__(self, serve: Callable[[], Awaitable[None]]):
        self.serve = serve
        self.served = self.dropped = 0
        self._waiting = False
        self._task: asyncio.Future | None = None

    def ask(self) -> None:
        """Ask for a serving, after the one under way (if any); one already waiting is dropped."""
        if self._waiting:
            self.dropped += 1
        self._waiting = True
        if self._task is None or self._task.done():
            self._task = asyncio.ensure_future(self._run())

    def drop(self) -> None:
        """Forget the request waiting, if any (what it asked for is asked otherwise now)."""
        if self._waiting:
            self.dropped += 1
        self._waiting = False

    async def _run(self) -> None:
        while self._waiting:
            self._waiting = False
            self.served += 1
            await self.serve()

    async def idle(self) -> None:
        """Wait until no request is served or waiting."""
        while self._task is not None and not self._task.done():
            await self._task


__all__ = ["Latest"]
