"""A client of hapticd, the SPIDAR haptics daemon, over D-Bus.

``hapticd.connect()`` reaches the daemon on the system bus (or at a bus address); its
``devices`` read and change their parameters, calibrate, and hand out every tick of their
haptic loop (``Device.telemetry``); ``scenes`` and ``switch_scene`` choose the world. Every
error the daemon returns is raised as :class:`Error` carrying its D-Bus error name.
"""

from __future__ import annotations

import os
import time
from typing import Any, Iterator, List, Optional

from jeepney import DBusAddress, HeaderFields, MessageType, Properties, new_method_call
from jeepney.io.blocking import DBusConnection, open_dbus_connection

from .telemetry import Ring, Sample

__all__ = ["connect", "Hapticd", "Device", "Error", "Sample"]

BUS_NAME = "org.hapticd.Hapticd1"
MANAGER_PATH = "/org/hapticd/Hapticd1"
MANAGER = "org.hapticd.Hapticd1.Manager"
DEVICE = "org.hapticd.Hapticd1.Device"


class Error(Exception):
    """An error the daemon (or the bus) returned: ``name`` is its D-Bus error name, such as
    ``org.hapticd.Hapticd1.Error.OutOfRange``, and the message says why."""

    def __init__(self, name: str, message: str) -> None:
        super().__init__(f"{name}: {message}")
        self.name = name
        self.message = message


class _Bus:
    """One connection and the calls made on it."""

    def __init__(self, connection: DBusConnection) -> None:
        self.connection = connection

    def send(self, message) -> tuple:
        """Send ``message`` and return its reply's body, raising :class:`Error` for an error."""
        reply = self.connection.send_and_get_reply(message)
        if reply.header.message_type == MessageType.error:
            name = reply.header.fields.get(HeaderFields.error_name, "error")
            raise Error(name, str(reply.body[0]) if reply.body else "")
        return reply.body

    def call(self, path: str, interface: str, method: str, signature: str = "", body: tuple = ()):
        address = DBusAddress(path, bus_name=BUS_NAME, interface=interface)
        return self.send(new_method_call(address, method, signature, body))

    def get(self, path: str, interface: str, name: str) -> Any:
        """Property ``name`` as (signature, value)."""
        address = DBusAddress(path, bus_name=BUS_NAME, interface=interface)
        return self.send(Properties(address).get(name))[0]

    def set(self, path: str, interface: str, name: str, signature: str, value: Any) -> None:
        address = DBusAddress(path, bus_name=BUS_NAME, interface=interface)
        self.send(Properties(address).set(name, signature, value))


class Device:
    """One haptic device of the daemon."""

    def __init__(self, bus: _Bus, path: str) -> None:
        self._bus = bus
        self.path = path
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

    def open_telemetry(self) -> Ring:
        """The device's telemetry ring, mapped read-only, its cursor at the next tick."""
        (fd,) = self._bus.call(self.path, DEVICE, "OpenTelemetry", "a{sv}", ({},))
        raw = fd.to_raw_fd()
        try:
            return Ring(raw)
        finally:
            os.close(raw)

    def telemetry(self, seconds: float) -> Iterator[Sample]:
        """Every tick of the haptic loop from now for ``seconds`` (of the loop's time), as
        it is written: samples with ``tick``, ``time``, ``position``, ``force`` and the rest
        (see :class:`Sample`). Ticks read too late are skipped; ``Ring.missed`` counts them."""
        ring = self.open_telemetry()
        try:
            yield from ring.follow(seconds)
        finally:
            ring.close()


class Hapticd:
    """The daemon, reached through one bus connection."""

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
        deadline = time.monotonic() + wait
        while True:
            try:
                self._bus.call(MANAGER_PATH, MANAGER, "SwitchScene", "s", (name,))
                return
            except Error as e:
                if not e.name.endswith(".Preparing") or time.monotonic() > deadline:
                    raise
                time.sleep(0.5)

    def close(self) -> None:
        """Close the connection."""
        self._bus.connection.close()


def connect(bus: Optional[str] = None) -> Hapticd:
    """The daemon on the system bus, or on the bus at address ``bus`` (``unix:path=…``)."""
    connection = open_dbus_connection(bus or "SYSTEM", enable_fds=True)
    return Hapticd(connection)
