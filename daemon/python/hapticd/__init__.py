"""A client of hapticd, the SPIDAR haptics daemon, over D-Bus.

``hapticd.connect()`` reaches the daemon on the system bus (or at a bus address); its
``devices`` read and change their parameters, calibrate, hand out every tick of their haptic
loop as it comes (``Device.telemetry``, ``Device.telemetry_async`` for ``async for``, and
``Device.telemetry_block``, a numpy array), announce their touches (``Device.touches``) and
show their picture of the world (``Device.open_world``); ``scenes`` and ``switch_scene``
choose the world, and ``bodies``, ``body``, ``set_pose``, ``set_velocity``, ``apply_impulse``,
``set_force``, ``set_mass``, ``set_friction``, ``set_material``, ``pin``, ``release``,
``add_body`` and ``remove_body`` drive the running one. Every error the daemon returns is raised as :class:`Error` carrying its
D-Bus error name; shared memory holding what no daemon of its layout writes is refused as an
:class:`Error` named :data:`BAD_SHARED_MEMORY`.
"""

from __future__ import annotations

import os
import time
from collections import deque
from dataclasses import dataclass
from typing import (
    TYPE_CHECKING,
    Any,
    AsyncIterator,
    Callable,
    Iterator,
    List,
    Optional,
    Sequence,
    Tuple,
)

from jeepney import (
    DBusAddress,
    HeaderFields,
    MatchRule,
    Message,
    MessageType,
    Properties,
    new_method_call,
)
from jeepney.bus_messages import message_bus
from jeepney.io.blocking import DBusConnection, open_dbus_connection

from ._errors import BAD_SHARED_MEMORY, NOT_RUNNING, Error, NotRunning, refuse
from .telemetry import Ring, Sample, to_numpy
from .world import Frame, Solid, World, read_geometry

if TYPE_CHECKING:
    import numpy
    from jeepney.io.common import FilterHandle

__all__ = [
    "connect",
    "Hapticd",
    "Device",
    "Touch",
    "Touches",
    "Body",
    "BodyState",
    "Joint",
    "JointState",
    "Error",
    "NotRunning",
    "BAD_SHARED_MEMORY",
    "NOT_RUNNING",
    "Sample",
    "World",
    "Frame",
    "Solid",
]

BUS_NAME = "org.hapticd.Hapticd1"
MANAGER_PATH = "/org/hapticd/Hapticd1"
MANAGER = "org.hapticd.Hapticd1.Manager"
DEVICE = "org.hapticd.Hapticd1.Device"
SCENE_PATH = "/org/hapticd/Hapticd1/scene"
SCENE = "org.hapticd.Hapticd1.Scene"


class _Bus:
    """One connection and the calls made on it."""

    def __init__(self, connection: DBusConnection) -> None:
        self.connection = connection

    def send(self, message: Message) -> Tuple[Any, ...]:
        """Send ``message`` and return its reply's body, raising :class:`Error` for an error."""
        reply = self.connection.send_and_get_reply(message)
        if reply.header.message_type == MessageType.error:
            name = reply.header.fields.get(HeaderFields.error_name, "error")
            raise Error(name, str(reply.body[0]) if reply.body else "")
        return reply.body

    def call(
        self,
        path: str,
        interface: str,
        method: str,
        signature: str = "",
        body: Tuple[Any, ...] = (),
    ) -> Tuple[Any, ...]:
        """Call ``method`` of ``interface`` on the daemon's object ``path``; the reply's body."""
        address = DBusAddress(path, bus_name=BUS_NAME, interface=interface)
        return self.send(new_method_call(address, method, signature, body))

    def get(self, path: str, interface: str, name: str) -> Tuple[str, Any]:
        """Property ``name`` as (signature, value)."""
        address = DBusAddress(path, bus_name=BUS_NAME, interface=interface)
        return self.send(Properties(address).get(name))[0]

    def set(self, path: str, interface: str, name: str, signature: str, value: Any) -> None:
        """Set property ``name`` to ``value`` of D-Bus type ``signature``."""
        address = DBusAddress(path, bus_name=BUS_NAME, interface=interface)
        self.send(Properties(address).set(name, signature, value))


class Device:
    """One haptic device of the daemon (as :attr:`Hapticd.devices` lists them)."""

    def __init__(self, bus: _Bus, path: str) -> None:
        self._bus = bus
        self.path: str = path
        """Its D-Bus object path."""

    def get(self, name: str) -> Any:
        """The property ``name`` (``Stiffness``, ``Pose``, ``State``, …)."""
        return self._bus.get(self.path, DEVICE, name)[1]

    def set(self, name: str, value: Any) -> None:
        """Set the writable property ``name`` (``Stiffness``, ``MaxForce``, …); a value the
        daemon refuses (NaN, out of range) raises :class:`Error` and changes nothing."""
        signature = self._bus.get(self.path, DEVICE, name)[0]
        if signature == "d":
            value = float(value)
        self._bus.set(self.path, DEVICE, name, signature, value)

    @property
    def state(self) -> str:
        """running, calibrating, fault, disconnected or uncalibrated."""
        return self.get("State")

    @property
    def mechanism(self) -> str:
        """The mechanism that drives the device."""
        return self.get("Mechanism")

    @property
    def identity(self) -> str:
        """The device's stable identity (its bus path or serial, or ``sim`` for the simulator)."""
        return self.get("Identity")

    def calibrate(self) -> None:
        """Take the counter offsets now, every grip held at its calibration pose."""
        self._bus.call(self.path, DEVICE, "Calibrate")

    @property
    def effects(self) -> List[Tuple[int, str]]:
        """The effects rendered besides the scene, by id, each as written (YAML)."""
        return [(int(i), str(text)) for i, text in self.get("Effects")]

    def add_effect(self, effect: str) -> int:
        """Start an effect written in YAML, one entry of a scene file's ``effects:`` (such as
        ``"{kind: sine, direction: [0, 1, 0], frequency: 40, amplitude: 0.5}"``); its id.
        Every mistake is an :class:`Error` named ``…Error.InvalidEffect`` saying where."""
        (id_,) = self._bus.call(self.path, DEVICE, "AddEffect", "s", (effect,))
        return int(id_)

    def change_effect(self, id_: int, effect: str) -> None:
        """Cross-fade effect ``id_`` into the one ``effect`` (YAML) describes."""
        self._bus.call(self.path, DEVICE, "ChangeEffect", "us", (id_, effect))

    def remove_effect(self, id_: int) -> None:
        """Fade effect ``id_`` out."""
        self._bus.call(self.path, DEVICE, "RemoveEffect", "u", (id_,))

    def clear_effects(self) -> None:
        """Fade every effect out."""
        self._bus.call(self.path, DEVICE, "ClearEffects")

    def open_telemetry(self) -> Ring:
        """The device's telemetry ring, mapped read-only, its cursor at the next tick. The
        calling thread moves off the CPU hapticd gives its haptic thread (the last one it may
        use), as hapticd's renderer and bridge do: on a kernel without full preemption, a
        reader's system calls there would delay the loop's wakes."""
        _keep_off_the_haptic_cpu()
        (fd,) = self._bus.call(self.path, DEVICE, "OpenTelemetry", "a{sv}", ({},))
        raw = fd.to_raw_fd()
        try:
            return Ring(raw)
        finally:
            os.close(raw)

    def open_world(self) -> World:
        """The device's picture of the world (grips, wrenches shown, every body's pose),
        mapped read-only."""
        (fd,) = self._bus.call(self.path, DEVICE, "OpenWorld")
        raw = fd.to_raw_fd()
        try:
            return World(raw)
        finally:
            os.close(raw)

    def solids(self) -> Tuple[int, List[Solid]]:
        """The running scene's solids as pictures show them, and the world frames'
        ``scene_switches`` of that scene (ask again when the frames count another)."""
        fd, switches = self._bus.call(self.path, DEVICE, "OpenGeometry")
        raw = fd.to_raw_fd()
        try:
            read, solids = read_geometry(raw)
        finally:
            os.close(raw)
        if read != switches:
            refuse(f"the scene's geometry is of switch {read}, the daemon said {switches}")
        return switches, solids

    def telemetry(self, seconds: Optional[float] = None) -> Iterator[Sample]:
        """Every tick of the haptic loop from now (this call) for ``seconds`` of the loop's
        time, or until the caller stops when None, each yielded as soon as it is written:
        samples with ``tick``, ``time``, ``position``, ``force`` and the rest (see
        :class:`Sample`). Ticks read too late are skipped (:meth:`open_telemetry` gives a ring
        whose ``missed`` counts them); :class:`TimeoutError` should the loop write none for
        two seconds."""
        return _followed(self.open_telemetry(), seconds)

    def telemetry_async(self, seconds: Optional[float] = None) -> AsyncIterator[Sample]:
        """:meth:`telemetry` for ``async for``: while the next tick is not written it sleeps
        in the event loop, which runs other tasks meanwhile."""
        return _followed_async(self.open_telemetry(), seconds)

    def telemetry_block(self, seconds: float) -> numpy.ndarray:
        """Every tick from now for ``seconds``, as one numpy structured array (a row a tick;
        the columns those of ``hapticctl record``, named for the device's effectors: see
        :func:`hapticd.telemetry.to_numpy`). Needs numpy: ``pip install hapticd[numpy]``."""
        return to_numpy(self.telemetry(seconds), self.get("Effectors"))

    def touches(self, timeout: Optional[float] = None) -> Touches:
        """The device's touches as the daemon announces them, from now on: iterating waits
        for each (up to ``timeout`` seconds, else :class:`TimeoutError`; None: for ever)."""
        return Touches(self._bus, self.path, timeout)


def _keep_off_the_haptic_cpu() -> None:
    """Move the calling thread off the last CPU it may use (hapticd's haptic CPU), unless
    that is the only one."""
    allowed = sorted(os.sched_getaffinity(0))
    if len(allowed) > 1:
        os.sched_setaffinity(0, allowed[:-1])


def _followed(ring: Ring, seconds: Optional[float]) -> Iterator[Sample]:
    """``ring.follow(seconds)``, the ring closed at its end."""
    try:
        yield from ring.follow(seconds)
    finally:
        ring.close()


async def _followed_async(ring: Ring, seconds: Optional[float]) -> AsyncIterator[Sample]:
    """``ring.follow_async(seconds)``, the ring closed at its end."""
    try:
        async for sample in ring.follow_async(seconds):
            yield sample
    finally:
        ring.close()


@dataclass(frozen=True)
class Touch:
    """A change of an effector's touch, as the daemon announces it (its ``Touch`` signal,
    found in the telemetry ring: at most ten a device each tenth of a second)."""

    effector: int
    """The effector, by index (the device's ``Effectors``)."""
    event: str
    """What happened: ``begin`` (it began touching a body, or another body than before),
    ``end`` (it stopped) or ``slip`` (it began to slide along it after sticking)."""
    tick: int
    """The tick it happened at."""
    time: float
    """The loop's time then, seconds."""
    body: Optional[Tuple[int, str]]
    """The body touched, by id and name (:attr:`Hapticd.bodies`); None for a solid that is no
    body."""
    point: Tuple[float, float, float]
    """Where they touch, metres (for an end: where they last touched)."""
    normal: Tuple[float, float, float]
    """The touched surface's outward normal (the force's direction where the scene cannot
    say)."""
    force: Tuple[float, float, float]
    """The force displayed, newtons."""


class Touches:
    """A device's touches as the daemon announces them (see :meth:`Device.touches`): an
    iterator of :class:`Touch`, each waited for. Calls on the same connection meanwhile keep
    the touches announced during them. A context manager, or :meth:`close` it."""

    def __init__(self, bus: _Bus, path: str, timeout: Optional[float]) -> None:
        self._bus = bus
        self.timeout: Optional[float] = timeout
        """How long iterating waits for the next touch, seconds (None: for ever)."""
        self._rule = MatchRule(type="signal", interface=DEVICE, member="Touch", path=path)
        # Unbounded: a touch is kept until it is read, however long the caller takes
        # (at most a hundred a second come).
        handle = bus.connection.filter(self._rule, queue=deque())
        try:
            # Filtered here before the bus is asked, so that none sent after its answer is lost.
            bus.send(message_bus.AddMatch(self._rule))
        except BaseException:
            handle.close()
            raise
        self._filter: Optional[FilterHandle] = handle

    def __iter__(self) -> "Touches":
        return self

    def __next__(self) -> Touch:
        """The next touch, waited for up to ``timeout`` seconds (:class:`TimeoutError` past
        them, after which the next may still come); none once closed."""
        if self._filter is None:
            raise StopIteration
        message = self._bus.connection.recv_until_filtered(
            self._filter.queue, timeout=self.timeout
        )
        effector, event, tick, time_, body, name, point, normal, force = message.body
        return Touch(
            effector=effector,
            event=event,
            tick=tick,
            time=time_,
            body=None if body < 0 else (body, name),
            point=tuple(point),
            normal=tuple(normal),
            force=tuple(force),
        )

    def close(self) -> None:
        """Stop following the touches (iterating ends)."""
        if self._filter is None:
            return
        self._filter.close()
        self._filter = None
        self._bus.send(message_bus.RemoveMatch(self._rule))

    def __enter__(self) -> "Touches":
        return self

    def __exit__(self, *_: object) -> None:
        self.close()


@dataclass(frozen=True)
class Body:
    """A body of the running world."""

    id: int
    """Its place in the world's list (and in a frame's ``bodies``)."""
    name: str
    """Its name in the scene file."""
    fixed: bool
    """Forces do not move it."""


@dataclass(frozen=True)
class BodyState:
    """A body's state, as a change left it (or now, for :meth:`Hapticd.body`)."""

    position: Tuple[float, float, float]
    """Centre of mass, metres."""
    orientation: Tuple[float, float, float, float]
    """Unit quaternion qw, qx, qy, qz."""
    velocity: Tuple[float, float, float]
    """Velocity of the centre of mass, m/s."""
    spin: Tuple[float, float, float]
    """Angular velocity, rad/s."""
    force: Tuple[float, float, float]
    """The force held on it besides gravity, newtons."""
    mass: float
    """kg (infinite for a fixed body)."""
    friction: float
    """The friction coefficient of its contacts."""


@dataclass(frozen=True)
class Joint:
    """A joint of the running world."""

    name: str
    """Its name in the scene file."""
    kind: str
    """``fixed``, ``revolute``, ``prismatic`` or ``spherical``."""


@dataclass(frozen=True)
class JointState:
    """Where a joint stands."""

    position: float
    """Its coordinate: rad (a hinge's counted in whole turns from load) or m."""
    velocity: float
    """Its rate, rad/s or m/s."""


def _state(reply: Tuple[Any, ...]) -> BodyState:
    values = {key: value for key, (_, value) in reply[0].items()}
    return BodyState(
        position=tuple(values["position"]),
        orientation=tuple(values["orientation"]),
        velocity=tuple(values["velocity"]),
        spin=tuple(values["spin"]),
        force=tuple(values["force"]),
        mass=values["mass"],
        friction=values["friction"],
    )


def _floats(what: str, values: Sequence[float], n: int) -> List[float]:
    values = [float(v) for v in values]
    if len(values) != n:
        raise ValueError(f"{what} takes {n} numbers, not {len(values)}")
    return values


class Hapticd:
    """The daemon, reached through one bus connection (:func:`connect` makes it); a context
    manager, closing the connection at its end."""

    def __init__(self, connection: DBusConnection) -> None:
        self._bus = _Bus(connection)

    def _manager(self, name: str) -> Any:
        return self._bus.get(MANAGER_PATH, MANAGER, name)[1]

    @property
    def version(self) -> str:
        """The daemon's version."""
        return self._manager("Version")

    @property
    def devices(self) -> List[Device]:
        """The devices it drives, in order."""
        return [Device(self._bus, path) for path in self._manager("Devices")]

    @property
    def scenes(self) -> List[str]:
        """The names of the scenes it can switch to."""
        return list(self._manager("Scenes"))

    @property
    def active_scene(self) -> str:
        """The scene running now."""
        return self._manager("ActiveScene")

    def switch_scene(self, name: str, wait: float = 600.0) -> None:
        """Switch every device to the scene called ``name`` (forces ramp down and up); while
        the daemon says its meshes are being prepared, ask again for up to ``wait`` seconds."""
        self._switch("SwitchScene", "s", lambda: (name,), wait)

    def switch_scene_file(self, path: str, wait: float = 600.0) -> None:
        """Switch every device to the scene file at ``path``, one of the caller's own: it is
        opened here, with the caller's rights, and sent by descriptor (the daemon opens no
        path a caller names); the scene is called by the file's name without ``.yaml``.
        While the daemon says its meshes are being prepared, ask again for up to ``wait``
        seconds."""
        name = os.path.splitext(os.path.basename(path))[0]
        if not name or name.startswith(".") or "." in name:
            raise ValueError(f"{path}: not a scene file name (NAME.yaml)")

        def sent() -> Tuple[Any, ...]:
            # Non-blocking, so that a FIFO given by mistake cannot hang the caller; the
            # daemon refuses anything but a regular file.
            return (os.open(path, os.O_RDONLY | os.O_NONBLOCK | os.O_CLOEXEC), name)

        self._switch("SwitchSceneFile", "hs", sent, wait)

    def _switch(
        self, method: str, signature: str, body: Callable[[], Tuple[Any, ...]], wait: float
    ) -> None:
        """Call ``method`` with ``body()``, again while the daemon says it is preparing."""
        deadline = time.monotonic() + wait
        while True:
            args = body()
            try:
                self._bus.call(MANAGER_PATH, MANAGER, method, signature, args)
                return
            except Error as e:
                if not e.name.endswith(".Preparing") or time.monotonic() > deadline:
                    raise
                time.sleep(0.5)
            finally:
                if signature.startswith("h"):
                    os.close(args[0])

    @property
    def bodies(self) -> List[Body]:
        """The running world's bodies, in the order of their ids (none when its scene cannot
        be changed from outside)."""
        listed = self._bus.get(SCENE_PATH, SCENE, "Bodies")[1]
        return [Body(k, name, fixed) for k, (name, fixed) in enumerate(listed)]

    def _drive(self, method: str, signature: str, *args: Any) -> BodyState:
        return _state(self._bus.call(SCENE_PATH, SCENE, method, signature, args))

    def body(self, body: str) -> BodyState:
        """Where ``body`` (its name, or its id as a string) is and how it moves, now."""
        return self._drive("Body", "s", str(body))

    def set_pose(
        self,
        body: str,
        position: Sequence[float],
        orientation: Sequence[float] = (1.0, 0.0, 0.0, 0.0),
    ) -> BodyState:
        """Put ``body``'s centre of mass at ``position`` (metres) with ``orientation`` (qw, qx,
        qy, qz), keeping its velocities; the forces ramp to zero first and back after."""
        p, q = _floats("position", position, 3), _floats("orientation", orientation, 4)
        return self._drive("SetPose", "sadad", str(body), p, q)

    def set_velocity(
        self, body: str, velocity: Sequence[float], spin: Sequence[float] = (0.0, 0.0, 0.0)
    ) -> BodyState:
        """Set ``body`` moving at ``velocity`` (m/s) and turning at ``spin`` (rad/s)."""
        v, w = _floats("velocity", velocity, 3), _floats("spin", spin, 3)
        return self._drive("SetVelocity", "sadad", str(body), v, w)

    def apply_impulse(
        self, body: str, impulse: Sequence[float], point: Optional[Sequence[float]] = None
    ) -> BodyState:
        """Give ``body`` the momentum ``impulse`` (N·s) at ``point`` (metres; None: its centre
        of mass, so it does not turn)."""
        j = _floats("impulse", impulse, 3)
        at = [] if point is None else _floats("point", point, 3)
        return self._drive("ApplyImpulse", "sadad", str(body), j, at)

    def set_force(self, body: str, force: Sequence[float]) -> BodyState:
        """Push ``body`` with ``force`` (N) at its centre at every step from now on, besides
        gravity; a zero force ends it."""
        return self._drive("SetForce", "sad", str(body), _floats("force", force, 3))

    def set_mass(self, body: str, mass: float) -> BodyState:
        """Make ``body``'s mass ``mass`` kg, its inertia scaled with it."""
        return self._drive("SetMass", "sd", str(body), float(mass))

    def set_friction(self, body: str, friction: float) -> BodyState:
        """Make the friction coefficient of ``body``'s contacts ``friction`` (a contact takes
        the lower of its two bodies')."""
        return self._drive("SetFriction", "sd", str(body), float(friction))

    def set_material(
        self, body: str, young: float, poisson: float, damping: float = 0.0
    ) -> BodyState:
        """Make soft ``body`` of Young's modulus ``young`` (Pa), Poisson's ratio ``poisson``
        and damping ``damping`` (s), its shape and motion kept."""
        return self._drive(
            "SetMaterial", "sddd", str(body), float(young), float(poisson), float(damping)
        )

    def pin(self, body: str, normal: Sequence[float], offset: float) -> BodyState:
        """Hold still the nodes of soft ``body`` that stand where ``normal``·x ≤ ``offset``
        (metres) now, ``normal`` a unit vector."""
        n = _floats("normal", normal, 3)
        return self._drive("Pin", "sadd", str(body), n, float(offset))

    def release(self, body: str, normal: Sequence[float], offset: float) -> BodyState:
        """Let go the held nodes of soft ``body`` that stand where ``normal``·x ≤ ``offset``
        (metres) now."""
        n = _floats("normal", normal, 3)
        return self._drive("Release", "sadd", str(body), n, float(offset))

    @property
    def joints(self) -> List[Joint]:
        """The running world's joints, in order (none when its scene cannot be changed from
        outside)."""
        listed = self._bus.get(SCENE_PATH, SCENE, "Joints")[1]
        return [Joint(name, kind) for name, kind in listed]

    def joint(self, joint: str) -> JointState:
        """Where ``joint`` stands now."""
        return JointState(*self._bus.call(SCENE_PATH, SCENE, "Joint", "s", (joint,)))

    def drive_joint(
        self,
        joint: str,
        *,
        velocity: Optional[float] = None,
        position: Optional[float] = None,
        max_force: float = 1.0,
    ) -> JointState:
        """Drive ``joint``'s coordinate with its motor at the rate ``velocity`` (rad/s or m/s)
        or to ``position`` (rad or m) with at most ``max_force`` (N·m or N, up to 100); with
        neither, stop driving it. Where it stands after."""
        if velocity is not None and position is not None:
            raise ValueError("a motor drives to a velocity or a position, not both")
        motor, target = ("off", 0.0)
        if velocity is not None:
            motor, target = ("velocity", float(velocity))
        elif position is not None:
            motor, target = ("position", float(position))
        args = (joint, motor, target, float(max_force))
        return JointState(*self._bus.call(SCENE_PATH, SCENE, "DriveJoint", "ssdd", args))

    def add_body(self, body: str) -> int:
        """Add ``body``, one entry of a scene file's ``bodies:`` in YAML with a ``name:`` of its
        own, to the running world (built again with it, the other bodies kept where they are
        and as they move); its id."""
        return self._bus.call(SCENE_PATH, SCENE, "AddBody", "s", (body,))[0]

    def remove_body(self, body: str) -> None:
        """Remove ``body`` (its name, or its id) from the running world; the ids after it move
        down by one."""
        self._bus.call(SCENE_PATH, SCENE, "RemoveBody", "s", (str(body),))

    def close(self) -> None:
        """Close the connection."""
        self._bus.connection.close()

    def __enter__(self) -> "Hapticd":
        return self

    def __exit__(self, *_: object) -> None:
        self.close()


def connect(bus: Optional[str] = None) -> Hapticd:
    """The daemon on the system bus, or on the bus at address ``bus`` (``unix:path=…``);
    :class:`NotRunning` when no hapticd is there. Also a context manager, closing the
    connection at its end: ``with hapticd.connect() as daemon: …``."""
    connection = open_dbus_connection(bus or "SYSTEM", enable_fds=True)
    reply = connection.send_and_get_reply(message_bus.NameHasOwner(BUS_NAME))
    if not reply.body[0]:
        connection.close()
        raise NotRunning("system" if bus is None else bus)
    return Hapticd(connection)
