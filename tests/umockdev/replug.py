#!/usr/bin/python3
"""Unplug an emulated USB amplifier under a running hapticd, then plug it back.

Run under umockdev-wrapper (the testbed sends uevents through the preloaded libudev):

    umockdev-wrapper /usr/bin/python3 replug.py DIR -- HAPTICD [ARGS...]

DIR holds `first.umockdev` (the root hub and the amplifier at /dev/bus/usb/001/002),
`first.ioctl` (its traffic, ending in transfers that fail as an unplugged device's do),
`second.umockdev` and `second.ioctl` (the same amplifier in the same socket after the
re-plug, at a new address, /dev/bus/usb/001/003, as the kernel gives it).

hapticd is started; once it drives the amplifier, the device leaves the bus (a "remove"
uevent, its sysfs and node gone). Once hapticd reports it disconnected and has had time to
look for it, it comes back. Once hapticd reports it reconnected, hapticd gets SIGTERM.
hapticd's standard error goes to DIR/hapticd.stderr, the moments of each step (seconds
since start) to DIR/replug.json; the exit status is hapticd's.
"""

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
from gi.repository import UMockdev  # noqa: E402

SYSFS = "/sys/devices/pci0000:00/0000:00:14.0/usb1/1-2"
TIMEOUT = 20.0


def main():
    directory, hapticd = sys.argv[1], sys.argv[3:]
    path = lambda name: os.path.join(directory, name)  # noqa: E731
    testbed = UMockdev.Testbed.new()
    with open(path("first.umockdev")) as f:
        testbed.add_from_string(f.read())
    testbed.load_ioctl("/dev/bus/usb/001/002", path("first.ioctl"))
    env = dict(os.environ, UMOCKDEV_DIR=testbed.get_root_dir())
    for name in ("JOURNAL_STREAM", "NOTIFY_SOCKET"):
        env.pop(name, None)
    start = time.monotonic()
    daemon = subprocess.Popen(
        hapticd, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True
    )
    lines = queue.Queue()
    log = []

    def read():
        for line in daemon.stderr:
            log.append(line)
            lines.put(line)

    reader = threading.Thread(target=read)
    reader.start()

    def wait_for(text):
        deadline = time.monotonic() + TIMEOUT
        while time.monotonic() < deadline:
            try:
                if text in lines.get(timeout=0.1):
                    return time.monotonic() - start
            except queue.Empty:
                pass
        raise TimeoutError(f"hapticd never said {text!r}")

    moments = {}
    try:
        moments["driving"] = wait_for("on usb:1-2")
        testbed.uevent(SYSFS, "remove")
        testbed.remove_device(SYSFS)
        moments["removed"] = time.monotonic() - start
        moments["disconnected"] = wait_for("device Disconnected")
        # Long enough for hapticd to look for it (every 0.5 s) and find nothing.
        time.sleep(1.2)
        with open(path("second.umockdev")) as f:
            testbed.add_from_string(f.read())
        testbed.load_ioctl("/dev/bus/usb/001/003", path("second.ioctl"))
        moments["plugged"] = time.monotonic() - start
        moments["reconnected"] = wait_for("is back: reconnected")
        time.sleep(0.6)
    finally:
        daemon.send_signal(signal.SIGTERM)
        status = daemon.wait(timeout=TIMEOUT)
        reader.join()
        with open(path("hapticd.stderr"), "w") as f:
            f.writelines(log)
        with open(path("replug.json"), "w") as f:
            json.dump(moments, f)
    sys.exit(status if status >= 0 else 128 - status)


if __name__ == "__main__":
    main()
