"""The Python client against a real hapticd on a private bus: the Rust test that runs these
(tests/daemon/python_client.rs) starts both and names the bus in HAPTICD_TEST_BUS."""

import asyncio
import itertools
import math
import os
import time

import pytest

import hapticd


@pytest.fixture
def daemon():
    d = hapticd.connect(os.environ["HAPTICD_TEST_BUS"])
    yield d
    d.close()


def test_devices_and_their_properties(daemon):
    (device,) = daemon.devices
    assert device.state == "running"
    assert device.mechanism == "spidar-g"
    assert device.identity == "sim-spidar-g-1"
    assert "static" in daemon.scenes and daemon.active_scene == "static"


def test_parameters_are_set_and_bad_values_refused_by_name(daemon):
    device = daemon.devices[0]
    device.set("Stiffness", 1500)
    assert device.get("Stiffness") == 1500.0
    for bad, reason in [(math.nan, "NotFinite"), (1e12, "OutOfRange")]:
        with pytest.raises(hapticd.Error) as refused:
            device.set("Stiffness", bad)
        assert refused.value.name == f"org.hapticd.Hapticd1.Error.{reason}"
    assert device.get("Stiffness") == 1500.0
    device.set("Stiffness", 2000)


def test_every_tick_arrives_in_order(daemon):
    device = daemon.devices[0]
    samples = list(device.telemetry(seconds=1.0))
    ring_rate = device.get("LoopRate")
    assert len(samples) == round(ring_rate)
    for a, b in zip(samples, samples[1:]):
        assert b.tick == a.tick + 1
        assert abs(b.time - a.time - 1 / ring_rate) < 1e-6
    for s in samples:
        assert s.state == "running"
        assert len(s.position) == 3 and len(s.force) == 3
        qw, qx, qy, qz = s.poses[0][3:]
        assert abs(qw * qw + qx * qx + qy * qy + qz * qz - 1) < 1e-9
        assert len(s.tensions) == 8 and all(t >= 0 for t in s.tensions)


def test_ticks_are_yielded_as_they_come_and_followed_without_end(daemon):
    device = daemon.devices[0]
    rate = device.get("LoopRate")
    started = time.monotonic()
    ticks = device.telemetry(seconds=2.0)
    first = next(ticks)
    # In hand long before the two seconds asked for are over.
    assert time.monotonic() - started < 1.0
    ticks.close()
    # Without a duration, ticks come until the caller stops taking them.
    taken = [s.tick for s in itertools.islice(device.telemetry(), round(rate / 2))]
    assert taken == list(range(taken[0], taken[0] + round(rate / 2)))
    assert taken[0] > first.tick


def test_ticks_are_followed_in_an_event_loop_that_runs_other_tasks_meanwhile(daemon):
    device = daemon.devices[0]
    rate = device.get("LoopRate")

    async def follow():
        beats = 0

        async def beat():
            nonlocal beats
            while True:
                await asyncio.sleep(0.01)
                beats += 1

        beating = asyncio.create_task(beat())
        ticks = [s.tick async for s in device.telemetry_async(seconds=0.5)]
        beating.cancel()
        return ticks, beats

    ticks, beats = asyncio.run(follow())
    assert ticks == list(range(ticks[0], ticks[0] + round(rate / 2)))
    # Fifty 10 ms beats at best: the follower seldom held the loop up.
    assert beats > 10


def test_a_block_of_ticks_is_a_numpy_array_a_row_a_tick(daemon):
    numpy = pytest.importorskip("numpy")
    device = daemon.devices[0]
    rate = device.get("LoopRate")
    block = device.telemetry_block(seconds=0.5)
    assert block.shape == (round(rate / 2),)
    assert (numpy.diff(block["tick"]) == 1).all()
    assert numpy.allclose(numpy.diff(block["time"]), 1 / rate, rtol=0, atol=1e-6)
    assert (block["state"] == "running").all()
    # One effector: its columns unprefixed, as hapticctl record names them.
    assert {"pose_qw", "force_y", "contact_body", "tension_8", "dac_8"} <= set(block.dtype.names)


def test_scenes_switch_and_unknown_ones_are_named(daemon):
    daemon.switch_scene("blocks")
    assert daemon.active_scene == "blocks"
    with pytest.raises(hapticd.Error) as refused:
        daemon.switch_scene("no-such-scene")
    assert refused.value.name == "org.hapticd.Hapticd1.Error.UnknownScene"
    daemon.switch_scene("static")


def test_a_scene_file_of_ones_own_is_sent_by_descriptor(daemon, tmp_path):
    shipped = os.path.join(os.path.dirname(__file__), "../../../config/scenes/static.yaml")
    mine = tmp_path / "my-floor.yaml"
    with open(shipped) as source:
        mine.write_text(source.read().replace("name: static", "name: my-floor"))
    daemon.switch_scene_file(str(mine))
    assert daemon.active_scene == "my-floor"
    broken = tmp_path / "broken.yaml"
    broken.write_text("shapes: [")
    with pytest.raises(hapticd.Error) as refused:
        daemon.switch_scene_file(str(broken))
    assert refused.value.name == "org.hapticd.Hapticd1.Error.SceneFailed"
    assert "broken.yaml" in refused.value.message
    assert daemon.active_scene == "my-floor"
    daemon.switch_scene("static")


def test_an_effect_is_added_felt_changed_and_removed(daemon):
    device = daemon.devices[0]
    effect = device.add_effect("{kind: constant, force: [0, 0, 1.5]}")
    try:
        assert device.effects == [(effect, "{kind: constant, force: [0, 0, 1.5]}")]
        # Past the forces' ramp back up after the last test's scene switch (0.2 s).
        time.sleep(0.4)
        felt = [s.force[2] for s in device.telemetry(0.1)]
        assert all(abs(f - 1.5) < 1e-9 for f in felt), felt
        device.change_effect(effect, "{kind: constant, force: [0, 0, -1]}")
        time.sleep(0.1)
        assert all(abs(s.force[2] + 1.0) < 1e-9 for s in device.telemetry(0.05))
        with pytest.raises(hapticd.Error) as refused:
            device.add_effect("{kind: sine, direction: [0, 1, 0], frequency: 40, amplitude: .nan}")
        assert refused.value.name == "org.hapticd.Hapticd1.Error.InvalidEffect"
        assert "amplitude" in refused.value.message
    finally:
        device.remove_effect(effect)
    assert device.effects == []
    time.sleep(0.1)
    assert all(s.force[2] == 0.0 for s in device.telemetry(0.05))


def test_calibrate_takes_the_offsets(daemon):
    device = daemon.devices[0]
    before = device.get("CalibrationOffsets")
    device.calibrate()
    assert device.state in ("running", "calibrating")
    assert len(device.get("CalibrationOffsets")) == len(before)


def test_the_world_is_read_and_driven_and_hostile_values_refused_by_name(daemon):
    daemon.switch_scene("blocks")
    names = [b.name for b in daemon.bodies]
    assert names[:2] == ["table", "block"] and daemon.bodies[0].fixed
    world = daemon.devices[0].open_world()
    try:
        before = daemon.body("block")
        impulse = (0.0, 0.0, 0.1 * before.mass)
        after = daemon.apply_impulse("block", impulse)
        assert abs((after.velocity[2] - before.velocity[2]) * before.mass - impulse[2]) < 1e-9
        # The picture shows the body where the scene interface says it is.
        _, frame = world.frame()
        shown = frame.bodies[names.index("block")]
        now = daemon.body("block")
        assert math.dist(shown[:3], now.position) < 0.01
        switches, solids = daemon.devices[0].solids()
        assert switches == frame.scene_switches
        # The table is fixed; the penalty engine shows its convex pieces as their faces.
        assert solids[0].fixed and solids[0].body == 0
        assert all(s.shape == "triangles" and s.triangles for s in solids)
        assert {s.body for s in solids} >= set(range(len(names)))
    finally:
        world.close()
    placed = daemon.set_pose("block", (0.03, 0.0, 0.0))
    assert math.dist(placed.position, (0.03, 0.0, 0.0)) < 1e-9
    for call, reason in [
        (lambda: daemon.body("no-such-body"), "UnknownBody"),
        (lambda: daemon.set_mass("block", math.nan), "NotFinite"),
        (lambda: daemon.set_mass("block", -1), "OutOfRange"),
        (lambda: daemon.apply_impulse("block", (1e6, 0, 0)), "OutOfRange"),
        (lambda: daemon.set_force("table", (0, 1, 0)), "FixedBody"),
    ]:
        with pytest.raises(hapticd.Error) as refused:
            call()
        assert refused.value.name == f"org.hapticd.Hapticd1.Error.{reason}"
    with pytest.raises(ValueError):
        daemon.set_pose("block", (0, 0))
    # A body added joins the world with the next id; the others stay where they rest.
    time.sleep(1.5)
    kept = daemon.body("block")
    cube = daemon.add_body("{ name: cube, box: [0.02, 0.02, 0.02], position: [-0.1, 0.2, -0.1] }")
    assert cube == len(names) and daemon.bodies[cube].name == "cube"
    assert math.dist(daemon.body("block").position, kept.position) < 1e-3
    daemon.remove_body("cube")
    assert "cube" not in [b.name for b in daemon.bodies]
    daemon.switch_scene("static")


def test_a_body_dropped_on_the_grip_is_announced_as_touched(daemon):
    daemon.switch_scene("blocks")
    device = daemon.devices[0]
    block = [b.name for b in daemon.bodies].index("block")
    with device.touches(timeout=0.3) as touches:
        # The grip rests at the origin, its 1 cm pointer clear of every body.
        with pytest.raises(TimeoutError):
            next(touches)
        touches.timeout = 5.0
        # The block (3 cm) let go 1 cm above the pointer falls onto it.
        daemon.set_pose("block", (0.0, 0.03, 0.0))
        touch = next(touches)
    assert touch.event == "begin" and touch.effector == 0, touch
    assert touch.body == (block, "block"), touch
    # Between where it was let go and the table.
    assert -0.03 < touch.point[1] < 0.015, touch
    assert len(touch.normal) == 3 and len(touch.force) == 3
    daemon.switch_scene("static")


def test_joints_are_read_and_driven_as_a_scientist_would(daemon):
    daemon.switch_scene("hinges", wait=60)
    kinds = {j.name: j.kind for j in daemon.joints}
    assert kinds["pivot"] == "revolute" and kinds["runners"] == "prismatic"
    daemon.drive_joint("runners", position=0.03, max_force=5.0)
    time.sleep(1.5)
    drawer = daemon.joint("runners")
    assert abs(drawer.position - 0.03) < 0.002 and abs(drawer.velocity) < 0.01
    daemon.drive_joint("runners")
    for bad, reason in [
        (dict(velocity=math.nan), "NotFinite"),
        (dict(position=99.0), "OutOfRange"),
    ]:
        with pytest.raises(hapticd.Error) as refused:
            daemon.drive_joint("runners", **bad)
        assert refused.value.name == f"org.hapticd.Hapticd1.Error.{reason}"
    with pytest.raises(hapticd.Error) as unknown:
        daemon.joint("trapdoor")
    assert unknown.value.name == "org.hapticd.Hapticd1.Error.UnknownJoint"
    daemon.switch_scene("static")


def test_a_soft_body_is_softened_and_let_go_as_a_scientist_would(daemon):
    daemon.switch_scene("jelly", wait=60)
    time.sleep(1.0)
    stood = -0.02125
    firm = daemon.body("jelly").position[1]
    daemon.set_material("jelly", young=3.0e3, poisson=0.45, damping=0.004)
    time.sleep(1.5)
    soft = daemon.body("jelly").position[1]
    # Ten times as soft, ten times the sag (the volume term stiffens it a little).
    assert 9.5 < (stood - soft) / (stood - firm) < 10.1
    daemon.release("jelly", normal=(0, 1, 0), offset=1.0)
    daemon.pin("jelly", normal=(0, 1, 0), offset=-0.0315)
    for bad, reason in [
        (lambda: daemon.set_material("jelly", math.nan, 0.45), "NotFinite"),
        (lambda: daemon.set_material("jelly", 3.0e3, 0.5), "OutOfRange"),
        (lambda: daemon.set_material("table", 3.0e3, 0.45), "CommandRefused"),
        (lambda: daemon.pin("jelly", (0, 0, 0), 0.0), "OutOfRange"),
    ]:
        with pytest.raises(hapticd.Error) as refused:
            bad()
        assert refused.value.name == f"org.hapticd.Hapticd1.Error.{reason}"
    daemon.switch_scene("static")
