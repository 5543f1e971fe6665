#!/usr/bin/env python3
"""Which linear solver wins inside PD and Newton on tet solids, by size and rank count.

Usage: /usr/bin/python3 runs/scaling/solvers.py [ranks, default 1,2] [sizes in springs, default 2e5,4e6]
Writes runs/scaling/solvers.csv (and prints each row). Tet boxes (-msim_scene box, fixed at x_min,
E = 1e6 Pa, rho = 1000 kg/m^3) of about 2 x 10^5 and 4 x 10^6 springs:
- PD, one step of 10 ms, 10 fixed iterations; its global step by msimllt (msim's supernodal
  Cholesky: serial factor per rank plus a dense Schur complement of the interface rows; only at
  the small size, where its factor takes seconds, not minutes), MUMPS's Cholesky (PORD ordering,
  the one this MUMPS build has) and CG + GAMG (msim's default beyond 10^5 free vertices): setup
  (MSimPDSetUp: the factorization, or GAMG's hierarchy), time per iteration (MSimPDGlobal +
  MSimPDLocal over 10), max memory (-memory_view, all ranks);
- Newton with CG (one step of 10 ms, to msim's default tolerance) preconditioned by block Jacobi +
  ICC(0) (msim's default), GAMG (rebuilt every Newton iteration, the Hessian changes) and hypre's
  BoomerAMG (only at the small size: tens of seconds per step beyond): time per step, Newton and
  CG iterations.
Timings are the best of 2 runs (the machine is shared)."""
import os
import re
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(os.path.dirname(HERE), "tools"))
from msimrun import ENV, MSIM, ROOT, event, write_csv  # noqa: E402

PD = "-msim_integrator implicit_euler -msim_dt 0.01 -msim_steps 1 -snes_type pd -snes_max_it 10 -snes_pd_fixed"
PD_SOLVERS = {
    "msimllt": "-pd_ksp_type preonly -pd_pc_type msimllt",
    "mumps": "-pd_ksp_type preonly -pd_pc_type cholesky -pd_pc_factor_mat_solver_type mumps",
    "cg+gamg": "-pd_ksp_type cg -pd_pc_type gamg",
}
NEWTON = "-msim_integrator implicit_euler -msim_dt 0.01 -msim_steps 1 -snes_type newtonls -ksp_type cg"
NEWTON_PCS = {
    "bjacobi+icc": "",
    "gamg": "-pc_type gamg",
    "hypre": "-pc_type hypre -pc_hypre_type boomeramg",
}
SMALL_ONLY = {"msimllt", "hypre"}


def box(springs):
    n = max(2, round((springs / 7.0) ** (1 / 3)))
    return n, f"-msim_scene box -msim_box_n {n},{n},{n} -msim_fix_plane x_min -msim_density 1000 -msim_young 1e6"


def once(args, np_):
    cmd = (["mpirun", "-n", str(np_)] if np_ > 1 else []) + [MSIM] + args.split() + ["-log_view", "-memory_view", "-msim_monitor"]
    r = subprocess.run(cmd, capture_output=True, text=True, env=ENV, cwd=ROOT)
    if r.returncode:
        sys.exit(f"msim failed: {' '.join(cmd)}\n{r.stderr[-3000:]}")
    step = re.search(r"^\s*\d+:\s+Stepping:\s+(\S+)", r.stdout, re.M)
    mem = re.search(r"Maximum \(over computational time\) process memory:\s+total (\S+)", r.stdout)
    springs = int(re.search(r"(\d+) springs", r.stdout).group(1)) if re.search(r"(\d+) springs", r.stdout) else 0
    mon = re.findall(r"^step\s+1 .* nl (\d+) lin (\d+)", r.stdout, re.M)
    return dict(step_s=float(step.group(1)), setup_s=event(r.stdout, "MSimPDSetUp")[1],
                setup_in_steps_s=event(r.stdout, "MSimPDSetUp", "Stepping")[1],
                pd_global_s=event(r.stdout, "MSimPDGlobal")[1], pd_local_s=event(r.stdout, "MSimPDLocal")[1],
                jacobian_s=event(r.stdout, "MSimJacobian")[1], pcsetup_s=event(r.stdout, "PCSetUp")[1],
                nonlinear_its=int(mon[0][0]) if mon else 0, linear_its=int(mon[0][1]) if mon else 0,
                max_memory_b=float(mem.group(1)) if mem else 0.0, springs=springs)


def best(args, np_):
    runs = [once(args, np_) for _ in range(2)]
    return min(runs, key=lambda r: r["step_s"])


def main():
    ranks = [int(x) for x in sys.argv[1].split(",")] if len(sys.argv) > 1 else [1, 2]
    sizes = [float(x) for x in sys.argv[2].split(",")] if len(sys.argv) > 2 else [2e5, 4e6]
    rows = []
    for size in sizes:
        n, scene = box(size)
        small = size <= min(sizes)
        for np_ in ranks:
            for name, opts in PD_SOLVERS.items():
                if name in SMALL_ONLY and not small:
                    continue
                r = best(f"{scene} {PD} {opts} -msim_scene_view", np_)
                # the step = setup + 10 iterations; per iteration without the setup
                per_it = (r["step_s"] - r["setup_in_steps_s"]) / 10
                rows.append(dict(method="pd", solver=name, box_n=n, springs=r["springs"], ranks=np_, setup_s=r["setup_s"], per_iteration_s=per_it,
                                 step_s=r["step_s"], nonlinear_its=r["nonlinear_its"], linear_its=r["linear_its"], max_memory_b=r["max_memory_b"],
                                 bytes_per_spring=r["max_memory_b"] / max(r["springs"], 1)))
                print(f"pd     {name:12s} box {n}^3 ({r['springs']} springs) {np_} ranks: setup {r['setup_s']:.2f} s, {per_it * 1e3:.1f} ms per iteration, "
                      f"{r['max_memory_b'] / 1e9:.2f} GB", flush=True)
            for name, opts in NEWTON_PCS.items():
                if name in SMALL_ONLY and not small:
                    continue
                r = best(f"{scene} {NEWTON} {opts} -msim_scene_view", np_)
                rows.append(dict(method="newton_cg", solver=name, box_n=n, springs=r["springs"], ranks=np_, setup_s=r["pcsetup_s"], per_iteration_s="",
                                 step_s=r["step_s"], nonlinear_its=r["nonlinear_its"], linear_its=r["linear_its"], max_memory_b=r["max_memory_b"],
                                 bytes_per_spring=r["max_memory_b"] / max(r["springs"], 1)))
                print(f"newton {name:12s} box {n}^3 ({r['springs']} springs) {np_} ranks: {r['step_s']:.2f} s per step ({r['nonlinear_its']} Newton, "
                      f"{r['linear_its']} CG iterations; PC setup {r['pcsetup_s']:.2f} s), {r['max_memory_b'] / 1e9:.2f} GB", flush=True)
    write_csv(os.path.join(HERE, "solvers.csv"), rows)


if __name__ == "__main__":
    main()
