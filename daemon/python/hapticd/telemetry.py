"""Every tick of a device's haptic loop, read from the telemetry ring the daemon hands out
(``Device.OpenTelemetry``): a sealed memfd, mapped read-only here, holding the last ticks in
slots each under a sequence lock of its own. The layout is ``hapticd_core::telemetry``'s
(version 3); a ring of another layout is refused.
"""

from __future__ import annotations

import mmap
import struct
import time
from dataclasses import dataclass
from typing import Iterator, List, Optional, Tuple

from ._errors import Error, check_count, check_rate, refuse

MAGIC = b"hapticdT"
VERSION = 3
SLOTS = 8192
MAX_EFFECTORS = 4
CHANNELS = 8
STATES = ("running", "fault", "disconnected", "uncalibrated")
"""The device states by their number (``state_code``); any other reads as ``unknown(N)``."""

NO_BODY = 0xFFFFFFFF

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
        return self.poses[0][:3]

    @property
    def force(self) -> Tuple[float, float, float]:
        """The force displayed on the first effector, newtons."""
        return self.wrenches[0][:3]


def _state_name(state: int) -> str:
    """The name of device state number ``state``."""
    # A number this client does not know is a newer daemon's state, likely a fault of a new
    # kind: named so that no caller testing for "running" takes it for running, yet not
    # raised, so that a recording keeps every tick around the fault (its poses and forces are
    # still sound).
    return STATES[state] if state < len(STATES) else f"unknown({state})"


def _sample(values: Tuple) -> Sample:
    tick, time_, state, effectors, strings, contacts, slipping = values[:7]
    effectors = check_count(effectors, f"effectors in the sample of tick {tick}", MAX_EFFECTORS)
    strings = check_count(strings, f"strings in the sample of tick {tick}", CHANNELS)
    at = 7
    touched = [None if b == NO_BODY else b for b in values[at : at + effectors]]
    at += MAX_EFFECTORS

    def per_effector(width: int) -> List[Tuple[float, ...]]:
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

    def read(self) -> "Sample | None":
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

    def follow(self, seconds: float) -> Iterator[Sample]:
        """Every tick from now for ``seconds`` of the loop's ticks, as they are written."""
        end = self.next + max(1, round(seconds * self.rate))
        waited = time.monotonic()
        while self.next < end:
            sample = self.read()
            if sample is None:
                if time.monotonic() - waited > 2.0:
                    raise TimeoutError("the haptic loop stopped writing ticks")
                time.sleep(0.001)
                continue
            waited = time.monotonic()
            yield sample

    def close(self) -> None:
        """Unmap the ring."""
        self._map.close()
