"""The CPU time of a command and every process it starts, whoever waits
for them (a multiprocessing forkserver's workers are not waited for, so
/usr/bin/time leaves them out): /proc sampled every PERIOD s, each
process's utime + stime at its last sample, summed; by command name too.

    python bench/cpu_tree.py .venv/bin/fullspeed reproduce --out /tmp/r

Linux only. A process that ends between two samples loses at most PERIOD
of its time.
"""
from __future__ import annotations

import collections
import os
import subprocess
import sys
import time

PERIOD = 0.2   # s between samples
TICK = os.sysconf("SC_CLK_TCK")


def _stat(pid: int):
    """(parent, CPU s, command name) of a process, or None if it has gone."""
    try:
        text = open(f"/proc/{pid}/stat").read()
    except OSError:
        return None
    rest = text[text.rindex(")") + 2:].split()
    return int(rest[1]), (int(rest[11]) + int(rest[12])) / TICK, text[text.index("(") + 1:text.rindex(")")]


def main(argv: list[str]) -> int:
    t0 = time.time()
    root = subprocess.Popen(argv)
    cpu: dict[int, float] = {}
    name: dict[int, str] = {}
    while root.poll() is None:
        table = {pid: s for pid in map(int, filter(str.isdigit, os.listdir("/proc"))) if (s := _stat(pid))}
        tree, grew = {root.pid}, True
        while grew:   # the descendants: whose parent is in the tree
            new = {pid for pid, (parent, _, _) in table.items() if parent in tree} - tree
            tree |= new
            grew = bool(new)
        for pid in tree & table.keys():
            cpu[pid] = max(cpu.get(pid, 0.0), table[pid][1])
            name[pid] = table[pid][2]
        time.sleep(PERIOD)
    by = collections.Counter()
    count = collections.Counter()
    for pid, c in cpu.items():
        by[name[pid]] += c
        count[name[pid]] += 1
    print(f"cpu_tree: wall {time.time() - t0:.1f} s, CPU {sum(cpu.values()):.1f} s over {len(cpu)} processes; "
          + ", ".join(f"{k} {v:.1f} s ({count[k]})" for k, v in by.most_common(8)), file=sys.stderr)
    return root.returncode


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
