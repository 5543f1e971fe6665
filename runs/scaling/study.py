#!/usr/bin/env python3
"""Scaling study: strong scaling on a fixed tet mesh, weak scaling on tet boxes, memory per spring,
setup cost, and a performance model past this machine (reading in runs/scaling/README.md).

Usage: /usr/bin/python3 runs/scaling/study.py [ranks, default 1,2] [--skip-memory] [--skip-model]
       [--only-memory: the memory and setup part alone, about 6 minutes]
Runs unchanged at any rank count (the ranks list is what mpirun gets). Writes runs/scaling/
{strong,weak,memory,partitions,pingpong,model}.csv and {speedup,model,edgecut}.png.

- strong: the bunny refined three times (-msim_refine 3: 4.9 M tets, 5.9 M springs), explicit
  symplectic Euler (100 steps of 20 us), projective dynamics (2 steps of 10 ms x 10 iterations,
  CG + GAMG global steps: msim's default at this size, and set for every run so that weak scaling
  compares like with like) and Newton with CG (1 step of 1 ms, msim's
  default block-Jacobi ICC; at 10 ms a step takes 5 Newton and 800 CG iterations on the bunny
  refined twice: minutes at this size);
  time per step from the Stepping stage of -log_view, setup from the Read, Partition,
  Distribution, Refinement and Setup stages, memory from -memory_view (all ranks).
- weak: tet boxes of about 5 x 10^5 springs per rank, the same methods.
- memory: bytes per spring for explicit, PD and Newton on boxes of 10^5, 10^6, 4 x 10^6 springs,
  and 3 x 10^7 for explicit, on one rank, with setup time.
- model: METIS partitions of a 10^7-spring box (and of the strong-scaling mesh) into 2 ... 1024
  parts (msim_partition_model: owned springs, halo springs, ghosts, neighbours of the busiest part),
  an MPI ping-pong and the triad bandwidth here, and the explicit step's per-spring and per-vertex
  costs measured on that box at one rank, give a predicted time per step at each P on a
  shared-memory node and over InfiniBand; checked against the box's and the bunny's measured
  runs at every rank count of the study."""
import csv
import os
import re
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(os.path.dirname(HERE), "tools"))
from msimrun import ENV, MSIM, ROOT, event  # noqa: E402

MODEL_TOOL = os.path.join(ROOT, "build", "msim_partition_model")
BUNNY_R3 = ("-msim_scene tet -msim_mesh_file examples/meshes/bunny.off -msim_mesh_scale 0.01 -msim_refine 3 -msim_fix_box -1,1,0.09,1,-1,1 "
            "-msim_gravity 0,-9.81,0 -msim_density 1100 -msim_young 2e4")
METHODS = {
    "explicit": "-msim_integrator symplectic_euler -msim_dt {dt_explicit} -msim_steps 100 -msim_spectrum_check 0",
    "pd": "-msim_integrator implicit_euler -msim_dt 0.01 -msim_steps 2 -snes_type pd -snes_max_it 10 -snes_pd_fixed -pd_ksp_type cg -pd_pc_type gamg",
    "newton_cg": "-msim_integrator implicit_euler -msim_dt 0.001 -msim_steps 1 -snes_type newtonls",
}
STAGES = ["Read", "Partition", "Distribution", "Refinement", "Setup", "Stepping"]
# a 16-core node and InfiniBand, the assumptions of the model (README states them)
NODE_CORES = 16
NODE_BW = 150e9         # B/s a 16-core node's memory system sustains with all cores streaming (8 channels of DDR4-3200: 205 GB/s peak)
SINGLE_CORE_BW = 15e9   # B/s one core alone gets (its outstanding misses limit it, not the channels)
CACHE_PER_CORE = 2.5e6  # B of last-level cache per core: a part smaller than that streams from cache
IB_LATENCY = 1.5e-6     # s per message between nodes (HDR InfiniBand, MPI)
IB_BW = 12.0e9          # B/s per link (HDR100: 12.5 GB/s)
BYTES_PER_SPRING = 28.0 # what a force evaluation moves per spring (runs/bench: 20 B record + vertex traffic)


def box(springs):
    """a Kuhn box (n, n, n) with about that many springs: 7 per cube"""
    n = max(2, round((springs / 7.0) ** (1 / 3)))
    return n, f"-msim_scene box -msim_box_n {n},{n},{n} -msim_fix_plane x_min -msim_density 1000 -msim_young 1e6"


def stages(log):
    out = {}
    for name in STAGES:
        m = re.search(rf"^\s*\d+:\s+{name}:\s+(\S+)", log, re.M)
        out[name] = float(m.group(1)) if m else 0.0
    return out


def run(scene, method, np_, extra="", repeat=2):
    """the best of `repeat` runs: the fastest step, and the fastest setup of the same runs (this
    machine is shared and its first run after a pause pays for the host backing fresh memory)"""
    rows = [run_once(scene, method, np_, extra) for _ in range(repeat)]
    best = min(rows, key=lambda r: r["step_s"])
    fastest = min(rows, key=lambda r: r["setup_total_s"])
    for key in fastest:
        if key.endswith("_s") and key not in ("step_s", "force_s", "stepping_s"):
            best[key] = fastest[key]
    return best


def run_once(scene, method, np_, extra=""):
    dt = "2e-5" if "bunny" in scene else "5e-5"
    args = f"{scene} {METHODS[method].format(dt_explicit=dt)} {extra} -log_view -memory_view -msim_scene_view".split()
    cmd = (["mpirun", "-n", str(np_)] if np_ > 1 else []) + [MSIM] + args
    r = subprocess.run(cmd, capture_output=True, text=True, env=ENV, cwd=ROOT)
    if r.returncode:
        sys.exit(f"msim failed: {' '.join(cmd)}\n{r.stderr[-3000:]}")
    st = stages(r.stdout)
    steps = int(re.search(r"-msim_steps (\d+)", METHODS[method]).group(1))
    springs = int(re.search(r"(\d+) springs", r.stdout).group(1))
    mem = float(re.search(r"Maximum \(over computational time\) process memory:\s+total (\S+)", r.stdout).group(1))
    force = event(r.stdout, "MSimForce")
    return dict(method=method, ranks=np_, springs=springs, step_s=st["Stepping"] / steps,
                setup_total_s=sum(st[s] for s in STAGES[:-1]), **{f"{s.lower()}_s": st[s] for s in STAGES},
                force_s=force[1] / max(force[0], 1), max_memory_total_b=mem, bytes_per_spring=mem / springs)


def write(name, rows):
    with open(os.path.join(HERE, name), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
        w.writeheader()
        w.writerows(rows)


def strong(ranks):
    rows = []
    for method in METHODS:
        for np_ in ranks:
            r = run(BUNNY_R3, method, np_, repeat=3)  # the ratios are the headline: one more run against this machine's noise
            rows.append(r)
            print(f"strong {method:9s} {np_} ranks: {r['step_s'] * 1e3:9.2f} ms/step, setup {r['setup_total_s']:.2f} s, {r['bytes_per_spring']:.0f} B/spring", flush=True)
    base = {r["method"]: r["step_s"] for r in rows if r["ranks"] == min(ranks)}
    for r in rows:
        r["speedup"] = base[r["method"]] / r["step_s"] * min(ranks)
        r["efficiency"] = r["speedup"] / r["ranks"]
    return rows


def weak(ranks):
    rows = []
    for np_ in ranks:
        n, scene = box(5e5 * np_)
        for method in METHODS:
            r = run(scene, method, np_)
            r["box_n"] = n
            rows.append(r)
            print(f"weak {method:9s} {np_} ranks (box {n}^3, {r['springs']} springs): {r['step_s'] * 1e3:9.2f} ms/step", flush=True)
    base = {r["method"]: r["step_s"] for r in rows if r["ranks"] == min(ranks)}
    for r in rows:
        r["efficiency"] = base[r["method"]] / r["step_s"]
    return rows


def memory():
    rows = []
    ft = first_touch()
    print(f"first touch here: {ft['4k'][0] / 1e9:.2f} GB/s with 4 KiB pages, {ft['thp'][0] / 1e9:.2f} GB/s with huge pages new to the process, "
          f"{ft['thp'][1] / 1e9:.2f} GB/s on huge pages it had freed; rewriting mapped pages {ft['thp'][2] / 1e9:.1f} GB/s", flush=True)
    for target in (1e5, 1e6, 4e6, 3e7):
        n, scene = box(target)
        for method in (METHODS if target < 1e7 else ["explicit"]):
            r = run(scene, method, 1, repeat=3)  # setup is the headline here, and the most at the host's mercy
            r["box_n"] = n
            # the least setup can cost here: fault in (zero) the peak resident memory once, on
            # pages new to the process (a fresh run) or on pages it had freed (the best case)
            r["first_touch_floor_cold_s"] = r["max_memory_total_b"] / ft["thp"][0]
            r["first_touch_floor_s"] = r["max_memory_total_b"] / ft["thp"][1]
            rows.append(r)
            print(f"memory {method:9s} box {n}^3, {r['springs']} springs: {r['bytes_per_spring']:.0f} B/spring, setup {r['setup_total_s']:.2f} s "
                  f"(first-touch floor {r['first_touch_floor_s']:.2f} s warm, {r['first_touch_floor_cold_s']:.2f} s cold), step {r['step_s'] * 1e3:.2f} ms", flush=True)
    return rows


def partitions(scene, parts, label):
    r = subprocess.run([MODEL_TOOL] + scene.split() + ["-parts", ",".join(map(str, parts))], capture_output=True, text=True, env=ENV, cwd=ROOT)
    if r.returncode:
        sys.exit(f"msim_partition_model failed: {r.stderr[-2000:]}")
    rows = list(csv.DictReader(r.stdout.splitlines()))
    for row in rows:
        row["mesh"] = label
    return rows


def pingpong():
    r = subprocess.run(["mpirun", "-n", "2", MODEL_TOOL, "-pingpong"], capture_output=True, text=True, env=ENV, cwd=ROOT)
    rows = list(csv.DictReader(r.stdout.splitlines()))
    # latency: the smallest message; bandwidth: the largest
    lat = float(rows[0]["half_round_trip_s"])
    big = rows[-1]
    bw = float(big["bytes"]) / (float(big["half_round_trip_s"]) - lat)
    return rows, lat, bw


def predict(part, t_spring, t_vertex, latency, link_bw, mem_bw_core, cache_core):
    """seconds per explicit step of the busiest part: its vertex updates and its spring sweep
    (owned and halo springs); the ghost exchange (a message each way per neighbour, 24 B per
    ghost) overlaps the sweep of the springs without a ghost end, which msim runs between posting
    the exchange and waiting for it. A part whose springs do not fit in its cache streams them
    from memory at its share of the bandwidth."""
    springs, ghosted = float(part["max_sweep_springs"]), float(part["max_ghosted_springs"])
    ts = t_spring if springs * BYTES_PER_SPRING <= cache_core else max(t_spring, BYTES_PER_SPRING / mem_bw_core)
    comm = 2 * float(part["max_neighbours"]) * latency + 2 * 24.0 * float(part["max_ghosts"]) / link_bw
    inner = (springs - ghosted) * ts
    return float(part["max_owned_vertices"]) * t_vertex + springs * ts + max(0.0, comm - inner)


def first_touch():
    """GB/s at which fresh pages are written the first time (runs/bench/first_touch.cpp), per page
    size (4 KiB, transparent huge pages): pages new to the process (cold), pages it had freed
    (warm), and rewriting pages already mapped"""
    exe = "/tmp/msim_first_touch"
    subprocess.run(["g++", "-O2", os.path.join(ROOT, "runs", "bench", "first_touch.cpp"), "-o", exe], check=True)
    out = {}
    for line in subprocess.run([exe], capture_output=True, text=True, check=True).stdout.splitlines():
        kind, cold, warm, second = line.split()
        out[kind] = (float(cold) * 1e9, float(warm) * 1e9, float(second) * 1e9)
    return out


def triad(np_):
    """GB/s of np ranks streaming at once (runs/bench/stream.cpp)"""
    exe = "/tmp/msim_stream"
    if not os.path.exists(exe):
        subprocess.run(["mpicxx", "-O3", "-march=x86-64-v2", os.path.join(ROOT, "runs", "bench", "stream.cpp"), "-o", exe], check=True)
    r = subprocess.run((["mpirun", "-n", str(np_)] if np_ > 1 else []) + [exe], capture_output=True, text=True, env=ENV)
    return float(re.search(r"([\d.]+)", r.stdout.strip().splitlines()[-1]).group(1)) * 1e9


def model(strong_rows, ranks):
    parts = [2, 4, 8, 16, 32, 64, 128, 256, 512, 1024]
    n10, box10 = box(1e7)
    label = f"box {n10}^3"
    prow = partitions(box10, parts, label) + partitions(BUNNY_R3, [p for p in ranks if p > 1] or [2], "bunny r3")
    write("partitions.csv", prow)
    pp, lat, bw = pingpong()
    write("pingpong.csv", pp)
    print(f"ping-pong here: latency {lat * 1e6:.2f} us, bandwidth {bw / 1e9:.1f} GB/s")
    # the explicit step on the modelled box itself, at each rank count here: the per-spring and
    # per-vertex costs come from its one-rank run, the other runs check the model
    boxruns = [run(box10, "explicit", np_) for np_ in ranks]
    one = next(r for r in boxruns if r["ranks"] == 1)
    nvert = float(next(r for r in prow if r["mesh"] == label)["vertices"])
    t_spring = one["force_s"] / one["springs"]
    t_vertex = max(one["step_s"] - one["force_s"], 0.0) / nvert
    print(f"explicit step of the {label} box here: {t_spring * 1e9:.3f} ns per spring (force), {t_vertex * 1e9:.3f} ns per vertex (the rest)")
    rows = []
    bunny_one = next(r for r in strong_rows if r["method"] == "explicit" and r["ranks"] == 1)
    bunny_vert = float(next(r for r in prow if r["mesh"] == "bunny r3")["vertices"])
    tb_spring = bunny_one["force_s"] / bunny_one["springs"]
    tb_vertex = max(bunny_one["step_s"] - bunny_one["force_s"], 0.0) / bunny_vert
    for mesh, measured, ts, tv, ref in ((label, boxruns, t_spring, t_vertex, one), ("bunny r3", [r for r in strong_rows if r["method"] == "explicit"], tb_spring, tb_vertex, bunny_one)):
        for r in measured:
            if r["ranks"] == 1:
                continue
            part = next((p for p in prow if p["mesh"] == mesh and int(p["parts"]) == r["ranks"] and p["partition"] == "metis"), None)
            if part is None:
                continue
            bw_here = triad(r["ranks"])
            pred = predict(part, ts, tv, lat, bw, bw_here / r["ranks"], 0)
            rows.append(dict(machine="here (check)", mesh=mesh, parts=r["ranks"], predicted_s=pred, measured_s=r["step_s"], error=pred / r["step_s"] - 1,
                             speedup=ref["step_s"] / pred, efficiency=ref["step_s"] / pred / r["ranks"]))
            print(f"model check, {mesh}: {r['ranks']} ranks predicted {pred * 1e3:.2f} ms per step, measured {r['step_s'] * 1e3:.2f} ms ({(pred / r['step_s'] - 1) * 100:+.1f}%); triad {bw_here / 1e9:.1f} GB/s")
    write("box_explicit.csv", boxruns)
    # the box on a modelled node: one rank alone gets SINGLE_CORE_BW, P ranks share NODE_BW; over
    # InfiniBand, 16 ranks per node
    boxp = [x for x in prow if x["mesh"] == label and x["partition"] == "metis"]
    springs1 = float(boxp[0]["springs"])
    serial = nvert * t_vertex + springs1 * max(t_spring, BYTES_PER_SPRING / SINGLE_CORE_BW)
    rows.append(dict(machine="node", mesh=label, parts=1, predicted_s=serial, measured_s="", error="", speedup=1.0, efficiency=1.0))
    for p in boxp:
        P = int(p["parts"])
        # over InfiniBand from one full node (16 ranks) up: fewer ranks fit in one node
        cases = [("infiniband", predict(p, t_spring, t_vertex, IB_LATENCY, IB_BW, NODE_BW / NODE_CORES, CACHE_PER_CORE))] if P >= NODE_CORES else []
        if P <= NODE_CORES:
            cases.insert(0, ("node", predict(p, t_spring, t_vertex, lat, bw, NODE_BW / P, CACHE_PER_CORE)))
        for machine, t in cases:
            rows.append(dict(machine=machine, mesh=label, parts=P, predicted_s=t, measured_s="", error="", speedup=serial / t, efficiency=serial / t / P))
            print(f"model {machine:10s} P = {P:4d}: {t * 1e3:8.3f} ms per step, speedup {serial / t:7.1f}, efficiency {serial / t / P:.2f}")
    write("model.csv", rows)
    return rows, prow, boxruns


def charts(strong_rows, weak_rows, model_rows, prow, boxruns):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    for method, mk in (("explicit", "o"), ("pd", "s"), ("newton_cg", "^")):
        sel = sorted((r for r in strong_rows if r["method"] == method), key=lambda r: r["ranks"])
        axes[0].plot([r["ranks"] for r in sel], [r["speedup"] for r in sel], mk + "-", label=f"{method} (strong, bunny r3)")
        selw = sorted((r for r in weak_rows if r["method"] == method), key=lambda r: r["ranks"])
        axes[1].plot([r["ranks"] for r in selw], [r["efficiency"] for r in selw], mk + "-", label=f"{method} (weak, 5e5 springs/rank)")
    mx = max(r["ranks"] for r in strong_rows)
    axes[0].plot([1, mx], [1, mx], "k:", label="ideal")
    axes[0].set_xlabel("ranks")
    axes[0].set_ylabel("speedup")
    axes[0].legend(fontsize=8)
    axes[1].set_xlabel("ranks")
    axes[1].set_ylabel("parallel efficiency")
    axes[1].set_ylim(0, 1.2)
    axes[1].legend(fontsize=8)
    fig.suptitle("Measured on this machine (2 cores)")
    fig.tight_layout()
    fig.savefig(os.path.join(HERE, "speedup.png"), dpi=110)

    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    for machine, mk in (("node", "o-"), ("infiniband", "s-")):
        sel = [r for r in model_rows if r["machine"] == machine]
        axes[0].plot([r["parts"] for r in sel], [r["speedup"] for r in sel], mk, label=f"predicted, {machine}")
        axes[1].plot([r["parts"] for r in sel], [r["efficiency"] for r in sel], mk, label=f"predicted, {machine}")
    base = next(r["step_s"] for r in boxruns if r["ranks"] == 1)
    axes[0].plot([r["ranks"] for r in boxruns], [base / r["step_s"] for r in boxruns], "k*", ms=10, label="measured here (the same box)")
    axes[1].plot([r["ranks"] for r in boxruns], [base / r["step_s"] / r["ranks"] for r in boxruns], "k*", ms=10, label="measured here (the same box)")
    axes[0].plot([1, 1024], [1, 1024], "k:", lw=0.8)
    for ax in axes:
        ax.set_xscale("log", base=2)
        ax.set_xlabel("ranks")
        ax.legend(fontsize=8)
    axes[0].set_yscale("log", base=2)
    axes[0].set_ylabel("speedup, explicit step (10^7-spring box)")
    axes[1].set_ylabel("parallel efficiency")
    axes[1].set_ylim(0, 1.1)
    fig.tight_layout()
    fig.savefig(os.path.join(HERE, "model.png"), dpi=110)

    fig, ax = plt.subplots(figsize=(5.5, 4))
    for part, mk in (("metis", "o-"), ("natural", "s--")):
        sel = [r for r in prow if r["mesh"].startswith("box") and r["partition"] == part]
        ax.plot([int(r["parts"]) for r in sel], [float(r["edge_cut"]) / float(r["springs"]) for r in sel], mk, label=part)
    ax.set_xscale("log", base=2)
    ax.set_yscale("log")
    ax.set_xlabel("parts")
    ax.set_ylabel("edge cut / springs")
    ax.set_title("Edge cut of the 10^7-spring box")
    ax.legend()
    fig.tight_layout()
    fig.savefig(os.path.join(HERE, "edgecut.png"), dpi=110)


def main():
    ranks = [int(x) for x in sys.argv[1].split(",")] if len(sys.argv) > 1 and not sys.argv[1].startswith("--") else [1, 2]
    if "--only-memory" in sys.argv:
        write("memory.csv", memory())
        return
    s = strong(ranks)
    write("strong.csv", s)
    w = weak(ranks)
    write("weak.csv", w)
    if "--skip-memory" not in sys.argv:
        write("memory.csv", memory())
    if "--skip-model" not in sys.argv:
        m, prow, boxruns = model(s, ranks)
        charts(s, w, m, prow, boxruns)


if __name__ == "__main__":
    main()
