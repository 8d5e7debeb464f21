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
    start               start the program, its standard error read line by line
    wait=TEXT           wait until the program writes a line containing TEXT
    unplug=SYSFS        a "remove" uevent, then the device is gone from sysfs and /dev
    sleep=SECONDS       wait that long

The program always gets SIGTERM after the last step (or when one fails). Its standard error
goes to DIR/program.stderr, the moment each step ended (seconds since the start) to
DIR/moments.json; the exit status is the program's (1 if a step failed).
"""

import errno
import json
import os
import queue
import signal
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
USBDEVFS_CLAIMINTERFACE = 0x8004550F
USBDEVFS_RELEASEINTERFACE = 0x80045510


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


class Program:
    """The program under test, its standard error collected as it comes."""

    def __init__(self, command, env):
        self.process = subprocess.Popen(
            command, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True
        )
        self.lines = queue.Queue()
        self.log = []
        self.reader = threading.Thread(target=self.read)
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

    def stop(self):
        self.process.send_signal(signal.SIGTERM)
        status = self.process.wait(timeout=TIMEOUT)
        self.reader.join()
        return status


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
    moments = []
    handlers = []
    failed = None
    try:
        for step in steps:
            verb, _, argument = step.partition("=")
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
            elif verb == "start":
                program = Program(command, env)
            elif verb == "wait":
                program.wait_for(argument)
            elif verb == "unplug":
                testbed.uevent(argument, "remove")
                testbed.remove_device(argument)
            elif verb == "sleep":
                time.sleep(float(argument))
            else:
                raise ValueError(f"unknown step {step!r}")
            moments.append({"step": step, "at": time.monotonic() - start})
    except (OSError, ValueError, TimeoutError, GLib.Error) as error:
        failed = f"testbed.py: step {len(moments) + 1}: {error}"
    status = program.stop() if program is not None else 1
    if program is not None:
        with open(path("program.stderr"), "w") as f:
            f.writelines(program.log)
    with open(path("moments.json"), "w") as f:
        json.dump(moments, f)
    if failed:
        print(failed, file=sys.stderr)
        sys.exit(1)
    sys.exit(status if status >= 0 else 128 - status)

if __name__ == "__main__":
    main()
