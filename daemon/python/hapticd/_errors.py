"""The package's error type, in a module of its own so that the readers of shared memory
(``telemetry``, ``world``) raise it without importing the package they are part of."""

from __future__ import annotations

import math
from typing import NoReturn

BAD_SHARED_MEMORY = "org.hapticd.Hapticd1.Python.BadSharedMemory"
"""The name of the :class:`Error` raised for memory the daemon shared that this client refuses
(another layout, a value no daemon of this layout writes): raised here, not sent by the daemon,
hence outside the daemon's ``org.hapticd.Hapticd1.Error`` names."""


class Error(Exception):
    """An error the daemon (or the bus) returned: ``name`` is its D-Bus error name, such as
    ``org.hapticd.Hapticd1.Error.OutOfRange``, and the message says why. Memory the daemon
    shared (the telemetry ring, the world) that holds what no daemon of its layout writes is
    refused with the name :data:`BAD_SHARED_MEMORY`."""

    def __init__(self, name: str, message: str) -> None:
        super().__init__(f"{name}: {message}")
        self.name: str = name
        """The D-Bus error name."""
        self.message: str = message
        """Why, in the daemon's words."""


class NotRunning(Error):
    """No hapticd on the bus asked for: raised by :func:`hapticd.connect`, not at the first
    call. Its ``name`` is :data:`NOT_RUNNING`."""

    def __init__(self, bus: str) -> None:
        super().__init__(NOT_RUNNING, f"hapticd is not running on the {bus} bus")
        self.bus: str = bus
        """The bus asked: ``system``, or its address."""


NOT_RUNNING = "org.hapticd.Hapticd1.Python.NotRunning"
"""The name of :class:`NotRunning`: said by this client, not sent by the daemon."""


# Shown as hapticd.Error and hapticd.NotRunning, where callers find them.
Error.__module__ = "hapticd"
NotRunning.__module__ = "hapticd"


MAX_RATE = 1e9
"""The most ticks a second shared memory may say its loop runs: a tick a nanosecond, far beyond
any haptic loop; a larger rate is corrupt memory, refused before it overflows a count of
ticks."""


def refuse(what: str) -> NoReturn:
    """Raise the :class:`Error` of shared memory that says ``what``."""
    raise Error(BAD_SHARED_MEMORY, what)


def check_rate(rate: float, what: str, *, zero: bool = False) -> float:
    """``rate`` (ticks a second) read from ``what``, refused unless finite, positive (or 0,
    when ``zero`` allows it) and at most :data:`MAX_RATE`."""
    if not (math.isfinite(rate) and (rate > 0 or zero and rate == 0) and rate <= MAX_RATE):
        least = "[0" if zero else "(0"
        refuse(f"{what}: {rate!r} ticks a second, not a rate in {least}, {MAX_RATE:g}]")
    return rate


def check_count(count: int, what: str, most: int) -> int:
    """``count`` read from ``what``, refused above ``most``: the layout holds no more, so a
    larger count is memory no daemon of that layout wrote."""
    if count > most:
        refuse(f"{what}: {count}, more than the {most} the layout holds")
    return count
