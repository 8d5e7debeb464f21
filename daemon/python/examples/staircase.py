"""A psychophysics staircase on hapticd: walls of varying stiffness are presented in turn, each
answered "stiffer than the reference or not", the stiffness stepped down after "stiffer" and up
after "not" (a one-up one-down staircase, its step halved at each reversal), and every tick of
every trial recorded.

The answer here comes from a stand-in observer who feels the mean force of the last half of
the trial against the reference wall's; put `input()` in `respond` for a person.

Run on the daemon's device while a hand presses the static scene's floor:
    python3 staircase.py [--bus ADDRESS] [--trials 12] [--out ticks.csv]
"""

from __future__ import annotations

import argparse
import csv
import math
from typing import List

import hapticd

REFERENCE = 2000.0  # N/m: the wall every other one is compared with
TRIAL = 0.4  # seconds of the loop's ticks per presentation


def present(device: hapticd.Device, stiffness: float) -> List[hapticd.Sample]:
    """One wall of `stiffness` N/m, felt for TRIAL seconds: every tick of it."""
    device.set("Stiffness", stiffness)
    return list(device.telemetry(seconds=TRIAL))


def felt(samples: List[hapticd.Sample]) -> float:
    """The mean force over the last half of a trial, newtons: what the observer goes by."""
    late = samples[len(samples) // 2 :]
    return sum(math.hypot(*s.force) for s in late) / len(late)


def respond(samples: List[hapticd.Sample], reference: float) -> bool:
    """Whether the wall felt stiffer than the reference."""
    return felt(samples) > reference


def staircase(device: hapticd.Device, trials: int, writer) -> List[float]:
    """Run `trials` presentations from 1.5 times the reference, writing every tick to the
    CSV `writer`; the stiffness of each trial."""
    reference = felt(present(device, REFERENCE))
    stiffness, step, last = 1.5 * REFERENCE, 400.0, None
    presented = []
    for trial in range(trials):
        samples = present(device, stiffness)
        for s in samples:
            writer.writerow([trial, stiffness, s.tick, f"{s.time:.6f}", *s.position, *s.force])
        stiffer = respond(samples, reference)
        presented.append(stiffness)
        if last is not None and stiffer != last:
            step /= 2
        last = stiffer
        stiffness = max(100.0, stiffness - step if stiffer else stiffness + step)
    device.set("Stiffness", REFERENCE)
    return presented


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--bus", help="the daemon's bus address (default: the system bus)")
    parser.add_argument("--trials", type=int, default=12)
    parser.add_argument("--out", default="ticks.csv", help="every tick of every trial")
    args = parser.parse_args()
    daemon = hapticd.connect(args.bus)
    device = daemon.devices[0]
    with open(args.out, "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(["trial", "stiffness", "tick", "time", "x", "y", "z", "fx", "fy", "fz"])
        presented = staircase(device, args.trials, writer)
    print("stiffness presented:", " ".join(f"{k:.0f}" for k in presented))
    print(f"threshold estimate: {sum(presented[-4:]) / 4:.0f} N/m (reference {REFERENCE:.0f})")


if __name__ == "__main__":
    main()
