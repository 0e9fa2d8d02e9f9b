#!/usr/bin/env python3
"""Paired A/B timing of isir binaries on the same command: the way every speed change in
ARCHITECTURE.md is measured.

    python3 tools/ab/ab.py OLD NEW -- render tp4-bunny --spp 64
    python3 tools/ab/ab.py --runs 11 OLD NEW -- render tp1-sphere --spp 256
    python3 tools/ab/ab.py --self-test

Each run starts every binary once, one after the other (the order alternating from run
to run, so a drift of the machine falls on both), with `-o FILE.exr` added to the
command. It prints each binary's median CPU time (user + system, what the process
really used: on a shared host the wall time also counts what other guests took) and
wall time, and each binary's CPU time over the first's, paired run by run: the median
and the range of those ratios. The images of the first run are compared byte for byte
(EXR: every float), since a speed change is meant to leave them exactly as they were.
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def run_once(binary: str, args: list[str], out: Path) -> tuple[float, float]:
    """Run `binary args -o out`; (CPU seconds, wall seconds). Exits on failure. Its
    messages go to a file, not a pipe: a pipe read only after the process ends would
    block a process that writes more than the pipe holds."""
    with tempfile.TemporaryFile() as err:
        start = time.perf_counter()
        proc = subprocess.Popen([binary, *args, "-o", str(out)], stdout=subprocess.DEVNULL, stderr=err)
        _, status, usage = os.wait4(proc.pid, 0)
        wall = time.perf_counter() - start
        proc.returncode = os.waitstatus_to_exitcode(status)
        if proc.returncode != 0:
            err.seek(0)
            message = err.read().decode(errors="replace").strip()
            sys.exit(f"ab: {binary} {' '.join(args)} failed (exit {proc.returncode}):\n{message}")
    return usage.ru_utime + usage.ru_stime, wall


def measure(binaries: list[str], args: list[str], runs: int, work: Path, log=print) -> dict:
    """Time every binary `runs` times, interleaved; the figures and whether the images match."""
    cpu: dict[int, list[float]] = {i: [] for i in range(len(binaries))}
    wall: dict[int, list[float]] = {i: [] for i in range(len(binaries))}
    for r in range(runs):
        order = list(range(len(binaries)))
        if r % 2:
            order.reverse()
        for i in order:
            c, w = run_once(binaries[i], args, work / f"{i}-{r}.exr")
            cpu[i].append(c)
            wall[i].append(w)
        log(f"run {r + 1}/{runs}: " + "  ".join(f"{Path(binaries[i]).name}[{i}] {cpu[i][-1]:.3f} s" for i in range(len(binaries))))
    first = (work / "0-0.exr").read_bytes()
    same = [(work / f"{i}-0.exr").read_bytes() == first for i in range(len(binaries))]
    ratios = {i: sorted(cpu[i][r] / cpu[0][r] for r in range(runs)) for i in range(1, len(binaries))}
    return {"cpu": cpu, "wall": wall, "same": same, "ratios": ratios}


def report(binaries: list[str], fig: dict) -> list[str]:
    lines = []
    for i, b in enumerate(binaries):
        line = f"[{i}] {b}: CPU {statistics.median(fig['cpu'][i]):.3f} s, wall {statistics.median(fig['wall'][i]):.3f} s (medians)"
        if i:
            rs = fig["ratios"][i]
            line += f"; CPU / [0]: {statistics.median(rs):.3f} (paired runs {rs[0]:.3f}-{rs[-1]:.3f})"
            line += "; image the same as [0]'s" if fig["same"][i] else "; IMAGE DIFFERS from [0]'s"
        lines.append(line)
    return lines


FAKE = r'''#!/usr/bin/env python3
import sys
args = sys.argv[1:]
out = args[args.index("-o") + 1]
work = int(args[0])
x = 0
for i in range(work):
    x = (x * 1103515245 + 12345) % 2147483648
open(out, "wb").write(args[1].encode())
'''


def self_test() -> None:
    """The measurement on fake binaries: a twice slower one measures about twice the
    CPU time, and a different image is reported as such."""
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        fake = tmp / "fake"
        fake.write_text(FAKE)
        fake.chmod(0o755)
        # The first argument is the work, the second the "image"; the same command runs for
        # every binary, so the slower binary is a wrapper doubling the work.
        slow = tmp / "slow"
        slow.write_text(f"#!/bin/sh\nw=$1; shift\nexec {fake} $((w * 2)) \"$@\"\n")
        slow.chmod(0o755)
        other = tmp / "other"
        other.write_text(f"#!/bin/sh\nw=$1; shift; shift\nexec {fake} $w different \"$@\"\n")
        other.chmod(0o755)
        fig = measure([str(fake), str(slow), str(other)], ["400000", "image"], 5, tmp, log=lambda _: None)
        ratio = statistics.median(fig["ratios"][1])
        assert 1.4 < ratio < 2.8, f"a binary doing twice the work measured {ratio:.2f} of the time"
        assert fig["same"] == [True, True, False], fig["same"]
        assert any("IMAGE DIFFERS" in l for l in report([str(fake), str(slow), str(other)], fig))
    print("ab self-test: ok")


def main() -> None:
    argv = sys.argv[1:]
    if "--" in argv:
        split = argv.index("--")
        own, command = argv[:split], argv[split + 1 :]
    else:
        own, command = argv, []
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter,
                                usage="ab.py [--runs N] [--keep DIR] BINARY BINARY... -- ISIR-ARGS... | ab.py --self-test")
    p.add_argument("binaries", nargs="*", help="isir binaries, the first being the reference")
    p.add_argument("--runs", type=int, default=9, help="runs of each binary (default: %(default)s)")
    p.add_argument("--keep", help="keep the images in this directory (made if missing)")
    p.add_argument("--self-test", action="store_true", help="check the measurement on fake binaries")
    a = p.parse_args(own)
    if a.self_test:
        self_test()
        return
    if len(a.binaries) < 2 or not command:
        p.error("give two or more binaries, then `--` and the isir command (e.g. -- render tp4-bunny --spp 64)")
    if not 1 <= a.runs <= 1000:
        p.error("--runs must be between 1 and 1000")
    if "-o" in command or "--output" in command:
        p.error("the command must not name an output: ab adds `-o FILE.exr` itself")
    for b in a.binaries:
        if not (shutil.which(b) or (Path(b).is_file() and os.access(b, os.X_OK))):
            p.error(f"{b}: not an executable")
    if a.keep:
        work = Path(a.keep)
        work.mkdir(parents=True, exist_ok=True)
        fig = measure(a.binaries, command, a.runs, work)
    else:
        with tempfile.TemporaryDirectory() as tmp:
            fig = measure(a.binaries, command, a.runs, Path(tmp))
    print("\n".join(report(a.binaries, fig)))


if __name__ == "__main__":
    main()
