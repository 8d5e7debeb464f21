#!/usr/bin/python3
"""Plug and unplug emulated devices around a running program, step by step.

Run under umockdev-wrapper (the testbed sends uevents through the preloaded libudev):

    umockdev-wrapper /usr/bin/python3 testbed.py DIR STEP... -- PROGRAM [ARGS...]

Steps, in order (files are in DIR):
    add=RECORD          add the devices of a umockdev record (with their "add" uevents)
    ioctl=NODE=SCRIPT   answer the ioctls of device node NODE from an ioctl script
    refuse=NODE         device node NODE can be claimed, but every transfer fails with EIO
                        (umockdev replays scripts one URB at a time across all devices, so
                        a second device that must keep running cannot have a script)
    amplifier=NODE=LOG  device node NODE is an SH4 amplifier board (0x0CEC:0x0205) for any
                        number of clients at once, each open of NODE one client, numbered
                        from 1 in the order they open it; it logs to LOG, one line each:
                            client N open (pid P)
                            client N dac D1 D2 D3 D4 D5 D6 D7 D8   (an OUT transfer on EP
                                0x02: its 8 D/A values; one that is no SH4 command is
                                "client N out HEX")
                            client N claim busy   (interface 0 is another client's: EBUSY,
                                after waiting 0.5 s for that client to close)
                            client N closed       (its node or its process: "closed in an
                                ioctl" when killed inside one; ", K URBs not reaped" when it
                                went with transfers done but not collected)
                        IN transfers on EP 0x86 echo the last D/A values the board got
                        (from any client), counters at 0, rotary switch 3
    guardian=SOCKET     serve the program's guardian as systemd does (hapticd-guardian.socket):
                        systemd-socket-activate listens on SOCKET and starts the program
                        as hapticd-guardian for each connection, in the testbed, outside
                        the program's process tree; the program is told the socket by
                        HAPTICD_GUARDIAN_SOCKET. The guardians' standard error goes to
                        DIR/guardian.log
    cgroup=NAME         start the program in a new control group NAME (cgroup v2), as
                        systemd starts a service in its own
    start               start the program, its standard error read line by line
    wait=TEXT           wait until the program writes a line containing TEXT
    wait-log=LOG=TEXT   wait until LOG has a line containing TEXT
    kill=SIGNAL         send the program SIGNAL (a number or a name: 9, KILL, SIGKILL)
    kill-cgroup         kill every process of the program's control group at once
                        (cgroup.kill: SIGKILL, as systemd's stop timeout does)
    exited              wait until the program has exited; the testbed and its devices
                        stay, for whatever it left running
    unplug=SYSFS        a "remove" uevent, then the device is gone from sysfs and /dev
    run=COMMAND         run COMMAND (split as a shell would, not through one) to its end,
                        in the testbed as the program is, its output appended to
                        DIR/run.log; its exit status is not judged
                        (a call to a daemon that dies answering it fails, as it should)
    sleep=SECONDS       wait that long

The program gets SIGTERM after the last step (or when one fails) unless it has exited. Its
standard error goes to DIR/program.stderr, how it ended to DIR/program.status ("exit N"
or "signal N"), the moment each step ended (seconds since the start) to DIR/moments.json.
The exit status is 1 if a step failed; otherwise 0 after a kill= or exited step (how the
program ended is then the test's to judge), else the program's (128 + N for signal N).
"""

import collections
import errno
import json
import os
import queue
import shlex
import signal
import socket
import struct
import subprocess
import sys
import threading
import time

import gi

gi.require_version("UMockdev", "1.0")
from gi.repository import GLib, UMockdev  # noqa: E402

TIMEOUT = 20.0

# <linux/usbdevice_fs.h>, 64-bit.
USBDEVFS_GETDRIVER = 0x41045508
USBDEVFS_SUBMITURB = 0x8038550A
USBDEVFS_DISCARDURB = 0x550B
USBDEVFS_REAPURB = 0x4008550C
USBDEVFS_REAPURBNDELAY = 0x4008550D
USBDEVFS_CLAIMINTERFACE = 0x8004550F
USBDEVFS_RELEASEINTERFACE = 0x80045510
USBDEVFS_CLEAR_HALT = 0x80045515
USBDEVFS_URB_TYPE_BULK = 3
# struct usbdevfs_urb without isochronous frames: type, endpoint, status, flags, buffer,
# buffer_length, actual_length, start_frame, number_of_packets, error_count, signr,
# usercontext; and the offsets of what a reap hands back.
URB = struct.Struct("<BBxxiIxxxxQiiiiiIQ")
URB_STATUS, URB_BUFFER, URB_ACTUAL_LENGTH = 4, 16, 28

# The SH4 board: a command on EP 0x02 is 01 0E and 8 × int16 D/A values; its reply on EP
# 0x86 is 512 bytes, the D/A values echoed, 8 × u16 counters and the input bits at 48.
SH4_OUT, SH4_IN = 0x02, 0x86
SH4_COMMAND = bytes([0x01, 0x0E])
SH4_REPLY = 512
SH4_ROTARY_SWITCH_3 = 0x0030

# How long a claim of an interface another client holds waits for that client's end: the
# kernel releases a dead process's claims before anyone can see it dead, umockdev only once
# its worker thread has read the end of that client's socket, and this board a poll later.
CLAIM_GRACE_MS = 500
# How often the board looks for clients that have gone: umockdev closes a client's stream
# when its socket ends, but does not notify that (nor emit client-vanished).
WATCH_MS = 10


def process_gone(pid):
    """Whether process `pid` has ended (a zombie has: its files are closed)."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rpartition(")")[2].split()[0] in ("Z", "X")
    except OSError:
        return True


def refuse_transfers(_handler, client):
    """Answer an ioctl of a device that can be claimed but fails every transfer."""
    request = client.get_request()
    if request in (USBDEVFS_CLAIMINTERFACE, USBDEVFS_RELEASEINTERFACE):
        client.complete(0, 0)
    elif request == USBDEVFS_GETDRIVER:
        client.complete(-1, errno.ENODATA)
    else:
        client.complete(-1, errno.EIO)
    return True


class Client:
    """One open of an amplifier's node: its number, its process (None if unknown), its URBs
    done but not yet reaped."""

    def __init__(self, number, pid):
        self.number = number
        self.pid = pid
        # (address in the client, status, actual length, bytes an IN transfer got)
        self.done = collections.deque()


class Amplifier:
    """An emulated SH4 board answering any number of clients, logging every OUT transfer.

    umockdev calls its handlers in the testbed's worker thread, one ioctl at a time for all
    clients, so the board's state needs no lock. The board answers at once: a URB is done
    as soon as it is submitted, and is never still in flight.
    """

    def __init__(self, log, socket_path):
        self.log = log
        # Where umockdev listens for the clients of this node, and the sockets of the
        # connections seen so far (each is told from its peer's pid).
        self.socket_path = os.path.normpath(socket_path)
        self.sockets = set()
        # IoctlClient → Client; holding the Python wrapper keeps it the same one each call.
        self.clients = {}
        self.dac = (0,) * 8
        self.owner = None  # the client that has claimed interface 0
        self.waiting = []  # (Client, IoctlClient) claims waiting for the owner to go away
        self.open = {}  # the clients not yet seen gone
        self.watching = False
        self.unknown = set()
        self.handler = UMockdev.IoctlBase()
        self.handler.connect("client-connected", self.connected)
        self.handler.connect("handle-ioctl", self.handle_ioctl)

    def note(self, client, text):
        # Flushed at once: the test reads the log while the board runs, and after a kill.
        self.log.write(f"client {client.number} {text}\n")
        self.log.flush()

    def connected(self, _handler, ioctl_client):
        client = Client(len(self.clients) + 1, self.new_peer())
        self.clients[ioctl_client] = client
        self.open[ioctl_client] = client
        if not self.watching:
            self.watching = True
            self.after(WATCH_MS, self.watch)
        self.note(client, "open" if client.pid is None else f"open (pid {client.pid})")
        return client

    def new_peer(self):
        """The process at the other end of the connection umockdev has just accepted.

        umockdev does not tell (the IoctlClient hides its socket), but that socket is one
        of this process's, bound to this node's socket path, and the only one not seen yet.
        """
        for fd in os.listdir("/proc/self/fd"):
            try:
                inode = os.readlink(f"/proc/self/fd/{fd}")
                if not inode.startswith("socket:") or inode in self.sockets:
                    continue
                with socket.socket(fileno=os.dup(int(fd))) as connection:
                    if connection.family != socket.AF_UNIX:
                        continue
                    name = connection.getsockname()
                    credentials = connection.getsockopt(
                        socket.SOL_SOCKET, socket.SO_PEERCRED, struct.calcsize("3i")
                    )
            except OSError:
                continue
            if not isinstance(name, str) or os.path.normpath(name) != self.socket_path:
                continue
            self.sockets.add(inode)
            pid = struct.unpack("3i", credentials)[0]
            if pid != os.getpid():  # not the listening socket itself
                return pid
        return None

    def after(self, milliseconds, callback):
        """Call `callback` after `milliseconds`, and again as long as it returns True."""
        timer = GLib.timeout_source_new(milliseconds)
        timer.set_callback(lambda _data: callback())
        # The worker thread's context, where umockdev serves the clients: nothing iterates
        # the default one.
        timer.attach(GLib.MainContext.get_thread_default())

    def watch(self):
        for ioctl_client, client in list(self.open.items()):
            # A client whose process has ended is gone even while its socket lives on:
            # umockdev's preload opens it without SOCK_CLOEXEC, so a child the client
            # started keeps it (unlike the node, the kernel's usbfs file), and a client
            # killed just before umockdev's answer never has its stream closed.
            if not ioctl_client.get_connected() or (
                client.pid is not None and process_gone(client.pid)
            ):
                self.closed(ioctl_client, "closed")
        self.watching = bool(self.open)
        return self.watching

    def closed(self, ioctl_client, how):
        client = self.open.pop(ioctl_client)
        left = len(client.done)
        urbs = "URB" if left == 1 else "URBs"
        self.note(client, f"{how}, {left} {urbs} not reaped" if left else how)
        self.waiting = [w for w in self.waiting if w[0] is not client]
        if self.owner is client:
            # As the kernel on close: the claim goes, to the client that waited longest.
            self.owner = None
            if self.waiting:
                self.owner, waiting = self.waiting.pop(0)
                waiting.complete(0, 0)

    def handle_ioctl(self, _handler, ioctl_client):
        client = self.clients.get(ioctl_client) or self.connected(None, ioctl_client)
        try:
            result = self.answer(client, ioctl_client)
        except GLib.Error as error:
            # The client's memory could not be read or written: it died inside the ioctl
            # (SIGKILL; umockdev's preload blocks every other signal during one). umockdev
            # then never closes its stream, so it would look connected for ever.
            print(f"testbed.py: amplifier client {client.number}: {error.message}",
                  file=sys.stderr)
            if ioctl_client in self.open:
                self.closed(ioctl_client, "closed in an ioctl")
            result = (-1, errno.EIO)
        if result is not None:
            ioctl_client.complete(*result)
        return True

    def answer(self, client, ioctl_client):
        """The result and errno of the client's ioctl, or None when it is to wait."""
        request, arg = ioctl_client.get_request(), ioctl_client.get_arg()
        if request == USBDEVFS_SUBMITURB:
            return self.submit(client, arg)
        if request in (USBDEVFS_REAPURB, USBDEVFS_REAPURBNDELAY):
            return self.reap(client, arg)
        if request in (USBDEVFS_CLAIMINTERFACE, USBDEVFS_RELEASEINTERFACE):
            interface = struct.unpack("<I", bytes(arg.resolve(0, 4).retrieve()))[0]
            if interface != 0:
                return -1, errno.ENOENT
            if request == USBDEVFS_RELEASEINTERFACE:
                if self.owner is not client:
                    return -1, errno.EINVAL
                self.owner = None
                return 0, 0
            if self.owner in (None, client):
                self.owner = client
                return 0, 0
            self.wait_for_claim(client, ioctl_client)
            return None
        if request == USBDEVFS_GETDRIVER:
            return -1, errno.ENODATA
        if request == USBDEVFS_DISCARDURB:
            # Nothing is ever in flight, and the kernel does not discard a URB already
            # done: it stays to be reaped with its own status.
            return -1, errno.EINVAL
        if request == USBDEVFS_CLEAR_HALT:
            return 0, 0
        if request not in self.unknown:
            self.unknown.add(request)
            print(f"testbed.py: amplifier: ioctl {request:#x} unknown, answered EINVAL",
                  file=sys.stderr)
        return -1, errno.EINVAL

    def wait_for_claim(self, client, ioctl_client):
        """Hold the claim until the owner's end is known, or refuse it after the grace."""
        self.waiting.append((client, ioctl_client))

        def refuse():
            if any(w[0] is client for w in self.waiting):
                self.waiting = [w for w in self.waiting if w[0] is not client]
                self.note(client, "claim busy")
                ioctl_client.complete(-1, errno.EBUSY)
            return False

        self.after(CLAIM_GRACE_MS, refuse)

    def submit(self, client, arg):
        # The URB's address in the client, read before resolving swaps in a local copy's.
        (address,) = struct.unpack("<Q", bytes(arg.retrieve()))
        urb = arg.resolve(0, URB.size)
        kind, endpoint, _, _, _, length, *_ = URB.unpack(bytes(urb.retrieve()))
        bulk = kind == USBDEVFS_URB_TYPE_BULK and endpoint in (SH4_OUT, SH4_IN)
        if not bulk or length < 0:
            return -1, errno.EINVAL
        # The kernel claims the interface for a client that submits without claiming it.
        if self.owner not in (None, client):
            self.note(client, "claim busy")
            return -1, errno.EBUSY
        self.owner = client
        if endpoint == SH4_OUT:
            sent = bytes(urb.resolve(URB_BUFFER, length).retrieve()) if length else b""
            if len(sent) >= 18 and sent[:2] == SH4_COMMAND:
                self.dac = struct.unpack_from("<8h", sent, 2)
                self.note(client, "dac " + " ".join(map(str, self.dac)))
            else:
                self.note(client, "out " + sent.hex())
            client.done.append((address, 0, length, b""))
        else:
            reply = bytearray(SH4_REPLY)
            struct.pack_into("<8h", reply, 0, *self.dac)
            struct.pack_into("<H", reply, 48, SH4_ROTARY_SWITCH_3)
            got = min(length, SH4_REPLY)
            # A buffer shorter than the board's packet overflows, as on the wire.
            status = 0 if got == SH4_REPLY else -errno.EOVERFLOW
            client.done.append((address, status, got, bytes(reply[:got])))
        return 0, 0

    def reap(self, client, arg):
        if not client.done:
            # Even REAPURB: it would wait for ever (nothing is in flight) with the client's
            # signals blocked, as umockdev's preload keeps them during an ioctl.
            return -1, errno.EAGAIN
        address, status, got, reply = client.done.popleft()
        # Where the client wants the URB's address: written there, then followed to the URB
        # to hand back its status, length and what an IN transfer got (umockdev writes
        # each block back if changed, the pointers as the client's addresses).
        slot = arg.resolve(0, 8)
        slot.update(0, struct.pack("<Q", address))
        urb = slot.resolve(0, URB.size)
        urb.update(URB_STATUS, struct.pack("<i", status))
        urb.update(URB_ACTUAL_LENGTH, struct.pack("<i", got))
        if reply:
            urb.resolve(URB_BUFFER, len(reply)).update(0, reply)
        return 0, 0


def outside_testbed(script, *args):
    """Run the shell `script` with `args` without umockdev's preload, which would redirect
    its /sys into the testbed's."""
    env = {k: v for k, v in os.environ.items() if k != "LD_PRELOAD"}
    subprocess.run(["sh", "-ec", script, "sh", *args], env=env, check=True, timeout=TIMEOUT)


class ControlGroup:
    """A new control group (cgroup v2), removed once empty."""

    def __init__(self, name):
        with open("/proc/self/mounts") as f:
            roots = [line.split()[1] for line in f if line.split()[2] == "cgroup2"]
        if not roots:
            raise OSError("no cgroup v2 hierarchy is mounted")
        self.path = os.path.join(roots[0], name)
        outside_testbed('mkdir "$1"', self.path)

    def command(self, command, env):
        """`command` started in the group: a shell outside the testbed moves itself in,
        then becomes the command with the testbed's environment."""
        preload = env.get("LD_PRELOAD", "")
        return [
            "env", "-u", "LD_PRELOAD", "sh", "-ec",
            'echo $$ > "$1/cgroup.procs"; shift; LD_PRELOAD="$1"; export LD_PRELOAD; '
            'shift; exec "$@"',
            "sh", self.path, preload, *command,
        ]

    def kill(self):
        outside_testbed('echo 1 > "$1/cgroup.kill"', self.path)

    def remove(self):
        outside_testbed(
            'for _ in $(seq 500); do rmdir "$1" 2>/dev/null && exit 0; sleep 0.02; done; '
            'rmdir "$1"',
            self.path,
        )


class Program:
    """The program under test, its standard error collected as it comes."""

    def __init__(self, command, env, cgroup=None):
        self.process = subprocess.Popen(
            cgroup.command(command, env) if cgroup else command,
            env=env,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
            text=True,
        )
        self.lines = queue.Queue()
        self.log = []
        # A daemon: whatever the program leaves running may keep its standard error open.
        self.reader = threading.Thread(target=self.read, daemon=True)
        self.reader.start()

    def read(self):
        for line in self.process.stderr:
            self.log.append(line)
            self.lines.put(line)

    def wait_for(self, text):
        deadline = time.monotonic() + TIMEOUT
        while time.monotonic() < deadline:
            try:
                if text in self.lines.get(timeout=0.1):
                    return
            except queue.Empty:
                pass
        raise TimeoutError(f"the program never wrote {text!r}")

    def wait_exited(self):
        try:
            self.process.wait(timeout=TIMEOUT)
        except subprocess.TimeoutExpired:
            raise TimeoutError("the program is still running") from None

    def stop(self):
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGTERM)
        status = self.process.wait(timeout=TIMEOUT)
        self.reader.join(timeout=1.0)
        return status


def signal_number(name):
    """The signal called `name`: 9, KILL or SIGKILL."""
    if name.isdigit():
        return int(name)
    try:
        return signal.Signals[name if name.upper().startswith("SIG") else "SIG" + name]
    except KeyError:
        raise ValueError(f"no signal {name!r}") from None


def wait_for_line(path, text):
    """Wait until the file at `path` has a whole line containing `text`."""
    deadline = time.monotonic() + TIMEOUT
    seen, rest = 0, ""
    while time.monotonic() < deadline:
        try:
            with open(path) as f:
                f.seek(seen)
                more = f.read()
        except FileNotFoundError:
            more = ""
        seen += len(more.encode())
        *lines, rest = (rest + more).split("\n")
        if any(text in line for line in lines):
            return
        time.sleep(0.02)
    raise TimeoutError(f"{os.path.basename(path)} never had a line with {text!r}")


def main():
    split = sys.argv.index("--")
    directory, steps, command = sys.argv[1], sys.argv[2:split], sys.argv[split + 1 :]
    path = lambda name: os.path.join(directory, name)  # noqa: E731
    testbed = UMockdev.Testbed.new()
    env = dict(os.environ, UMOCKDEV_DIR=testbed.get_root_dir())
    for name in ("JOURNAL_STREAM", "NOTIFY_SOCKET"):
        env.pop(name, None)
    start = time.monotonic()
    program = None
    cgroup = None
    guardian = None
    moments = []
    handlers = []
    failed = None
    # Once the program is killed or waited for, how it ends is the test's to check.
    ending_expected = any(
        s.partition("=")[0] in ("kill", "kill-cgroup", "exited") for s in steps
    )
    try:
        for step in steps:
            verb, _, argument = step.partition("=")
            if verb in ("wait", "kill", "kill-cgroup", "exited") and program is None:
                raise ValueError(f"{step!r} before start")
            if verb == "add":
                with open(path(argument)) as f:
                    testbed.add_from_string(f.read())
            elif verb == "ioctl":
                node, _, script = argument.partition("=")
                testbed.load_ioctl(node, path(script))
            elif verb == "refuse":
                handler = UMockdev.IoctlBase()
                handler.connect("handle-ioctl", refuse_transfers)
                testbed.attach_ioctl(argument, handler)
                handlers.append(handler)
            elif verb == "amplifier":
                node, _, log = argument.partition("=")
                sockets = os.path.join(testbed.get_root_dir(), "ioctl", node.lstrip("/"))
                amplifier = Amplifier(open(path(log), "w"), sockets)
                testbed.attach_ioctl(node, amplifier.handler)
                handlers.append(amplifier)
            elif verb == "guardian":
                socket_path = path(argument)
                # The program again, under the guardian's name (systemd's unit sets argv[0]).
                as_guardian = path("hapticd-guardian")
                os.symlink(os.path.abspath(command[0]), as_guardian)
                guardian = subprocess.Popen(
                    ["systemd-socket-activate", "--seqpacket", "--accept", "--inetd",
                     "-l", socket_path, "-E", "LD_PRELOAD", "-E", "UMOCKDEV_DIR",
                     as_guardian],
                    env=env,
                    stdout=subprocess.DEVNULL,
                    stderr=open(path("guardian.log"), "w"),
                )
                deadline = time.monotonic() + TIMEOUT
                while not os.path.exists(socket_path):
                    if time.monotonic() > deadline or guardian.poll() is not None:
                        raise OSError("systemd-socket-activate never listened")
                    time.sleep(0.02)
                env["HAPTICD_GUARDIAN_SOCKET"] = socket_path
            elif verb == "cgroup":
                cgroup = ControlGroup(argument)
            elif verb == "start":
                program = Program(command, env, cgroup)
            elif verb == "wait":
                program.wait_for(argument)
            elif verb == "wait-log":
                log, _, text = argument.partition("=")
                wait_for_line(path(log), text)
            elif verb == "kill":
                program.process.send_signal(signal_number(argument))
            elif verb == "kill-cgroup":
                if cgroup is None:
                    raise ValueError("kill-cgroup without a cgroup= step")
                cgroup.kill()
            elif verb == "exited":
                program.wait_exited()
            elif verb == "unplug":
                testbed.uevent(argument, "remove")
                testbed.remove_device(argument)
            elif verb == "run":
                with open(path("run.log"), "a") as log:
                    subprocess.run(
                        shlex.split(argument),
                        env=env,
                        stdout=log,
                        stderr=log,
                        timeout=TIMEOUT,
                    )
            elif verb == "sleep":
                time.sleep(float(argument))
            else:
                raise ValueError(f"unknown step {step!r}")
            moments.append({"step": step, "at": time.monotonic() - start})
    except (
        OSError, ValueError, TimeoutError, subprocess.TimeoutExpired, GLib.Error
    ) as error:
        failed = f"testbed.py: step {len(moments) + 1}: {error}"
    status = program.stop() if program is not None else 1
    if cgroup is not None:
        cgroup.remove()
    if guardian is not None:
        guardian.terminate()
        guardian.wait(timeout=TIMEOUT)
    if program is not None:
        with open(path("program.stderr"), "w") as f:
            f.writelines(list(program.log))
        with open(path("program.status"), "w") as f:
            f.write(f"exit {status}\n" if status >= 0 else f"signal {-status}\n")
    with open(path("moments.json"), "w") as f:
        json.dump(moments, f)
    if failed:
        print(failed, file=sys.stderr)
        sys.exit(1)
    if ending_expected:
        sys.exit(0)
    sys.exit(status if status >= 0 else 128 - status)


if __name__ == "__main__":
    main()
