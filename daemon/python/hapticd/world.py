"""A device's picture of the world, read from the memory the daemon hands out: the latest
frame (the grips, the wrenches shown, every body's pose and where the corners of deforming
solids stand) under a sequence lock in a sealed memfd (``Device.OpenWorld``; the layout is
``hapticd_core::world_state``'s, version 4), and the
running scene's solids in a sealed memfd of their own, written once and sized by the scene
(``Device.OpenGeometry``; the layout is ``hapticd_core::world_geometry``'s, version 1). Memory
of another layout is refused.
"""

from __future__ import annotations

import mmap
import os
import struct
from dataclasses import dataclass
from typing import Any, Callable, List, Optional, Tuple, TypeVar

from ._errors import check_count, check_rate, refuse
from .telemetry import CHANNELS, MAX_EFFECTORS

__all__ = ["World", "Frame", "Solid", "Pose", "read_geometry", "SHAPES", "MAX_BODIES"]

MAGIC = b"hapticdW"
VERSION = 4
MAX_BODIES = 4096
"""The most bodies a frame shows: a world of more shows its first ones."""
MAX_CORNERS = 8192
"""The most corners of deforming solids a frame shows: a world of more draws them as at load."""
GEOMETRY_MAGIC = b"hapticdG"
GEOMETRY_VERSION = 1
MAX_SOLIDS = 65536
MAX_TRIANGLES = 2_000_000

SHAPES = {1: "box", 2: "sphere", 3: "cylinder", 4: "plane", 5: "triangles"}
"""The shape of a solid by its number (``HAPTICD_SHAPE_*``)."""
FIXED = 1
"""The flag of a solid that does not move."""
DEFORMING = 4
"""The flag of a solid of triangles whose corners move on their own (a soft body)."""
NO_BODY = 0xFFFFFFFF
"""The body of a solid that belongs to none."""

_HEADER = struct.Struct("<8sII")
_SEQUENCE = struct.Struct("<Q")
# The frame: time, rate, state, scene switches, effectors, strings, bodies, whether it has
# proxies; each effector's grip pose, degrees of freedom, proxy and wrench; each string's
# effector, motor, knot, tension and tension range; then the bodies' poses.
_FRAME_HEAD = struct.Struct(
    "<dd6I"
    + "7d" * MAX_EFFECTORS
    + f"{MAX_EFFECTORS}I"
    + "3d" * MAX_EFFECTORS
    + "6d" * MAX_EFFECTORS
    + f"{CHANNELS}I"
    + "3d" * CHANNELS
    + "3d" * CHANNELS
    + f"{CHANNELS}d"
    + "2d" * CHANNELS
)
_POSE = struct.Struct("<7d")
# After the bodies: how many corners the deforming solids have, then where they stand.
_CORNER_COUNT = struct.Struct("<I")
_CORNER = struct.Struct("<3f")
_CORNERS_AT = _FRAME_HEAD.size + MAX_BODIES * _POSE.size
# The frame ends padded to its 8-byte alignment.
_FRAME = -(-(_CORNERS_AT + _CORNER_COUNT.size + MAX_CORNERS * _CORNER.size) // 8) * 8
# A solid: body, shape, flags, first triangle, triangle count, sizes, frame, colour.
_SOLID = struct.Struct("<5I4x3d7d4f")
_TRIANGLE = struct.Struct("<9d")
# After the geometry's header: the scene's switches, bodies, solids and triangles.
_GEOMETRY_HEAD = struct.Struct("<4I")

_SEQUENCE_AT = _HEADER.size
_FRAME_AT = _SEQUENCE_AT + _SEQUENCE.size
SIZE = _FRAME_AT + _FRAME

Pose = Tuple[float, float, float, float, float, float, float]
"""x, y, z (metres), then the orientation qw, qx, qy, qz."""

_T = TypeVar("_T")


@dataclass(frozen=True)
class Frame:
    """One picture of the world."""

    time: float
    """Loop time, seconds."""
    scene_switches: int
    """Scenes swapped in since the start: a change means other bodies and solids."""
    grips: List[Pose]
    """Each effector's grip pose."""
    wrenches: List[Tuple[float, ...]]
    """Each effector's displayed force (N) and torque (N·m)."""
    bodies: List[Pose]
    """Each body's pose, in the order of its id (the scene interface's ``Bodies``)."""
    corners: List[Tuple[float, float, float]]
    """Where the corners of the deforming solids' triangles stand (metres, in each solid's
    frame), solid by solid and triangle by triangle in the geometry's order; empty when there
    are more than a frame holds."""


@dataclass(frozen=True)
class Solid:
    """One drawable solid of the scene, placed by its body's pose."""

    body: Optional[int]
    """The id of the body it moves with, or None (it stays where ``offset`` puts it)."""
    shape: str
    """box, sphere, cylinder, plane or triangles."""
    fixed: bool
    """Whether it never moves."""
    deforming: bool
    """Whether its corners move on their own (a soft body's surface): the frames' ``corners``
    say where they stand."""
    size: Tuple[float, float, float]
    """A box's half edges; a sphere's or cylinder's radius (and a cylinder's length); a plane's
    width drawn."""
    offset: Pose
    """Its frame in its body's frame (in the world's when it has no body)."""
    triangles: List[Tuple[float, ...]]
    """A triangles solid's corners, nine numbers each, in its frame."""


class World:
    """A device's picture of the world, mapped read-only from the descriptor ``fd``."""

    def __init__(self, fd: int) -> None:
        try:
            self._map = mmap.mmap(fd, SIZE, mmap.MAP_SHARED, mmap.PROT_READ)
        except ValueError as e:  # shorter than the layout
            refuse(f"not a shared world of layout {VERSION} ({SIZE} bytes): {e}")
        magic, version, size = _HEADER.unpack_from(self._map, 0)
        if magic != MAGIC or version != VERSION or size != SIZE:
            self._map.close()
            refuse(
                f"not a shared world of layout {VERSION} ({SIZE} bytes): magic {magic!r}, "
                f"layout {version}, {size} bytes"
            )

    def _read(self, sequence_at: int, read: Callable[[], _T]) -> Tuple[int, _T]:
        """``read()`` of a block under the sequence at ``sequence_at``, retried while written."""
        while True:
            (before,) = _SEQUENCE.unpack_from(self._map, sequence_at)
            value = read()
            (after,) = _SEQUENCE.unpack_from(self._map, sequence_at)
            if before % 2 == 0 and before == after:
                return before, value

    def frame(self) -> Tuple[int, Frame]:
        """The latest frame and its sequence (it grows with every frame written)."""

        def read() -> Tuple[Tuple[Any, ...], List[Pose], List[Tuple[float, float, float]]]:
            head = _FRAME_HEAD.unpack_from(self._map, _FRAME_AT)
            # A world of more bodies than the layout holds shows its first ones.
            shown = min(head[6], MAX_BODIES)
            first = _FRAME_AT + _FRAME_HEAD.size
            bodies = [_POSE.unpack_from(self._map, first + k * _POSE.size) for k in range(shown)]
            at = _FRAME_AT + _CORNERS_AT
            (count,) = _CORNER_COUNT.unpack_from(self._map, at)
            at += _CORNER_COUNT.size
            corners = (
                [_CORNER.unpack_from(self._map, at + k * _CORNER.size) for k in range(count)]
                if count <= MAX_CORNERS
                else []
            )
            return head, bodies, corners

        sequence, (head, bodies, corners) = self._read(_SEQUENCE_AT, read)
        # Checked once the sequence says the frame is whole, not half written. Its state and
        # proxy flag are neither used nor shown here, so they are left unchecked.
        time_, rate, _state, switches, effectors, strings, _count, _ = head[:8]
        check_rate(rate, "the world frame's rate", zero=True)  # 0: no frame written yet
        check_count(effectors, "effectors in the world frame", MAX_EFFECTORS)
        check_count(strings, "strings in the world frame", CHANNELS)
        at = 8
        grips = [tuple(head[at + 7 * k : at + 7 * k + 7]) for k in range(effectors)]
        at += 7 * MAX_EFFECTORS + MAX_EFFECTORS + 3 * MAX_EFFECTORS
        wrenches = [tuple(head[at + 6 * k : at + 6 * k + 6]) for k in range(effectors)]
        return sequence, Frame(time_, switches, grips, wrenches, bodies, corners)

    def close(self) -> None:
        """Unmap the world."""
        self._map.close()


def read_geometry(fd: int) -> Tuple[int, List[Solid]]:
    """The solids in the memory ``fd`` (from ``Device.OpenGeometry``), and the frames'
    ``scene_switches`` of the scene they are."""
    length = os.fstat(fd).st_size
    what = f"not a scene's geometry of layout {GEOMETRY_VERSION}"
    if length < _HEADER.size + _GEOMETRY_HEAD.size:
        refuse(f"{what}: {length} bytes")
    with mmap.mmap(fd, length, mmap.MAP_SHARED, mmap.PROT_READ) as block:
        magic, version, size = _HEADER.unpack_from(block, 0)
        switches, _bodies, count, triangles = _GEOMETRY_HEAD.unpack_from(block, _HEADER.size)
        check_count(count, "solids in the scene's geometry", MAX_SOLIDS)
        check_count(triangles, "triangles in the scene's geometry", MAX_TRIANGLES)
        solids_at = _HEADER.size + _GEOMETRY_HEAD.size
        triangles_at = solids_at + count * _SOLID.size
        expected = triangles_at + triangles * _TRIANGLE.size
        if (magic, version, size) != (GEOMETRY_MAGIC, GEOMETRY_VERSION, expected) or length < size:
            refuse(
                f"{what} ({expected} bytes for {count} solids and {triangles} triangles): "
                f"magic {magic!r}, layout {version}, {size} bytes, {length} mapped"
            )
        out = []
        for k in range(count):
            v = _SOLID.unpack_from(block, solids_at + k * _SOLID.size)
            body, shape, flags, first, n = v[:5]
            if first + n > triangles:
                refuse(f"solid {k} of the scene's geometry: triangles {first}..{first + n} "
                       f"of {triangles}")
            corners = [
                _TRIANGLE.unpack_from(block, triangles_at + t * _TRIANGLE.size)
                for t in range(first, first + n)
            ]
            out.append(
                Solid(
                    body=None if body == NO_BODY else body,
                    shape=SHAPES.get(shape, "unknown"),
                    fixed=bool(flags & FIXED),
                    deforming=bool(flags & DEFORMING),
                    size=tuple(v[5:8]),
                    offset=tuple(v[8:15]),
                    triangles=corners,
                )
            )
    return switches, out
