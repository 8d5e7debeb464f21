"""The readers of the memory the daemon shares (the telemetry ring, the world), without a
daemon: each test lays the memory out in a memfd as ``hapticd.telemetry`` and
``hapticd.world`` read it, with what a newer or a broken daemon could leave there."""

import math
import os
import struct
import sys

import pytest

import hapticd
from hapticd import telemetry, world
from hapticd.telemetry import Ring
from hapticd.world import World


@pytest.fixture
def memfd():
    """Make a memfd of ``length`` bytes holding ``writes`` ({offset: bytes}); closed after."""
    fds = []

    def make(length, writes):
        fd = os.memfd_create("hapticd-test", os.MFD_CLOEXEC)
        fds.append(fd)
        for at, data in writes.items():
            os.pwrite(fd, data, at)
        # Cut to length after writing: a write past the end would make it longer.
        os.ftruncate(fd, length)
        return fd

    yield make
    for fd in fds:
        os.close(fd)


def sample(tick, state=0, effectors=1, strings=4):
    """The bytes of a tick's sample: the first effector at rest at the origin."""
    values = [tick, tick / 1000, state, effectors, strings, 0, 0]
    values += [telemetry.NO_BODY] * telemetry.MAX_EFFECTORS
    poses = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0] * telemetry.MAX_EFFECTORS
    # Velocities, angular velocities, wrenches, touch points and normals, then tensions.
    rest = [0.0] * ((3 + 3 + 6 + 3 + 3) * telemetry.MAX_EFFECTORS + telemetry.CHANNELS)
    dac = [0] * telemetry.CHANNELS
    return telemetry._SAMPLE.pack(*values, *poses, *rest, *dac)


def ring(
    memfd,
    samples=(),
    rate=1000.0,
    magic=telemetry.MAGIC,
    version=telemetry.VERSION,
    size=telemetry.SIZE,
    length=telemetry.SIZE,
):
    """A telemetry ring's descriptor holding ``samples`` (ticks 0, 1, …, each whole)."""
    header = telemetry._HEADER.pack(magic, version, size, rate, len(samples))
    writes = {0: header}
    for tick, data in enumerate(samples):
        at = telemetry._SLOTS_AT + tick * telemetry._SLOT
        writes[at] = telemetry._SEQUENCE.pack(2) + data
    return memfd(length, writes)


def frame(rate=1000.0, effectors=1, strings=4, bodies=2):
    """The bytes of a world frame with ``effectors``, ``strings`` and ``bodies``."""
    head = [1.5, rate, 0, 1, effectors, strings, bodies, 0]
    head += [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0] * world.MAX_EFFECTORS  # grips
    head += [3] * world.MAX_EFFECTORS  # degrees of freedom
    head += [0.0] * ((3 + 6) * world.MAX_EFFECTORS)  # proxies, wrenches
    head += [0] * world.CHANNELS  # each string's effector
    head += [0.0] * ((3 + 3 + 1 + 2) * world.CHANNELS)  # motors, knots, tensions, ranges
    return world._FRAME_HEAD.pack(*head)


def solid(first=0, triangles=0):
    """The bytes of a triangles solid of no body."""
    sizes, offset, colour = (0.0,) * 3, (0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0), (0.0,) * 4
    return world._SOLID.pack(world.NO_BODY, 5, 0, first, triangles, *sizes, *offset, *colour)


def shared_world(
    memfd,
    head=None,
    magic=world.MAGIC,
    version=world.VERSION,
    size=world.SIZE,
    length=world.SIZE,
):
    """A shared world's descriptor: ``head`` as its frame."""
    writes = {
        0: world._HEADER.pack(magic, version, size),
        world._SEQUENCE_AT: world._SEQUENCE.pack(2),
        world._FRAME_AT: frame() if head is None else head,
    }
    return memfd(length, writes)


def geometry(memfd, solids=(), triangles=0, solid_count=None, triangle_count=None, size=None):
    """A scene's geometry's descriptor: ``solids`` and ``triangles`` (each its index), the
    counts and the size it says as given, else as written."""
    head = world._HEADER.size + world._GEOMETRY_HEAD.size
    written = head + len(solids) * world._SOLID.size + triangles * world._TRIANGLE.size
    solid_count = len(solids) if solid_count is None else solid_count
    triangle_count = triangles if triangle_count is None else triangle_count
    writes = {
        0: world._HEADER.pack(world.GEOMETRY_MAGIC, world.GEOMETRY_VERSION,
                              written if size is None else size),
        world._HEADER.size: world._GEOMETRY_HEAD.pack(3, 2, solid_count, triangle_count),
    }
    for k, data in enumerate(solids):
        writes[head + k * world._SOLID.size] = data
    at = head + len(solids) * world._SOLID.size
    for t in range(triangles):
        writes[at + t * world._TRIANGLE.size] = world._TRIANGLE.pack(t, *[0.0] * 8)
    return memfd(written, writes)


def refused(call):
    """The :class:`hapticd.Error` ``call()`` raises, checked to name bad shared memory."""
    with pytest.raises(hapticd.Error) as e:
        call()
    assert e.value.name == hapticd.BAD_SHARED_MEMORY
    return e.value.message


def test_a_state_this_client_does_not_know_never_reads_as_running(memfd):
    # A newer daemon's states 4 and 7 (a new kind of fault, say) beside a known one.
    r = Ring(ring(memfd, [sample(0, state=1), sample(1, state=4), sample(2, state=7)]))
    try:
        r.next = 0
        states = [r.read().state for _ in range(3)]
    finally:
        r.close()
    assert states == ["fault", "unknown(4)", "unknown(7)"]


@pytest.mark.parametrize("rate", [math.nan, math.inf, -math.inf, 0.0, -1000.0, 1e300])
def test_a_ring_whose_rate_is_no_rate_is_refused(memfd, rate):
    # Read as it was, a NaN rate raised ValueError from follow(), an infinite one
    # OverflowError, and 0 followed a single tick however long it was asked to.
    message = refused(lambda: Ring(ring(memfd, rate=rate)))
    assert repr(rate) in message and "rate" in message


@pytest.mark.parametrize("field, value", [("effectors", 5), ("strings", 9)])
def test_a_sample_counting_more_than_its_layout_holds_is_refused(memfd, field, value):
    r = Ring(ring(memfd, [sample(0), sample(1, **{field: value})]))
    try:
        r.next = 0
        assert r.read().tick == 0
        message = refused(r.read)
    finally:
        r.close()
    assert f"{field} in the sample of tick 1: {value}" in message


LAYOUTS = {
    "magic": {"magic": b"hapticdX"},
    "version": {"version": 99},
    "size": {"size": 12345},
    "short": {"length": 4096},
}


@pytest.mark.parametrize("mismatch", LAYOUTS)
def test_a_ring_of_another_layout_is_refused(memfd, mismatch):
    message = refused(lambda: Ring(ring(memfd, **LAYOUTS[mismatch])))
    assert "not a telemetry ring of layout" in message


@pytest.mark.parametrize("mismatch", LAYOUTS)
def test_a_world_of_another_layout_is_refused(memfd, mismatch):
    message = refused(lambda: World(shared_world(memfd, **LAYOUTS[mismatch])))
    assert "not a shared world of layout" in message


@pytest.mark.parametrize(
    "bad, said",
    [
        ({"rate": math.nan}, "nan ticks a second"),
        ({"rate": math.inf}, "inf ticks a second"),
        ({"rate": -1.0}, "-1.0 ticks a second"),
        ({"rate": 1e300}, "1e+300 ticks a second"),
        ({"effectors": 5}, "effectors in the world frame: 5"),
        ({"strings": 9}, "strings in the world frame: 9"),
    ],
    ids=["rate-nan", "rate-inf", "rate-negative", "rate-1e300", "effectors-5", "strings-9"],
)
def test_a_world_frame_whose_rate_or_counts_are_not_its_layouts_is_refused(memfd, bad, said):
    # What a daemon writes reads: rate 0 before its first frame, and more bodies than the
    # layout holds (the first ones shown).
    w = World(shared_world(memfd, head=frame(rate=0.0, bodies=world.MAX_BODIES + 5)))
    try:
        _, good = w.frame()
    finally:
        w.close()
    assert len(good.grips) == 1 and len(good.bodies) == world.MAX_BODIES
    w = World(shared_world(memfd, head=frame(**bad)))
    try:
        assert said in refused(w.frame)
    finally:
        w.close()


def test_a_scene_of_more_triangles_than_the_world_once_held_reads_whole(memfd):
    # 20 000 triangles: the world's block once kept the first 16 384 of a scene's.
    fd = geometry(memfd, [solid(0, 20_000), solid(20_000, 0)], triangles=20_000)
    switches, (mesh, empty) = world.read_geometry(fd)
    assert switches == 3 and mesh.shape == "triangles" and empty.triangles == []
    assert len(mesh.triangles) == 20_000 and mesh.triangles[-1][0] == 19_999


@pytest.mark.parametrize(
    "bad, said",
    [
        ({"solid_count": world.MAX_SOLIDS + 1}, "solids in the scene's geometry: 65537"),
        ({"triangle_count": world.MAX_TRIANGLES + 1},
         "triangles in the scene's geometry: 2000001"),
        # More solids than its size holds: read as it says, it would read past the memory.
        ({"solid_count": 3}, "bytes for 3 solids"),
        ({"size": 12345}, "12345 bytes"),
        ({"solids": [solid(first=1, triangles=5)]}, "triangles 1..6 of 3"),
    ],
    ids=["solids", "triangles", "counts-past-size", "size", "solid-past-triangles"],
)
def test_a_scene_geometry_that_does_not_fit_its_layout_is_refused(memfd, bad, said):
    given = {"solids": [solid(first=1, triangles=2)], "triangles": 3, **bad}
    assert said in refused(lambda: world.read_geometry(geometry(memfd, **given)))


def test_ticks_lay_out_as_numpy_columns_named_for_their_effectors(memfd):
    numpy = pytest.importorskip("numpy")
    two = {"effectors": 2}
    r = Ring(ring(memfd, [sample(0, **two), sample(1, state=4, **two), sample(2)]))
    try:
        r.next = 0
        both, unknown, one = r.read(), r.read(), r.read()
    finally:
        r.close()
    block = telemetry.to_numpy([both, unknown], ["thumb", "index"])
    assert block.shape == (2,) and list(block["state"]) == ["running", "unknown(4)"]
    assert list(block["index_pose_qw"]) == [1.0, 1.0]
    assert list(block["thumb_contact_body"]) == [-1, -1]
    assert block.dtype.names[-1] == "dac_4" and "pose_x" not in block.dtype.names
    assert telemetry.to_numpy([one]).dtype.names[3] == "pose_x"
    with pytest.raises(ValueError, match="tick 0 has 2 effectors and 4 strings where tick 2"):
        telemetry.to_numpy([one, both])
    assert numpy.array_equal(telemetry.to_numpy([])["tick"], [])


def test_without_numpy_a_block_says_how_to_install_it_before_reading_a_tick(monkeypatch):
    monkeypatch.setitem(sys.modules, "numpy", None)  # import numpy: ImportError

    def unread():
        raise AssertionError("a tick was read")
        yield

    with pytest.raises(ImportError, match=r"pip install hapticd\[numpy\]"):
        telemetry.to_numpy(unread())
