"""Child processes of the harness (``compare validate``, ``compare stress``): each runs with
its output in a log file, one progress line per stage and a heartbeat line while it runs
(the log's last line when it moved on), its CPU time measured beside its wall time, and a
timeout that kills its process group.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import TextIO


class Progress:
    """Thread-safe progress lines ``[elapsed] benchmark | stage | message``."""

    def __init__(self, stream: TextIO | None = None, interval: float = 10.0) -> None:
        self.start = time.monotonic()
        self.stream = stream if stream is not None else sys.stdout
        self.interval = interval
        self.lock = threading.Lock()
        self.jobs_total = 0
        self.jobs_done = 0

    def finished_job(self) -> str:
        """Counts a finished child job: "(k/N jobs)"."""
        with self.lock:
            self.jobs_done += 1
            return f" ({self.jobs_done}/{self.jobs_total} jobs)" if self.jobs_total else ""

    def elapsed(self) -> float:
        return time.monotonic() - self.start

    def line(self, bench: str, stage: str, message: str) -> None:
        with self.lock:
            self.stream.write(f"[{self.elapsed():7.1f} s] {bench} | {stage} | {message}\n")
            self.stream.flush()


def last_log_line(log: Path) -> str:
    """The last non-empty line of ``log`` (from its last 4 KiB, at most 100 characters),
    our own command echo skipped; "" when there is none or the log cannot be read."""
    try:
        with open(log, "rb") as fh:
            fh.seek(max(0, log.stat().st_size - 4096))
            tail = fh.read().decode(errors="replace")
    except OSError:
        return ""
    parts = [p.strip() for p in tail.replace("\r", "\n").split("\n")
             if p.strip() and not p.startswith("$ ")]  # skip our own command echo
    return parts[-1][:100] if parts else ""


@dataclass
class ChildResult:
    returncode: int
    elapsed: float
    timed_out: bool
    cpu: float | None = None  # user + system seconds of the child and what it waited for


def _wait_child(proc: subprocess.Popen, timeout: float) -> tuple[int, float] | None:
    """Exit code and CPU seconds of ``proc`` once it ends (None while it runs): wait4 gives
    the child's resource use, its own waited-for children included (the OpenFOAM driver's
    solvers), so a job's CPU time shows beside its wall time on a busy machine."""
    deadline = time.monotonic() + timeout
    while True:
        pid, status, usage = os.wait4(proc.pid, os.WNOHANG)
        if pid == proc.pid:
            proc.returncode = os.waitstatus_to_exitcode(status)
            return proc.returncode, usage.ru_utime + usage.ru_stime
        if time.monotonic() >= deadline:
            return None
        time.sleep(0.05)


def run_child(cmd: list[str], log: Path, progress: Progress, bench: str, stage: str,
              timeout: float, cwd: Path, env: dict[str, str] | None = None) -> ChildResult:
    """Run ``cmd`` with output to ``log``; heartbeat lines while it runs; kill on timeout."""
    log.parent.mkdir(parents=True, exist_ok=True)
    t0 = time.monotonic()
    with open(log, "wb") as fh:
        fh.write(("$ " + " ".join(cmd) + "\n").encode())
        fh.flush()
        try:
            proc = subprocess.Popen(cmd, stdout=fh, stderr=subprocess.STDOUT, cwd=cwd, env=env,
                                    start_new_session=True)
        except OSError as exc:
            fh.write(f"cannot start: {exc}\n".encode())
            return ChildResult(127, 0.0, False)
        next_beat = t0 + progress.interval
        shown = ""
        quiet_beats = 0
        while True:
            ended = _wait_child(proc, 0.2)
            if ended is not None:
                rc, cpu = ended
                break
            now = time.monotonic()
            if now - t0 > timeout:
                os.killpg(proc.pid, signal.SIGKILL)  # our own child's process group
                proc.wait()
                return ChildResult(-9, now - t0, True)
            if now >= next_beat:
                # a line when the child's log moved on, else every 6 intervals
                last = last_log_line(log)
                if last != shown or quiet_beats >= 5:
                    progress.line(bench, stage, f"running {now - t0:.0f} s"
                                  + (f": {last}" if last else ""))
                    shown, quiet_beats = last, 0
                else:
                    quiet_beats += 1
                next_beat = now + progress.interval
    return ChildResult(rc, time.monotonic() - t0, False, cpu)
