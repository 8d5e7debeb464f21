"""Every tick of a device's haptic loop, read from the telemetry ring the daemon hands out
(``Device.OpenTelemetry``): a sealed memfd, mapped read-only here, holding the last ticks in
slots each under a sequence lock of its own. The layout is ``hapticd_core::telemetry``'s
(version 3); a ring of another layout is refused. :func:`to_numpy` lays ticks out as a numpy
array (the ``numpy`` extra: ``pip install hapticd[numpy]``).
"""

from __future__ import annotations

import asyncio
import mmap
import struct
import time
from dataclasses import dataclass
from typing import (
    TYPE_CHECKING,
    Any,
    AsyncIterator,
    Iterable,
    Iterator,
    List,
    Optional,
    Sequence,
    Tuple,
)

from ._errors import Error, check_count, check_rate, refuse

if TYPE_CHECKING:
    import numpy

__all__ = ["Ring", "Sample", "to_numpy", "STATES", "SLOTS", "MAX_EFFECTORS", "CHANNELS", "VERSION"]

MAGIC = b"hapticdT"
VERSION = 3
"""The layout of ring this client reads."""
SLOTS = 8192
"""The ticks a ring holds: a reader more than this many ticks behind misses some."""
MAX_EFFECTORS = 4
"""The most effectors a tick holds."""
CHANNELS = 8
"""The most strings (motors) a tick holds."""
STATES = ("running", "fault", "disconnected", "uncalibrated")
"""The device states by their number (``state_code``); any other reads as ``unknown(N)``."""

NO_BODY = 0xFFFFFFFF
# Seconds a follower sleeps while the next tick is not written: a tick of a 1 kHz loop, so
# that it is a tick late at most without spinning.
_POLL = 0.001

# A slot: its sequence (u64), then the sample: tick, time, state, effectors, strings,
# contacts, slipping, the body each effector touches, each effector's pose (x, y, z, qw,
# qx, qy, qz), velocity, angular velocity and wrench, where it touches and the normal
# there, each string's tension and D/A value.
_HEADER = struct.Struct("<8sIIdQ")
_SAMPLE = struct.Struct(
    "<Qd5I"
    + f"{MAX_EFFECTORS}I"
    + "4x"  # the poses' doubles start on an 8-byte boundary
    + "7d" * MAX_EFFECTORS
    + "3d" * MAX_EFFECTORS
    + "3d" * MAX_EFFECTORS
    + "6d" * MAX_EFFECTORS
    + "3d" * MAX_EFFECTORS
    + "3d" * MAX_EFFECTORS
    + f"{CHANNELS}d{CHANNELS}h"
)
_SEQUENCE = struct.Struct("<Q")
# The sample is padded to its alignment (its doubles') in the slot.
_SLOT = _SEQUENCE.size + (_SAMPLE.size + 7) // 8 * 8
_SLOTS_AT = _HEADER.size
SIZE = _SLOTS_AT + SLOTS * _SLOT


@dataclass(frozen=True)
class Sample:
    """One tick as the haptic loop left it."""

    tick: int
    """Ticks since the loop started, from 0."""
    time: float
    """Loop time, seconds."""
    state: str
    """running, fault, disconnected or uncalibrated; ``unknown(N)`` for a state number ``N``
    this client does not know (a newer daemon's), which is never running."""
    poses: List[Tuple[float, ...]]
    """Each effector's pose: x, y, z (metres), then the orientation qw, qx, qy, qz."""
    velocities: List[Tuple[float, float, float]]
    """Each effector's velocity, m/s."""
    angular_velocities: List[Tuple[float, float, float]]
    """Each effector's angular velocity, rad/s (zeros for three degrees of freedom)."""
    wrenches: List[Tuple[float, ...]]
    """Each effector's displayed force (N) and torque (N·m): fx, fy, fz, tx, ty, tz."""
    contacts: List[bool]
    """Whether each effector displays a force: it touches something."""
    slipping: List[bool]
    """Whether each effector slides along what it touches (dynamic friction)."""
    touched: List[Optional[int]]
    """The id of the body each effector touches (the scene's ``bodies``), or None."""
    touch_points: List[Tuple[float, float, float]]
    """Where each effector touches, metres."""
    touch_normals: List[Tuple[float, float, float]]
    """The outward normal of what each effector touches (zeros when the scene cannot say)."""
    tensions: List[float]
    """Each string's tension, newtons."""
    dac: List[int]
    """Each motor's D/A value as sent."""

    @property
    def position(self) -> Tuple[float, float, float]:
        """The first effector's position, metres."""
        x, y, z = self.poses[0][:3]
        return x, y, z

    @property
    def force(self) -> Tuple[float, float, float]:
        """The force displayed on the first effector, newtons."""
        x, y, z = self.wrenches[0][:3]
        return x, y, z


def _state_name(state: int) -> str:
    """The name of device state number ``state``."""
    # A number this client does not know is a newer daemon's state, likely a fault of a new
    # kind: named so that no caller testing for "running" takes it for running, yet not
    # raised, so that a recording keeps every tick around the fault (its poses and forces are
    # still sound).
    return STATES[state] if state < len(STATES) else f"unknown({state})"


def _sample(values: Tuple[Any, ...]) -> Sample:
    tick, time_, state, effectors, strings, contacts, slipping = values[:7]
    effectors = check_count(effectors, f"effectors in the sample of tick {tick}", MAX_EFFECTORS)
    strings = check_count(strings, f"strings in the sample of tick {tick}", CHANNELS)
    at = 7
    touched = [None if b == NO_BODY else b for b in values[at : at + effectors]]
    at += MAX_EFFECTORS

    def per_effector(width: int) -> List[Tuple[Any, ...]]:
        return [tuple(values[at + width * k : at + width * k + width]) for k in range(effectors)]

    poses = per_effector(7)
    at += 7 * MAX_EFFECTORS
    velocities = per_effector(3)
    at += 3 * MAX_EFFECTORS
    angular_velocities = per_effector(3)
    at += 3 * MAX_EFFECTORS
    wrenches = per_effector(6)
    at += 6 * MAX_EFFECTORS
    points = per_effector(3)
    at += 3 * MAX_EFFECTORS
    normals = per_effector(3)
    at += 3 * MAX_EFFECTORS
    tensions = list(values[at : at + strings])
    at += CHANNELS
    dac = list(values[at : at + strings])
    return Sample(
        tick=tick,
        time=time_,
        state=_state_name(state),
        poses=poses,
        velocities=velocities,
        angular_velocities=angular_velocities,
        wrenches=wrenches,
        contacts=[bool(contacts >> k & 1) for k in range(effectors)],
        slipping=[bool(slipping >> k & 1) for k in range(effectors)],
        touched=touched,
        touch_points=points,
        touch_normals=normals,
        tensions=tensions,
        dac=dac,
    )


class Ring:
    """A device's telemetry ring, mapped read-only from the descriptor ``fd``."""

    def __init__(self, fd: int) -> None:
        try:
            self._map = mmap.mmap(fd, SIZE, mmap.MAP_SHARED, mmap.PROT_READ)
        except ValueError as e:  # shorter than the layout
            refuse(f"not a telemetry ring of layout {VERSION} ({SIZE} bytes): {e}")
        try:
            magic, version, size, rate, _ = _HEADER.unpack_from(self._map, 0)
            if magic != MAGIC or version != VERSION or size != SIZE:
                refuse(
                    f"not a telemetry ring of layout {VERSION} ({SIZE} bytes): magic {magic!r}, "
                    f"layout {version}, {size} bytes"
                )
            # Written once before the ring was shared, so checked once; the loop ticks, so
            # no rate is 0.
            check_rate(rate, "the telemetry ring's rate")
        except Error:
            self._map.close()
            raise
        self.rate: float = rate
        """Haptic ticks per second."""
        self.next: int = self.written()
        """The next tick to read."""
        self.missed: int = 0
        """Ticks overwritten before they were read."""

    def written(self) -> int:
        """Ticks written so far: the next tick's number."""
        return _HEADER.unpack_from(self._map, 0)[4]

    def read(self) -> Optional[Sample]:
        """The next tick, or None if it is not written yet; ticks overwritten before they
        were read are skipped and counted in ``missed``."""
        while True:
            written = self.written()
            if self.next >= written:
                return None
            oldest = max(0, written - (SLOTS - 1))
            if self.next < oldest:
                self.missed += oldest - self.next
                self.next = oldest
            at = _SLOTS_AT + (self.next % SLOTS) * _SLOT
            (before,) = _SEQUENCE.unpack_from(self._map, at)
            values = _SAMPLE.unpack_from(self._map, at + _SEQUENCE.size)
            (after,) = _SEQUENCE.unpack_from(self._map, at)
            if before % 2 == 0 and before == after and values[0] == self.next:
                self.next += 1
                return _sample(values)
            # Written over while read: the writer is a lap ahead.
            self.missed += 1
            self.next += 1

    def follow(self, seconds: Optional[float] = None) -> Iterator[Sample]:
        """Every tick from ``next`` on, each as soon as it is written, for ``seconds`` of the
        loop's ticks (None: until the caller stops); :class:`TimeoutError` should the loop
        write none for two seconds."""
        for sample in self._polled(seconds):
            if sample is None:
                time.sleep(_POLL)
            else:
                yield sample

    async def follow_async(self, seconds: Optional[float] = None) -> AsyncIterator[Sample]:
        """:meth:`follow` for ``async for``: between ticks it sleeps in the event loop, which
        runs other tasks meanwhile."""
        for sample in self._polled(seconds):
            if sample is None:
                await asyncio.sleep(_POLL)
            else:
                yield sample

    def _polled(self, seconds: Optional[float]) -> Iterator[Optional[Sample]]:
        """:meth:`follow`'s ticks, and None each time the next one is not written yet."""
        end = None if seconds is None else self.next + max(1, round(seconds * self.rate))
        waited = time.monotonic()
        while end is None or self.next < end:
            sample = self.read()
            if sample is not None:
                waited = time.monotonic()
            elif time.monotonic() - waited > 2.0:
                raise TimeoutError("the haptic loop stopped writing ticks")
            yield sample

    def close(self) -> None:
        """Unmap the ring."""
        self._map.close()


# Each effector's columns, named as ``hapticctl record`` names them
# (``hapticd_ipc::telemetry_csv``): the numbers first, then the contact's flags and body,
# then where it touches.
_NUMBERS = [
    f"{what}_{axis}"
    for what, axes in [
        ("pose", ["x", "y", "z", "qw", "qx", "qy", "qz"]),
        ("velocity", "xyz"),
        ("angular_velocity", "xyz"),
        ("force", "xyz"),
        ("torque", "xyz"),
    ]
    for axis in axes
]
_WHERE = [f"{what}_{axis}" for what in ("contact", "normal") for axis in "xyz"]


def _numpy() -> Any:
    """The numpy module, or an ImportError saying how to install it."""
    try:
        import numpy
    except ImportError as e:
        raise ImportError(
            "hapticd's numpy blocks need numpy: pip install hapticd[numpy] "
            "(or Debian's python3-numpy)"
        ) from e
    return numpy


def to_numpy(
    samples: Iterable[Sample], effectors: Optional[Sequence[str]] = None
) -> numpy.ndarray:
    """``samples`` as a numpy structured array, a row each, its columns those of ``hapticctl
    record``: ``tick``, ``time``, ``state``; each effector's ``pose_x`` … ``pose_qz``,
    ``velocity_*``, ``angular_velocity_*``, ``force_*``, ``torque_*``, ``contact`` and ``slip``
    (booleans), ``contact_body`` (the body's id, -1 for none), ``contact_*`` (where it touches)
    and ``normal_*``; each string's ``tension_1`` … and ``dac_1`` …. With several effectors
    their columns are named for them (``thumb_pose_x``) by ``effectors``, the device's
    ``Effectors`` (by default ``e0``, ``e1``, …). Every sample must have the first one's
    effectors and strings (ValueError). Needs numpy: ImportError, before ``samples`` is read,
    without it (``pip install hapticd[numpy]``)."""
    numpy = _numpy()
    samples = list(samples)
    effectors_n = len(samples[0].poses) if samples else 0
    strings = len(samples[0].tensions) if samples else 0
    names = [f"e{k}" for k in range(effectors_n)] if effectors is None else list(effectors)
    if len(names) != effectors_n:
        raise ValueError(f"{len(names)} effector names for samples of {effectors_n} effectors")

    def named(k: int, column: str) -> str:
        return column if effectors_n == 1 else f"{names[k]}_{column}"

    state_width = max((len(s.state) for s in samples), default=1)
    columns: List[Tuple[str, str]] = [("tick", "u8"), ("time", "f8"), ("state", f"U{state_width}")]
    for k in range(effectors_n):
        columns += [(named(k, c), "f8") for c in _NUMBERS]
        columns += [(named(k, "contact"), "?"), (named(k, "contact_body"), "i8")]
        columns += [(named(k, "slip"), "?")]
        columns += [(named(k, c), "f8") for c in _WHERE]
    columns += [(f"tension_{j + 1}", "f8") for j in range(strings)]
    columns += [(f"dac_{j + 1}", "i2") for j in range(strings)]
    rows = []
    for s in samples:
        if (len(s.poses), len(s.tensions)) != (effectors_n, strings):
            raise ValueError(
                f"tick {s.tick} has {len(s.poses)} effectors and {len(s.tensions)} strings "
                f"where tick {samples[0].tick} has {effectors_n} and {strings}"
            )
        row: List[Any] = [s.tick, s.time, s.state]
        for k in range(effectors_n):
            row += [*s.poses[k], *s.velocities[k], *s.angular_velocities[k], *s.wrenches[k]]
            body = s.touched[k]
            row += [s.contacts[k], -1 if body is None else body, s.slipping[k]]
            row += [*s.touch_points[k], *s.touch_normals[k]]
        rows.append(tuple(row + s.tensions + s.dac))
    return numpy.array(rows, dtype=columns)
