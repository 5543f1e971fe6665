#!/usr/bin/env python3
"""runs/soak: msim under load. A simulation of a tet box of about 10^6 springs (symplectic Euler, or
with --method pd implicit Euler by PD, 10 iterations per step) sized to run MINUTES (default 10), with a checkpoint every 100 steps and a frame every
FRAMES steps, run twice at once (one rank each unless --ranks): once uninterrupted, once killed
with SIGKILL at two random moments and restarted each time from its last checkpoint. Reports:
- memory over time (resident set size summed over the run's ranks, sampled every 2 s) and its
  growth between the first and the last fifth of the stepping;
- whether the interrupted run ended in the same state (its final checkpoint byte for byte), with
  the same frames (byte for byte), the same series.pvd and the same monitor rows (wall time
  aside), and left no .tmp file.
Writes soak.csv (one row per run), memory.csv and memory.png here.
Usage: runs/soak/soak.py [--minutes 10] [--ranks 1] [--box 52] [--method explicit|pd] [--seed S] [--serial]"""
import argparse
import csv
import filecmp
import os
import random
import shutil
import subprocess
import sys
import threading
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(os.path.dirname(HERE), "tools"))
from msimrun import ENV, MSIM, ROOT  # noqa: E402
sys.path.insert(0, os.path.join(ROOT, "tests"))
from msimtest import kill_all  # noqa: E402  (SIGKILL to msim, or to mpirun and its ranks at once)

WORK = "/tmp/msim_soak"


def scene(box, method):
    box = f"-msim_scene box -msim_box_n {box},{box},{box} -msim_fix_plane z_max "
    if method == "pd":
        return (box + "-msim_integrator implicit_euler -msim_dt 0.01 -snes_type pd -snes_max_it 10 -snes_pd_fixed").split()
    return (box + "-msim_integrator symplectic_euler -msim_dt 1e-6 -msim_spectrum_check 0").split()


def command(ranks, args):
    return ([MSIM] if ranks == 1 else ["mpirun", "-n", str(ranks), MSIM]) + args


def rss_mb(pid):
    """resident set size of pid and its descendants (mpirun's ranks), MB"""
    total, todo = 0, [pid]
    while todo:
        p = todo.pop()
        try:
            with open(f"/proc/{p}/status") as f:
                for line in f:
                    if line.startswith("VmRSS:"):
                        total += int(line.split()[1])
            with open(f"/proc/{p}/task/{p}/children") as f:
                todo += [int(c) for c in f.read().split()]
        except (FileNotFoundError, ProcessLookupError):
            pass
    return total / 1024.0


class Run:
    """one run of the soak: its directory, its processes one after another, its memory samples"""

    def __init__(self, name, ranks, args, steps):
        self.name, self.ranks, self.steps = name, ranks, steps
        self.dir = os.path.join(WORK, name)
        shutil.rmtree(self.dir, ignore_errors=True)
        os.makedirs(self.dir)
        self.args = args + ["-msim_steps", str(steps), "-msim_checkpoint", "state.ck", "-msim_checkpoint_every", "100",
                            "-msim_monitor_csv", "monitor.csv", "-msim_output", "out"]
        self.samples, self.kills, self.t0 = [], [], time.time()

    def start(self, restart):
        args = self.args + (["-msim_restart", "state.ck"] if restart else [])
        self.log = open(os.path.join(self.dir, "stderr.txt"), "a")
        self.p = subprocess.Popen(command(self.ranks, args), cwd=self.dir, env=ENV, stdout=subprocess.DEVNULL, stderr=self.log)

    def sample_until_done(self, kill_at=None):
        """samples memory every 2 s; kills the run at wall time kill_at (from the soak's start)"""
        while self.p.poll() is None:
            now = time.time() - self.t0
            if kill_at is not None and now >= kill_at and os.path.exists(os.path.join(self.dir, "state.ck")):
                rows = self.rows()
                kill_all(self.p)
                self.kills.append((round(now, 1), rows))
                self.samples.append((round(now, 1), 0.0, rows))
                return False
            self.samples.append((round(now, 1), rss_mb(self.p.pid), self.rows()))
            time.sleep(2)
        return self.p.returncode == 0

    def rows(self):
        try:
            with open(os.path.join(self.dir, "monitor.csv")) as f:
                return max(sum(1 for _ in f) - 1, 0)
        except FileNotFoundError:
            return 0


def calibrate(ranks, args, steps):
    """wall seconds per step as the soak runs them (a monitor row every step, its energy computed
    each step): the difference between a run of 1 + steps steps and one of 1 step, with both runs
    of the soak at once (two ranks' worth of memory traffic) when together"""
    def wall(n):
        t = time.time()
        subprocess.run(command(ranks, args + ["-msim_steps", str(n), "-msim_monitor_csv", "/tmp/msim_soak_calibrate.csv"]),
                       env=ENV, cwd=ROOT, check=True, capture_output=True)
        return time.time() - t
    return (wall(1 + steps) - wall(1)) / steps


def growth(samples):
    """MB between the median of the second fifth and of the last fifth of the samples taken while
    stepping (the first fifth holds setup)"""
    live = [s[1] for s in samples if s[1] > 0]
    if len(live) < 10:
        return 0.0, 0.0
    k = len(live) // 5
    early, late = sorted(live[k:2 * k]), sorted(live[-k:])
    return early[len(early) // 2], late[len(late) // 2]


def same_outputs(a, b):
    """what differs between two runs' outputs: final checkpoint, frames, series.pvd, monitor rows"""
    diffs = []
    if not filecmp.cmp(os.path.join(a, "state.ck"), os.path.join(b, "state.ck"), shallow=False):
        diffs.append("final checkpoint differs")
    fa, fb = sorted(os.listdir(os.path.join(a, "out"))), sorted(os.listdir(os.path.join(b, "out")))
    if fa != fb:
        diffs.append(f"frame files differ: {sorted(set(fa) ^ set(fb))[:5]}")
    else:
        bad = [f for f in fa if not filecmp.cmp(os.path.join(a, "out", f), os.path.join(b, "out", f), shallow=False)]
        if bad:
            diffs.append(f"{len(bad)} frame files differ in content, e.g. {bad[0]}")
    rows = []
    for d in (a, b):
        with open(os.path.join(d, "monitor.csv")) as f:
            rows.append([{k: v for k, v in r.items() if k != "wall_s"} for r in csv.DictReader(f)])
    if rows[0] != rows[1]:
        diffs.append(f"monitor rows differ ({len(rows[0])} and {len(rows[1])} rows)")
    for d in (a, b):
        for root, _, files in os.walk(d):
            diffs += [f"{os.path.join(root, f)} left behind" for f in files if f.endswith(".tmp")]
    return diffs


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--minutes", type=float, default=10.0)
    ap.add_argument("--ranks", type=int, default=1)
    ap.add_argument("--box", type=int, default=52)
    ap.add_argument("--method", choices=["explicit", "pd"], default="explicit")
    ap.add_argument("--seed", type=int, default=int(time.time()))
    ap.add_argument("--serial", action="store_true", help="the two runs one after the other (on a machine with fewer than 2 x ranks cores)")
    a = ap.parse_args()
    rng = random.Random(a.seed)
    args = scene(a.box, a.method)
    per_step = calibrate(a.ranks, args, 6 if a.method == "pd" else 1000)
    if not a.serial:
        per_step *= 1.15  # two runs at once share the memory bandwidth: 1.15x measured here (box 52)
    steps = max(300, int(a.minutes * 60 / per_step) // 100 * 100 + 50)  # ends between checkpoints: the final one is written at the end
    frames = max(10, steps // 20)
    args += ["-msim_output_every", str(frames)]
    out = subprocess.run([MSIM] + args + ["-msim_steps", "1", "-msim_dt", "1e-9", "-msim_scene_view"], capture_output=True, text=True, env=ENV).stdout
    springs = next((line.split()[line.split().index("springs") - 1] for line in out.splitlines() if " springs" in line), "?")
    print(f"soak: box {a.box}^3 ({springs} springs), {a.method}, {a.ranks} rank(s), {per_step * 1e3:.0f} ms per step -> {steps} steps "
          f"(about {steps * per_step / 60:.1f} minutes), checkpoint every 100, frame every {frames}; seed {a.seed}", flush=True)

    ref, cut = Run("uninterrupted", a.ranks, args, steps), Run("killed", a.ranks, args, steps)
    expected = steps * per_step
    kill_times = sorted(rng.uniform(0.15, 0.45) * expected for _ in range(1)) + [rng.uniform(0.55, 0.8) * expected]

    def uninterrupted():
        ref.start(False)
        ref.ok = ref.sample_until_done()

    def killed():
        cut.start(False)
        ok = False
        for i, at in enumerate(kill_times + [None]):
            ok = cut.sample_until_done(at)
            if at is None:
                break
            print(f"soak: killed at {cut.kills[-1][0]:.0f} s after {cut.kills[-1][1]} steps; restarting from its checkpoint", flush=True)
            cut.start(True)
        cut.ok = ok

    if a.serial:
        uninterrupted()
        cut.t0 = time.time()
        killed()
    else:
        th = threading.Thread(target=killed)
        th.start()
        uninterrupted()
        th.join()
    diffs = same_outputs(ref.dir, cut.dir) if ref.ok and cut.ok else ["a run failed: see " + WORK + "/*/stderr.txt"]
    rows = []
    for r in (ref, cut):
        early, late = growth(r.samples)
        rows.append(dict(run=r.name, springs=springs, method=a.method, ranks=a.ranks, steps=steps, wall_s=round(r.samples[-1][0], 1) if r.samples else 0,
                         kills=len(r.kills), peak_rss_mb=round(max(s[1] for s in r.samples), 1), rss_early_mb=round(early, 1), rss_late_mb=round(late, 1),
                         growth_mb=round(late - early, 1), completed=r.ok, same_as_uninterrupted="" if r is ref else not diffs, seed=a.seed))
        print(f"soak: {r.name}: {rows[-1]['wall_s']:.0f} s, {len(r.kills)} kills, peak RSS {rows[-1]['peak_rss_mb']} MB, "
              f"stepping RSS {early:.1f} -> {late:.1f} MB ({late - early:+.1f})", flush=True)
    print("soak: the killed and restarted run ends " + ("exactly as the uninterrupted one (final state, frames, series.pvd, monitor rows)"
                                                        if not diffs else "DIFFERENTLY: " + "; ".join(diffs)))
    with open(os.path.join(HERE, "soak.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    with open(os.path.join(HERE, "memory.csv"), "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["run", "wall_s", "rss_mb", "steps_done"])
        for r in (ref, cut):
            w.writerows([r.name] + list(s) for s in r.samples)
    plot(ref, cut)
    sys.exit(0 if not diffs else 1)


def plot(ref, cut):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(9, 4.5))
    for r, style in ((ref, "-"), (cut, "--")):
        ax.plot([s[0] for s in r.samples], [s[1] for s in r.samples], style, label=r.name)
    for t, _ in cut.kills:
        ax.axvline(t, color="red", alpha=0.4)
    ax.set_xlabel("wall time, s")
    ax.set_ylabel("resident memory, MB (all ranks)")
    ax.set_title("soak: memory over time (red: SIGKILL, then restart from the last checkpoint)")
    ax.grid(True, alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(os.path.join(HERE, "memory.png"), dpi=100)


if __name__ == "__main__":
    main()
