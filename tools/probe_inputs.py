#!/usr/bin/env python3
"""Re-runs the probe classes of issue 15 against a built capsflow and counts which inputs
are handled as promised (DESIGN.md, "What the user sees"):

- bad input (case file, --set, --out, a checkpoint that cannot restart this case, a memory
  bomb): exit status 2, exactly one line on stderr, nothing written to --out;
- a blow-up: exit status 3, the output written so far kept;
- SIGINT / SIGTERM mid-run: a checkpoint written and an exit status of its own (not 0, 2
  or 3, and not death by the signal);
- --out onto another run's folder: exit 2 (the folder untouched) unless --force.

Usage: tools/probe_inputs.py [BINARY]   (default build/src/app/capsflow)
Prints one line per probe, then the counts; exit status 0 when every probe is handled, 1
otherwise. Only the standard library; each probe takes well under a few seconds (cavity_2d
with levels 3-4 and a tiny t_end) and runs under a 4 GB address-space limit, so a memory
bomb cannot hurt the machine.
"""
import os
import re
import resource
import shutil
import signal
import struct
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
CAVITY = ROOT / "cases" / "cavity_2d.toml"
DUCT = ROOT / "cases" / "duct_3d.toml"
CAPSULE = ROOT / "cases" / "relaxation_quick.toml"
MEMORY_LIMIT = 4 << 30  # bytes of address space per run
TIMEOUT = 20            # seconds per run: a fast probe still running is a hang

# A few steps of the cavity on a coarse tree.
FAST = ["--quiet", "--set", "adapt.min_level=3", "--set", "adapt.max_level=4", "--set", "time.t_end=0.04",
        "--set", "output.cells_csv=false"]
# One step of a small capsule (642 nodes, P1, coarse tree).
CAPSULE_FAST = ["--quiet", "--set", "capsule[0].nodes=642", "--set", "capsule[0].element_order=1",
                "--set", "adapt.max_level=4", "--set", "adapt.wall_level=3", "--set", "adapt.membrane_band=2",
                "--set", "time.t_end=0.002", "--set", "output.checkpoint=true"]


def limit_memory():
    resource.setrlimit(resource.RLIMIT_AS, (MEMORY_LIMIT, MEMORY_LIMIT))


class Run:
    def __init__(self, returncode, err, timed_out=False):
        self.returncode, self.err, self.timed_out = returncode, err, timed_out


def capsflow(binary, args, cwd, interrupt=None):
    """Runs capsflow; `interrupt` = (signal, seconds) sends the signal after that long."""
    env = dict(os.environ, OMP_NUM_THREADS="1")
    p = subprocess.Popen([str(binary)] + [str(a) for a in args], cwd=cwd, env=env, stdout=subprocess.DEVNULL,
                         stderr=subprocess.PIPE, preexec_fn=limit_memory)
    try:
        if interrupt:
            try:
                p.wait(timeout=interrupt[1])
            except subprocess.TimeoutExpired:
                p.send_signal(interrupt[0])
        _, err = p.communicate(timeout=TIMEOUT)
        return Run(p.returncode, err.decode("utf-8", "replace"))
    except subprocess.TimeoutExpired:
        p.kill()
        _, err = p.communicate()
        return Run(None, err.decode("utf-8", "replace"), timed_out=True)


def snapshot(folder):
    """The files of a folder with their contents, to tell whether a run touched it."""
    folder = Path(folder)
    if not folder.exists():
        return None
    if folder.is_file():
        return folder.read_bytes()
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def describe(r):
    if r.timed_out:
        return f"no exit within {TIMEOUT} s"
    if r.returncode < 0:
        return f"killed by signal {-r.returncode}"
    first = re.sub(r"\x1b\[[0-9;]*m", "", r.err).strip().splitlines()[:1]  # (VTK logs in colour)
    return f"exit {r.returncode}" + (f": {first[0][:160]}" if first else "")


def refused(r, out=None, before=None):
    """'' when the run refused as promised, else what went wrong."""
    if r.timed_out or r.returncode != 2:
        return f"expected exit 2, got {describe(r)}"
    lines = r.err.splitlines()
    if len(lines) != 1 or not r.err.endswith("\n"):
        return f"expected one stderr line, got {len(lines)}: {r.err[:200]!r}"
    if out is not None and snapshot(out) != before:
        return f"exit 2 but {out} was changed"
    return ""


class Prober:
    def __init__(self, binary, work):
        self.binary, self.work = binary, Path(work)
        self.results = []  # (name, problem)
        self.count = 0

    def dir(self, name):
        d = self.work / name
        d.mkdir(parents=True, exist_ok=True)
        return d

    def record(self, name, problem):
        self.results.append((name, problem))
        print(f"  {'ok ' if not problem else 'NOT HANDLED'}  {name}" + (f": {problem}" if problem else ""), flush=True)

    def run(self, args, cwd=None, interrupt=None):
        return capsflow(self.binary, args, cwd or self.work, interrupt)

    # Bad input: exit 2, one line, an existing --out folder (with a marker) untouched.
    def expect_refused(self, name, case, extra, out=None):
        d = self.dir(f"refuse_{len(self.results)}")
        if out is None:
            out = d / "out"
            out.mkdir()
            (out / "marker.txt").write_text("keep")
        before = snapshot(out)
        r = self.run(["run", case, "--out", out] + list(extra), cwd=d)
        self.record(name, refused(r, out, before))

    def finished_run(self, name, extra=(), case=CAVITY):
        """A finished fast run with its checkpoints, in a folder of its own."""
        out = self.dir(name) / "out"
        r = self.run(["run", case, "--out", out] + FAST + ["--set", "output.checkpoint=true"] + list(extra))
        if r.returncode != 0:
            raise RuntimeError(f"the reference run {name} failed: {describe(r)}")
        return out


def write_case(folder, text):
    path = Path(folder) / "case.toml"
    path.write_text(text)
    return path


def patch_double(path, old, new):
    """Replaces the stored bytes of the float64 `old` by those of `new` (the first copy in
    the file: /scalars/time for a value no other dataset holds). False if not found."""
    data = bytearray(Path(path).read_bytes())
    at = data.find(struct.pack("<d", old))
    if at < 0:
        return False
    data[at:at + 8] = struct.pack("<d", new)
    Path(path).write_bytes(bytes(data))
    return True


def probe_case_files(p):
    print("bad case files:")
    base = CAVITY.read_text()
    d = p.dir("cases")
    p.expect_refused("syntax error", write_case(p.dir("c1"), base + "\noops = = 3\n"), FAST)
    p.expect_refused("unknown key", write_case(p.dir("c2"), base + "\n[extra]\nvalue = 1\n"), FAST)
    p.expect_refused("wrong type (Re = \"fast\")", write_case(p.dir("c3"), base.replace("Re = 100.0", 'Re = "fast"')), FAST)
    p.expect_refused("out of range (dt = -1)", write_case(p.dir("c4"), base.replace("dt = 0.02", "dt = -1.0")), FAST)
    p.expect_refused("max_level < min_level", write_case(p.dir("c5"), base.replace("max_level = 7", "max_level = 2")), [])
    p.expect_refused("missing case file", d / "nope.toml", FAST)
    p.expect_refused("a directory as case file", d, FAST)
    p.expect_refused("binary junk as case file", write_case(p.dir("c6"), "\x00\xff\xfe junk ["), FAST)


def probe_set(p):
    print("bad --set:")
    for name, arg in [("no '='", "fluid.Re"), ("unknown key", "fluid.nonsense=1"), ("wrong type", "fluid.Re=fast"),
                      ("negative dt", "time.dt=-1"), ("NaN dt", "time.dt=nan"), ("infinite t_end", "time.t_end=inf"),
                      ("huge capsule index", "capsule[99999999999999999999].radius=1"),
                      ("index into a case without capsules", "capsule[0].radius=1"),
                      ("huge root_size", "domain.root_size=1e300"), ("tiny dt", "time.dt=1e-300"),
                      ("level out of range", "adapt.max_level=99"), ("unicode value", "fluid.Re=\u00e9t\u00e9")]:
        p.expect_refused(f"--set {arg} ({name})", CAVITY, FAST + ["--set", arg])


def probe_out(p):
    print("bad --out:")
    d = p.dir("outs")
    afile = d / "a_file"
    afile.write_text("keep")
    p.expect_refused("--out is a file", CAVITY, FAST, out=afile)
    p.expect_refused("--out below a file", CAVITY, FAST, out=afile / "sub")
    p.expect_refused("--out /proc/x", CAVITY, FAST, out=Path("/proc/capsflow_probe"))
    if os.geteuid() != 0:  # root writes anywhere
        locked = d / "locked"
        locked.mkdir()
        locked.chmod(0o500)
        p.expect_refused("--out in an unwritable folder", CAVITY, FAST, out=locked / "out")
        locked.chmod(0o700)
    else:
        p.expect_refused("--out in an unwritable place (/sys)", CAVITY, FAST, out=Path("/sys/capsflow_probe"))


def probe_memory(p):
    print(f"memory bombs (address space limited to {MEMORY_LIMIT >> 30} GB):")
    p.expect_refused("--adapt off --set adapt.max_level=12", CAVITY, ["--quiet", "--adapt", "off", "--set", "adapt.max_level=12"])
    p.expect_refused("domain.roots=[1000,1000,1000]", DUCT, ["--quiet", "--set", "domain.roots=[1000,1000,1000]"])


def probe_blowup(p):
    print("blow-ups:")
    out = p.dir("blowup") / "out"
    r = p.run(["run", CAVITY, "--out", out, "--quiet", "--set", "adapt.min_level=3", "--set", "adapt.max_level=4",
               "--set", "time.cfl=0", "--set", "time.dt=0.5", "--set", "time.t_end=100"])
    problem = ""
    if r.timed_out or r.returncode != 3:
        problem = f"expected exit 3, got {describe(r)}"
    elif not (out / "diagnostics.csv").exists() or not (out / "fluid_000000.vtu").exists():
        problem = "exit 3 but the output written before is gone"
    p.record("huge dt (time.dt = 0.5, no CFL)", problem)


def probe_restarts(p):
    print("restarts:")
    first = p.finished_run("restart_source")
    checkpoint = sorted(first.glob("checkpoint_*.h5"))[-1]
    longer = FAST + ["--set", "time.t_end=0.08"]

    def damaged(name, change, expect=None):
        d = p.dir(f"restart_{len(p.results)}")
        out = d / "out"
        shutil.copytree(first, out)
        bad = d / "bad.h5"
        data = bytearray(checkpoint.read_bytes())
        change(data, bad)
        if not bad.exists():
            bad.write_bytes(bytes(data))
        before = snapshot(out)
        r = p.run(["run", CAVITY, "--out", out, "--restart", bad] + longer, cwd=d)
        p.record(name, refused(r, out, before))

    def flip(data, _):
        data[len(data) // 2] ^= 0x10

    def truncate(data, bad):
        bad.write_bytes(bytes(data[: len(data) // 2]))

    # The checkpoint's time, exactly: the last row of diagnostics.csv (shortest round-trip digits).
    rows = (first / "diagnostics.csv").read_text().split()
    t_saved = float(rows[-1].split(",")[rows[0].split(",").index("t")])

    def time_to(value):
        def change(data, bad):
            bad.write_bytes(bytes(data))
            if not patch_double(bad, t_saved, value):
                raise RuntimeError(f"the time {t_saved} is not in the checkpoint")
        return change

    damaged("corrupted checkpoint (a bit flipped mid-file)", flip)
    damaged("truncated checkpoint", truncate)
    damaged("checkpoint time = NaN", time_to(float("nan")))
    damaged("checkpoint time = -1e300", time_to(-1e300))
    # t_end of the restart below the checkpoint's time: nothing left to run.
    d = p.dir("restart_past_end")
    out = d / "out"
    shutil.copytree(first, out)
    before = snapshot(out)
    r = p.run(["run", CAVITY, "--out", out, "--restart", checkpoint] + FAST + ["--set", "time.t_end=0.02"], cwd=d)
    p.record("checkpoint at or past t_end", refused(r, out, before))

    # A capsule case's checkpoint restarted in a case without capsules.
    caps = p.dir("capsule") / "out"
    r = p.run(["run", CAPSULE, "--out", caps] + CAPSULE_FAST)
    if r.returncode != 0:
        p.record("capsule checkpoint into a case without capsules", f"the capsule run failed: {describe(r)}")
    else:
        cp = sorted(caps.glob("checkpoint_*.h5"))[-1]
        before = snapshot(caps)
        r = p.run(["run", CAPSULE, "--out", caps, "--restart", cp] + CAPSULE_FAST +
                  ["--set", "capsule=[]", "--set", "time.t_end=0.004"])
        p.record("capsule checkpoint into a case without capsules", refused(r, caps, before))

    # Restart into a new folder: continues there (exit 0, diagnostics written).
    new = p.dir("restart_new") / "out"
    r = p.run(["run", CAVITY, "--out", new, "--restart", checkpoint] + longer)
    problem = "" if r.returncode == 0 and (new / "diagnostics.csv").exists() else f"expected exit 0 and diagnostics, got {describe(r)}"
    p.record("restart into a new folder", problem)


def probe_signals(p):
    print("signals:")
    for sig, name in [(signal.SIGINT, "SIGINT"), (signal.SIGTERM, "SIGTERM")]:
        out = p.dir(f"signal_{name}") / "out"
        r = p.run(["run", CAVITY, "--out", out, "--quiet", "--set", "time.t_end=1000"], interrupt=(sig, 2.0))
        problem = ""
        if r.timed_out:
            problem = f"no exit within {TIMEOUT} s of {name}"
        elif r.returncode < 0:
            problem = f"killed by {name} (no handler: no checkpoint, no status of its own)"
        elif r.returncode in (0, 2, 3):
            problem = f"exit {r.returncode}, not a status of its own"
        elif not list(out.glob("checkpoint_*.h5")):
            problem = f"exit {r.returncode} but no checkpoint in {out}"
        p.record(f"{name} mid-run", problem)


def probe_other_run(p):
    print("output onto another run's folder:")
    out = p.finished_run("other_run")
    before = snapshot(out)
    r = p.run(["run", CAVITY, "--out", out] + FAST)
    p.record("--out onto a finished run's folder", refused(r, out, before))
    r = p.run(["run", CAVITY, "--out", out, "--force"] + FAST)
    p.record("... with --force", "" if r.returncode == 0 else f"expected exit 0, got {describe(r)}")


def main():
    binary = Path(sys.argv[1] if len(sys.argv) > 1 else ROOT / "build" / "src" / "app" / "capsflow").resolve()
    if not binary.is_file():
        sys.exit(f"probe_inputs: no capsflow binary at {binary} (build it, or give its path)")
    start = time.time()
    with tempfile.TemporaryDirectory(prefix="capsflow_probe_") as work:
        p = Prober(binary, work)
        for probe in (probe_case_files, probe_set, probe_out, probe_memory, probe_blowup, probe_restarts,
                      probe_signals, probe_other_run):
            try:
                probe(p)
            except RuntimeError as e:
                p.record(probe.__name__, f"could not run: {e}")
    failed = [(n, why) for n, why in p.results if why]
    print(f"\nprobes run: {len(p.results)}, handled as promised: {len(p.results) - len(failed)}, "
          f"not handled: {len(failed)} ({time.time() - start:.0f} s)")
    for n, why in failed:
        print(f"  - {n}: {why}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
