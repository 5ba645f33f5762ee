#!/usr/bin/python3
"""The memory estimate's bytes per cell against the memory uniform runs hold.

Usage:
  memory_per_cell.py CAPSFLOW CASES OUT [--tolerance 0.15]

capsflow refuses a uniform grid that cannot fit before it allocates anything
(src/app/memory_estimate.cpp): its estimate is the tree's cell count on every level times
bytes per cell measured once, plus a fixed part. Those bytes go stale as the solver grows
(the 2D table once read 261 B a cell where runs held 382). This check measures them again:
for cases/duct_3d.toml at uniform levels 5 and 6 and cases/cavity_2d.toml at levels 9 and
10, with and without .vtu snapshots, a few steps each, the peak resident memory of the run
(its maximum resident set, from wait4) at the two levels, whose difference over the
difference of the cell counts removes the fixed part, against the same difference of the
estimates capsflow reports (`--max-memory 1k` makes it refuse the run and print its
estimate). Prints a table; exits 1 when a measured slope is off the estimate's by more than
the tolerance (a fraction).
"""
import argparse
import os
import re
import subprocess
import sys
import tomllib

# (case file, levels one apart, settings besides the uniform level, its steps)
RUNS = [
    ("duct_3d.toml", (5, 6), ["adapt.wall_level={level}", "time.t_end=0.25"]),
    ("cavity_2d.toml", (9, 10), ["time.t_end=0.06"]),
]
UNITS = {"B": 1, "KiB": 1024, "MiB": 1024**2, "GiB": 1024**3, "TiB": 1024**4}


def cells(case, level):
    """The tree's cells on levels 0 to `level`, as the estimate counts them."""
    with open(case, "rb") as f:
        c = tomllib.load(f)
    dim = c["dimension"]
    roots = 1
    for r in c["domain"]["roots"][:dim]:
        roots *= r
    return roots * sum(2 ** (dim * l) for l in range(level + 1))


def command(capsflow, case, level, extra, vtu, out):
    args = [capsflow, "run", case, "--out", out, "--force", "--quiet",
            "--set", "adapt.enabled=false", "--set", f"adapt.min_level={level}",
            "--set", f"adapt.max_level={level}", "--set", f"output.vtu={'true' if vtu else 'false'}",
            "--set", "output.checkpoint=false"]
    for s in extra:
        args += ["--set", s.format(level=level)]
    return args


def peak_resident(args, log):
    """The run's maximum resident set in bytes (it must succeed); its stderr in `log`."""
    with open(log, "w") as err:
        p = subprocess.Popen(args, stdout=subprocess.DEVNULL, stderr=err)
        _, status, usage = os.wait4(p.pid, 0)
    p.returncode = os.waitstatus_to_exitcode(status)  # reaped by wait4: Popen must not wait again
    if p.returncode != 0:
        with open(log) as err:
            sys.exit(f"memory_per_cell: {' '.join(args)} exited with {p.returncode}: {err.read().strip()}")
    return usage.ru_maxrss * 1024  # kilobytes on Linux


def estimate(args):
    """The estimate capsflow prints when it refuses the run for --max-memory."""
    r = subprocess.run(args + ["--max-memory", "1k"], capture_output=True, text=True)
    m = re.search(r"memory estimate ([0-9.]+) (B|KiB|MiB|GiB|TiB)", r.stderr)
    if r.returncode != 2 or not m:
        sys.exit(f"memory_per_cell: expected a refusal with the estimate, got status {r.returncode}: {r.stderr.strip()}")
    return float(m.group(1)) * UNITS[m.group(2)]


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("capsflow")
    ap.add_argument("cases", help="the folder of the case files")
    ap.add_argument("out")
    ap.add_argument("--tolerance", type=float, default=0.15)
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    worst = 0.0
    print("case | snapshots | measured B/cell | estimated B/cell | off")
    for name, levels, extra in RUNS:
        case = os.path.join(a.cases, name)
        for vtu in (False, True):
            held, estimated, counts = [], [], []
            for level in levels:
                out = os.path.join(a.out, f"{name}_{level}_{vtu}")
                args = command(a.capsflow, case, level, extra, vtu, out)
                held.append(peak_resident(args, out + ".err"))
                estimated.append(estimate(args))
                counts.append(cells(case, level))
            span = counts[1] - counts[0]
            measured = (held[1] - held[0]) / span
            expected = (estimated[1] - estimated[0]) / span
            off = measured / expected - 1.0
            worst = max(worst, abs(off))
            print(f"{name} | {vtu} | {measured:.0f} | {expected:.0f} | {off:+.1%}")
    if worst > a.tolerance:
        print(f"memory_per_cell: a slope is {worst:.1%} off the estimate's (tolerance {a.tolerance:.0%}): "
              "measure the bytes per cell again (src/app/memory_estimate.cpp)")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
