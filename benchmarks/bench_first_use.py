"""First use in a fresh environment (issue 31 item 2): what a new user waits for.

A new virtual environment (the running Python's ``venv``, in a temporary folder) is set up by the
README's first command (its Quickstart's first line up to ``&&``, run from this checkout), then
in new processes, each from a neutral folder: the README's first Python example (its first
``python`` block) twice, cold (no compiled kernels cached yet) and cached, and ``flexmb demo
--quick`` twice, its kernels' cache emptied before the cold run. Wall clock and CPU time (user +
system of the child process) with the host's load; whether the compiled kernels ran
(``flexmb.jit.enabled``) and which sparse solver is installed. numba caches beside the installed
package here (the venv is writable); a read-only install caches in the user's cache folder
(`flexmb.jit`). Writes the "first-use" section of BENCHMARKS.md.
Run: python benchmarks/bench_first_use.py [--quick] (--quick: no cached demo run)
"""

from __future__ import annotations

import os
import re
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _report import ROOT, machine, run  # noqa: E402


def readme_parts() -> tuple[str, str]:
    """The README's first command (before ``&&``) and its first Python example."""
    text = (ROOT / "README.md").read_text()
    command = re.search(r"```bash\n(.*?)\n", text).group(1).split("&&")[0].strip()
    example = re.search(r"```python\n(.*?)```", text, re.S).group(1)
    return command, example


def timed(args, cwd, env=None) -> tuple[float, float, str]:
    """(wall [s], CPU of the child [s], stdout) of a command."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t = time.perf_counter()
    out = subprocess.run(args, cwd=cwd, env=env, capture_output=True, text=True, check=True)
    wall = time.perf_counter() - t
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime), out.stdout


def main(quick: bool = False) -> str:
    command, example = readme_parts()
    lines = ["## First use in a fresh environment (issue 31 item 2)", "", f"{machine()}.", ""]
    with tempfile.TemporaryDirectory() as tmp:
        venv = Path(tmp) / "venv"
        subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True)
        py = str(venv / ("Scripts" if os.name == "nt" else "bin") / "python")
        env = {k: v for k, v in os.environ.items() if k not in ("NUMBA_CACHE_DIR", "PYTHONPATH", "FLEXMB_KERNELS",
                                                                  "VIRTUAL_ENV")}
        env["PATH"] = str(Path(py).parent) + os.pathsep + env.get("PATH", "")
        args = command.split()
        args[0] = py  # "python -m pip install ..." with the new environment's Python
        t = time.perf_counter()
        subprocess.run([a.strip('"') for a in args], cwd=ROOT, env=env, check=True, capture_output=True)
        install = time.perf_counter() - t
        script = Path(tmp) / "first_example.py"
        script.write_text("import time\nt0 = time.perf_counter()\n" + example +
                          "\nimport flexmb.jit, flexmb.linear\n"
                          "print('KERNELS', flexmb.jit.enabled(), flexmb.linear.available()['qdldl'], "
                          "round(time.perf_counter() - t0, 3))\n")
        work = Path(tmp) / "work"
        work.mkdir()
        rows = []
        for label in ("cold", "cached"):
            wall, cpu, out = timed([py, str(script)], work, env)
            kern = out.split("KERNELS")[-1].split()
            rows.append((f"README's first example ({label})", wall, cpu, kern[0] == "True", kern[1] == "True"))
        site = subprocess.run([py, "-c", "import flexmb, os; print(os.path.dirname(flexmb.__file__))"],
                              env=env, cwd=work, capture_output=True, text=True, check=True).stdout.strip()
        for f in Path(site).rglob("*.nb[ic]"):
            f.unlink()  # the demo's cold run compiles every kernel it uses
        for label in ("cold",) if quick else ("cold", "cached"):
            wall, cpu, _ = timed([str(Path(py).parent / "flexmb"), "demo", "--quick", "--out", str(work / "figures")],
                                 work, env)
            rows.append((f"`flexmb demo --quick` ({label})", wall, cpu, True, True))
        shutil.rmtree(work, ignore_errors=True)
    lines += [f"The README's first command, `{command}`, from this checkout: {install:.0f} s (downloads included). "
              "Then, in new processes of that environment (compilation and `import flexmb` included):", "",
              "| run | wall [s] | CPU [s] | compiled kernels | qdldl |", "|---|---:|---:|---|---|"]
    for name, wall, cpu, kern, ldl in rows:
        lines.append(f"| {name} | {wall:.1f} | {cpu:.1f} | {'yes' if kern else 'NO'} | {'yes' if ldl else 'NO'} |")
    lines += ["", f"Load average {os.getloadavg()[0]:.1f} at the end: on a busy host the wall clock includes the "
              "time slices other work takes; the CPU time is the work done (one thread)."]
    return "\n".join(lines)


if __name__ == "__main__":
    run("first-use", main, __doc__, "no cached demo run")
