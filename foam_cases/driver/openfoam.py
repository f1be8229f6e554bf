"""Running OpenFOAM tools in a case folder: environment, logs, failures."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import time
from pathlib import Path

BASHRC = Path("/usr/share/openfoam/etc/bashrc")


class FoamError(RuntimeError):
    """An OpenFOAM tool failed; carries the tail of its log."""

    def __init__(self, message: str, log: Path | None = None, tail_lines: int = 40):
        self.log = log
        self.tail = log_tail(log, tail_lines) if log else ""
        super().__init__(message)


def log_tail(log: Path | None, n: int = 40) -> str:
    if log is None or not log.exists():
        return ""
    lines = log.read_text(errors="replace").splitlines()
    return "\n".join(lines[-n:])


_ENV: dict[str, str] | None = None


def foam_env() -> dict[str, str]:
    """The environment after sourcing the OpenFOAM bashrc.

    Debian's bashrc returns non-zero and complains about missing helper scripts;
    the binaries live in /usr/bin anyway, so its exit status is ignored.
    """
    global _ENV
    if _ENV is None:
        env = dict(os.environ)
        if BASHRC.exists():
            out = subprocess.run(
                ["bash", "-c", f"source {BASHRC} >/dev/null 2>&1; env -0"],
                capture_output=True, check=False,
            ).stdout.decode(errors="replace")
            for item in out.split("\0"):
                if "=" in item:
                    k, v = item.split("=", 1)
                    env[k] = v
        # Trap floating-point exceptions so a diverging run stops with an error.
        env["FOAM_SIGFPE"] = "true"
        # OpenMPI refuses to run as root in containers unless told otherwise.
        env.setdefault("OMPI_ALLOW_RUN_AS_ROOT", "1")
        env.setdefault("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1")
        _ENV = env
    return _ENV


def openfoam_available() -> tuple[bool, str]:
    if not BASHRC.exists():
        return False, f"OpenFOAM not installed ({BASHRC} missing)"
    if shutil.which("interFoam", path=foam_env().get("PATH")) is None:
        return False, "OpenFOAM bashrc found but interFoam is not on PATH"
    return True, ""


def openfoam_version() -> str:
    v = foam_env().get("WM_PROJECT_VERSION")
    if v:
        return v
    return "unknown"


def run_tool(case: Path, args: list[str], log_name: str, np_: int = 1) -> float:
    """Run one OpenFOAM tool in `case`, log to `case/log.<log_name>`.

    Returns the wall time in seconds; raises FoamError on a non-zero exit
    or a FOAM FATAL message.
    """
    cmd = list(args)
    if np_ > 1:
        cmd = ["mpirun", "--oversubscribe", "-np", str(np_)] + cmd + ["-parallel"]
    log = case / f"log.{log_name}"
    t0 = time.perf_counter()
    with open(log, "w") as fh:
        env = dict(foam_env(), PWD=str(case))
        proc = subprocess.run(cmd, cwd=case, env=env, stdout=fh,
                              stderr=subprocess.STDOUT, check=False)
    wall = time.perf_counter() - t0
    text = log.read_text(errors="replace")
    if proc.returncode != 0:
        raise FoamError(f"{' '.join(args)} exited with code {proc.returncode}", log)
    if "FOAM FATAL" in text:
        raise FoamError(f"{' '.join(args)} reported FOAM FATAL ERROR", log)
    return wall


def set_entry(case: Path, file: str, entry: str, value: str) -> None:
    """Change one dictionary entry with foamDictionary (like `--set`)."""
    target = case / file
    if not target.exists():
        raise FoamError(f"--set: no file {file} in the case")
    proc = subprocess.run(
        ["foamDictionary", str(target), "-entry", entry, "-set", value],
        cwd=case, env=foam_env(), capture_output=True, text=True, check=False,
    )
    if proc.returncode != 0:
        raise FoamError(f"--set {file}:{entry}={value} failed: "
                        f"{(proc.stdout + proc.stderr).strip()[-500:]}")


# Transient solvers print "Time = t", solidDisplacementFoam "Iteration: n".
_TIME_RE = re.compile(r"^(?:Time =|Iteration:) ([0-9.eE+-]+)\s*$", re.M)


def solver_steps(log: Path) -> list[float]:
    """Simulated times of all steps printed in a solver log."""
    return [float(m.group(1)) for m in _TIME_RE.finditer(log.read_text(errors="replace"))]


def log_reached_end(log: Path) -> bool:
    text = log.read_text(errors="replace")
    return bool(re.search(r"^End\s*$", text, re.M))


_CO_RE = re.compile(r"^Courant Number mean: \S+ max: (\S+)", re.M)


def max_courant(log: Path) -> float:
    """Largest Courant number reported in a transient solver log (0 if none)."""
    vals = [float(v) for v in _CO_RE.findall(log.read_text(errors="replace"))]
    return max(vals, default=0.0)
