"""Where ``make test``'s time goes: CPU seconds and wall seconds of every test file, on the suite's own workers.

Run: ``python benchmarks/suite.py`` (the whole suite, as ``make test`` runs it: about 10-13 minutes on 2 cores),
or ``python benchmarks/suite.py tests/browser`` (any pytest arguments: the files or options to run instead).
``CAMSIM_SUITE_KEEP=rows.tsv`` keeps every test's row (node id, CPU s, wall s, CPU by process).

Each test's CPU is that of its worker's processes while the test ran (its setup, call and teardown): the worker,
its servers (``camsim serve`` subprocesses and their upload readers), Playwright's driver and Chromium's processes,
by kind. A thread in each worker (this file, loaded as a pytest plugin with ``-p suite``) reads the CPU of every
process under the worker from ``/proc`` every ``SAMPLE_S`` seconds, so a process that ends during a test (a page's
renderer) is counted up to its last reading: Chromium's processes are not collected by their parents in a way
that adds their CPU to them (``time make test`` and a parent's ``cutime`` miss about 40 % of the suite's CPU). A
server or browser started for a file or a worker is counted in the test that started it. Linux only.

Printed:

1. The run: wall time against the goal (``make test`` under 5 minutes on two quiet cores), the CPU the machine
   spent meanwhile (from ``/proc/stat``, everything on it) and how busy its cores were, the load average before
   and after (a busy machine before the run makes every figure meaningless: run it alone).
2. The tests' CPU by process: the workers themselves, the servers, Chromium's renderers, browser and GPU
   processes, Playwright's driver.
3. Per area (``tests/engine``, ``tests/app``, ``tests/browser``): tests, CPU, the sum of the tests' wall times
   (three workers run at once: the sums add up to about three times the run's wall time), CPU per test.
4. The files that took most CPU, with their share of the suite's CPU.
5. The tests that took most CPU.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
import tempfile
import threading
import time
from collections import Counter
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
#: ``make test``'s goal (s): the whole suite on two quiet cores.
GOAL_S = 300.0
#: ``make test``'s pytest arguments (the Makefile's ``test`` target).
MAKE_TEST_ARGS = ["-q", "-n", "3", "--dist", "loadfile", "--no-loadscope-reorder"]
#: Environment variable naming the file the plugin appends its rows to (one line per test, tab-separated).
OUT_ENV = "CAMSIM_SUITE_CPU_FILE"
_TICK = os.sysconf("SC_CLK_TCK") if hasattr(os, "sysconf") else 100


#: Seconds between two readings of the worker's processes.
SAMPLE_S = 0.5


def _read(pid):
    """``(parent pid, start time, CPU s, command line)`` of process ``pid`` from ``/proc``, or None once gone."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            fields = f.read().rsplit(")", 1)[1].split()
        with open(f"/proc/{pid}/cmdline", "rb") as f:
            cmd = f.read().replace(b"\0", b" ").decode(errors="replace")
    except OSError:
        return None
    return int(fields[1]), fields[19], (int(fields[11]) + int(fields[12])) / _TICK, cmd


def kind(cmd):
    """What a process is, from its command line: ``chromium:renderer``, ``server``, ``worker``, ..."""
    if "chrom" in cmd:
        found = re.search(r"--type=([a-z-]+)", cmd)
        return "chromium:" + (found.group(1) if found else "crashpad" if "crashpad" in cmd else "browser")
    if "playwright" in cmd:
        return "playwright driver"
    if " serve " in cmd:
        return "server"
    if "multiprocessing" in cmd:
        return "server's readers"
    return "other"


class Sampler:
    """The CPU of every process under ``root`` (the worker itself included), read every ``SAMPLE_S`` seconds
    in a thread: ``totals()`` is CPU s by kind so far, ended processes included up to their last reading."""

    def __init__(self, root):
        self.root, self.seen, self.lock = root, {}, threading.Lock()  # (pid, start) -> [kind, cpu]
        self.read()
        threading.Thread(target=self._run, name="suite-cpu-sampler", daemon=True).start()

    def read(self):
        procs = {}
        for name in os.listdir("/proc"):
            if name.isdigit():
                found = _read(name)
                if found is not None:
                    procs[int(name)] = found
        children = {}
        for pid, (ppid, *_rest) in procs.items():
            children.setdefault(ppid, []).append(pid)
        todo = [self.root]
        with self.lock:
            while todo:
                pid = todo.pop()
                if pid in procs:
                    _, start, cpu, cmd = procs[pid]
                    entry = self.seen.setdefault((pid, start), ["worker" if pid == self.root else kind(cmd), 0.0])
                    entry[1] = cpu
                todo += children.get(pid, [])

    def _run(self):
        while True:
            time.sleep(SAMPLE_S)
            self.read()

    def totals(self):
        self.read()
        out = Counter()
        with self.lock:
            for name, cpu in self.seen.values():
                out[name] += cpu
        return out


# --- the pytest plugin (loaded in each worker with ``-p suite``) ---
_sampler = None
_started = {}


def pytest_runtest_setup(item):
    global _sampler
    if _sampler is None:
        _sampler = Sampler(os.getpid())
    _started[item.nodeid] = (_sampler.totals(), time.perf_counter())


def pytest_runtest_logfinish(nodeid, location):
    out = os.environ.get(OUT_ENV)
    if out and _sampler is not None and nodeid in _started:
        before, wall0 = _started.pop(nodeid)
        spent = _sampler.totals()
        spent.subtract(before)
        kinds = ";".join(f"{k}={v:.2f}" for k, v in spent.items() if v > 0.005)
        with open(out, "a") as f:
            f.write(f"{nodeid}\t{sum(spent.values()):.2f}\t{time.perf_counter() - wall0:.2f}\t{kinds}\n")


# --- the runner ---
def _busy_ticks():
    with open("/proc/stat") as f:
        values = [int(x) for x in f.readline().split()[1:]]
    idle = values[3] + values[4]  # idle, iowait
    return sum(values) - idle, sum(values)


def _load():
    with open("/proc/loadavg") as f:
        return " ".join(f.read().split()[:3])


#: A fixed pure-Python loop (20 million additions) and what it took at the fastest seen on the machine these
#: tables come from (s): the host's speed varies by itself (by 1.5-2.7 times in a day), so each run is timed
#: against the loop, run alone before and after it.
LOOP = "import time\nt = time.perf_counter()\ns = 0\nfor i in range(20_000_000):\n    s += i\nprint(time.perf_counter() - t)"
LOOP_FASTEST_S = 1.27


def _loop_s():
    """Seconds the fixed loop (:data:`LOOP`) takes now, in a process of its own."""
    return float(subprocess.run([sys.executable, "-c", LOOP], capture_output=True, text=True, check=True).stdout)


def main(argv):
    with tempfile.NamedTemporaryFile("w", suffix=".tsv", delete=False) as f:
        out = f.name
    # no empty entry: it would put the working directory (the checkout) on every subprocess's path
    path = [str(Path(__file__).resolve().parent)] + [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p]
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(path), **{OUT_ENV: out})
    args = MAKE_TEST_ARGS + (argv or [])
    loop_before = _loop_s()
    load_before, (busy0, all0), t0 = _load(), _busy_ticks(), time.perf_counter()
    code = subprocess.call([sys.executable, "-m", "pytest", "-p", "suite", *args], cwd=ROOT, env=env)
    wall, (busy1, all1), load_after = time.perf_counter() - t0, _busy_ticks(), _load()
    loop_after = _loop_s()
    rows = []
    by_kind = Counter()
    for line in Path(out).read_text().splitlines():
        nodeid, cpu, spent, kinds = (line.split("\t") + [""])[:4]
        rows.append((nodeid, float(cpu), float(spent)))
        for part in filter(None, kinds.split(";")):
            name, value = part.split("=")
            by_kind[name] += float(value)
    keep = os.environ.get("CAMSIM_SUITE_KEEP")
    if keep:  # every test's row (node id, CPU s, wall s, CPU by process), for a closer look
        Path(keep).write_text(Path(out).read_text())
    os.unlink(out)
    if not rows:
        print("no test ran")
        return code or 1
    machine_cpu = (busy1 - busy0) / _TICK
    cores = os.cpu_count() or 1
    print(f"\npytest {' '.join(args)}: exit status {code}")
    print(f"load average before {load_before}, after {load_after}; {cores} cores")
    loop = (loop_before + loop_after) / 2
    print(f"the fixed loop took {loop_before:.2f} s before and {loop_after:.2f} s after ({LOOP_FASTEST_S} s at this "
          f"machine's fastest): the host ran {loop / LOOP_FASTEST_S:.2f} times slower than at its fastest\n")
    print("| run | seconds | ratio to the goal |\n|---|---|---|")
    print(f"| wall time | {wall:.0f} | {wall / GOAL_S:.2f} (goal {GOAL_S:.0f} s) |")
    print(f"| CPU of the machine meanwhile | {machine_cpu:.0f} | cores busy {machine_cpu / wall / cores:.0%} |")
    total = sum(cpu for _, cpu, _ in rows)
    print(f"| CPU of the tests (their workers' processes) | {total:.0f} | share of the machine's "
          f"{total / machine_cpu:.0%} |\n")
    print("| process | CPU s | share |\n|---|---|---|")
    for name, cpu in by_kind.most_common():
        print(f"| {name} | {cpu:.0f} | {cpu / total:.0%} |")
    print()
    areas, area_wall, area_n = Counter(), Counter(), Counter()
    files, file_wall, file_n = Counter(), Counter(), Counter()
    for nodeid, cpu, spent in rows:
        path = nodeid.split("::")[0]
        area = "/".join(path.split("/")[:2]) if path.startswith("tests/") else path
        areas[area] += cpu
        area_wall[area] += spent
        area_n[area] += 1
        files[path] += cpu
        file_wall[path] += spent
        file_n[path] += 1
    print("| area | tests | CPU s | share | tests' wall s | CPU s per test |\n|---|---|---|---|---|---|")
    for area, cpu in areas.most_common():
        print(f"| {area} | {area_n[area]} | {cpu:.0f} | {cpu / total:.0%} | {area_wall[area]:.0f} | "
              f"{cpu / area_n[area]:.2f} |")
    print("\n| file (most CPU first) | tests | CPU s | share | tests' wall s |\n|---|---|---|---|---|")
    for path, cpu in files.most_common(25):
        print(f"| {path} | {file_n[path]} | {cpu:.1f} | {cpu / total:.1%} | {file_wall[path]:.0f} |")
    print("\n| test (most CPU first) | CPU s | wall s |\n|---|---|---|")
    for nodeid, cpu, spent in sorted(rows, key=lambda r: -r[1])[:15]:
        print(f"| {nodeid} | {cpu:.1f} | {spent:.0f} |")
    return code


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
