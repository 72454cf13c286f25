"""bench/cpu_tree.py counts the CPU of every process a command starts,
its grandchildren included."""
import re
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "bench"))
import cpu_tree  # noqa: E402

BURN = ("import time\nt = time.process_time()\nwhile time.process_time() - t < 0.6: pass")


def test_a_grandchilds_cpu_is_counted(capsys):
    # the command starts a child that starts the burner: 0.6 s of CPU two levels down
    child = f"import subprocess, sys; subprocess.run([sys.executable, '-c', {BURN!r}])"
    assert cpu_tree.main([sys.executable, "-c", child]) == 0
    line = capsys.readouterr().err
    cpu = float(re.search(r"CPU ([0-9.]+) s over (\d+) processes", line).group(1))
    assert cpu >= 0.5 and int(re.search(r"over (\d+) processes", line).group(1)) >= 2
