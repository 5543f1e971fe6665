#!/usr/bin/env python3
"""Contact evidence (issue 34): penetration, contact force against m g, cost per step with and
without contact, for each integrator and solver against h; explicit stability with the penalty
against the guard; friction on an incline against g (sin - mu cos) t^2/2; the cost targets on the
benchmark cloth draped on a ball (analytic sphere and a >= 10^4-triangle mesh sphere).
Usage: /usr/bin/python3 runs/contact/study.py [rest|stability|friction|targets|meshcheck|newton|plot|all] [--n 11] [--bench-n 41] [--msim PATH]
       [--solvers pd10,newton_cg] [--obstacles none,sphere,mesh] [--cases 'NAME;NAME'] [--repeat R] [--out CSV]
Small sizes by default (2 shared cores); --bench-n 101 is the benchmark cloth. Costs: PETSc's
MSimStep event (wall, ms per step; this machine is shared, so they vary by tens of %) and the
run's CPU time per step."""
import argparse
import math
import os
import resource
import subprocess
import sys
import tempfile

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "tools"))
import msimrun  # noqa: E402
import vtu  # noqa: E402

G = 9.81
PLANE = "0,0,1,-0.05"


def run(msim, args, np_=1):
    """runs msim; (returncode, stderr, -log_view text, CPU user seconds of the run)"""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    cmd = ([] if np_ == 1 else ["mpirun", "-n", str(np_)]) + [msim] + [str(a) for a in args] + ["-log_view"]
    r = subprocess.run(cmd, capture_output=True, text=True, env=msimrun.ENV)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.returncode, r.stderr, r.stdout, after.ru_utime - before.ru_utime


def read_csv(path):
    import csv
    with open(path) as f:
        return list(csv.DictReader(f))


def min_plane_distance(out):
    """least z + 0.05 over the free vertices of every frame, and the number of frames"""
    least, n = np.inf, 0
    for _, f in vtu.read_pvd(os.path.join(out, "series.pvd")):
        g = vtu.read_vtu(f)
        least = min(least, float((g["points"][g["fixed"] == 0, 2] + 0.05).min()))
        n += 1
    return least, n


METHODS = {  # name: (integrator, options, step sizes)
    "implicit_euler newton": ("implicit_euler", [], (0.02, 0.01, 0.005)),
    "implicit_euler pd": ("implicit_euler", ["-snes_type", "pd", "-snes_pd_anderson", "5", "-snes_max_it", "300"], (0.02, 0.01, 0.005)),
    "implicit_euler lbfgs": ("implicit_euler", ["-snes_type", "qn", "-snes_max_it", "300"], (0.02, 0.01, 0.005)),
    "bdf2 newton": ("bdf2", [], (0.02, 0.01, 0.005)),
    "implicit_euler newton VI bounds": ("implicit_euler", ["-msim_contact_bounds"], (0.02, 0.01, 0.005)),
    "symplectic_euler penalty": ("symplectic_euler", ["-msim_contact_stiffness", "2000"], (0.001, 0.0005, 0.00025)),
}


def rest(a, tmp):
    """a cloth (mass 1 kg, drag 0.5) dropped 5 cm on the plane z >= -0.05 and left to rest until
    T = 2 s: penetration over every frame, the monitor's contact force against m g at the end,
    iterations and cost per step with the plane and without it"""
    rows = []
    T = 2.0
    for name, (integ, opts, hs) in METHODS.items():
        for h in hs:
            steps = int(round(T / h))
            every = max(1, steps // 100)
            base = ["-msim_cloth_n", a.n, "-msim_fix", "none", "-msim_drag", "0.5", "-msim_integrator", integ, "-msim_dt", h, "-msim_steps", steps] + opts
            out, csv = os.path.join(tmp, "o"), os.path.join(tmp, "m.csv")
            rc, err, log, cpu = run(a.msim, base + ["-msim_contact_plane", PLANE, "-msim_output", out, "-msim_output_every", every, "-msim_monitor_csv", csv])
            if rc:
                rows.append(dict(method=name, h=h, steps=steps, ok=0, frames=0, penetration_m=float("nan"), min_gap_m=float("nan"), force_rel_error=float("nan"),
                                 its_per_step=float("nan"), ms_per_step=float("nan"), cpu_ms_per_step=float("nan"), ms_per_step_free=float("nan"), cost_ratio=float("nan"), note=err.strip().splitlines()[-1][:120] if err.strip() else ""))
                print(rows[-1], flush=True)
                continue
            least, frames = min_plane_distance(out)
            mon = read_csv(csv)
            fz = float(mon[-1]["contact_fz"])
            its = np.mean([int(r["nonlinear_its"]) for r in mon[1:]])
            n_step, t_step = msimrun.event(log, "MSimStep")
            # without the plane (the "-msim_contact_bounds" option needs obstacles: dropped)
            free_opts = [o for o in opts if o != "-msim_contact_bounds"]
            if "-msim_contact_stiffness" in free_opts:
                free_opts = []
            rc2, _, log2, cpu2 = run(a.msim, base[:-len(opts)] + free_opts if opts else base)
            n2, t2 = msimrun.event(log2, "MSimStep")
            rows.append(dict(method=name, h=h, steps=steps, ok=1, frames=frames, penetration_m=max(0.0, -least), min_gap_m=least,
                             force_rel_error=abs(fz - 1.0 * G) / G, its_per_step=round(float(its), 2),
                             ms_per_step=1e3 * t_step / max(n_step, 1), cpu_ms_per_step=1e3 * cpu / steps,
                             ms_per_step_free=1e3 * t2 / max(n2, 1), cost_ratio=(t_step / max(n_step, 1)) / max(t2 / max(n2, 1), 1e-12), note=""))
            print(rows[-1], flush=True)
    msimrun.write_csv(os.path.join(HERE, "rest.csv"), rows)


def stability(a, tmp):
    """symplectic Euler with a stiff penalty (kc = 1e5 N/m) on a 5 x 5 cloth resting on the plane
    from the start (1 mm above it, drag 0.5): the guard's limit (Gershgorin, counting kc) and runs
    at fractions of it, stable or not (msim's divergence check over 4000 steps)"""
    base = ["-msim_cloth_n", "5", "-msim_fix", "none", "-msim_drag", "0.5", "-msim_integrator", "symplectic_euler", "-msim_contact_plane", "0,0,1,-0.001", "-msim_contact_stiffness", "1e5"]
    rc, err, _, _ = run(a.msim, base + ["-msim_dt", "1", "-msim_steps", "1", "-msim_divergence_factor", "1e300"])
    said = [l for l in err.splitlines() if "exceeds the stability limit" in l]
    hcrit = float(said[0].split("h <= ")[1].split()[0])
    rows = []
    for guard in ("gershgorin", "slepc"):
        rc, err, _, _ = run(a.msim, base + ["-msim_dt", "1", "-msim_steps", "1", "-msim_divergence_factor", "1e300", "-msim_spectrum_guard", guard])
        said = [l for l in err.splitlines() if "exceeds the stability limit" in l]
        rows.append(dict(kind="guard", guard=guard, h_over_limit=float("nan"), h=float(said[0].split("h <= ")[1].split()[0]) if said else float("nan"), stable=-1, kinetic_end_J=float("nan")))
    for f in (0.5, 0.8, 0.95, 1.0, 1.05, 1.1, 1.2, 1.5, 2.0, 3.0):
        csv = os.path.join(tmp, "s.csv")
        rc, err, _, _ = run(a.msim, base + ["-msim_dt", f * hcrit, "-msim_steps", "4000", "-msim_spectrum_check", "0", "-msim_monitor_csv", csv])
        mon = read_csv(csv)
        # the penalty acts only inside, so an unstable contact kicks the vertex out and gravity brings
        # it back: bounded, not divergent; at rest (drag) a stable run's kinetic energy is ~0
        ke = float(mon[-1]["kinetic"]) if mon else float("nan")
        rows.append(dict(kind="run", guard="gershgorin", h_over_limit=f, h=f * hcrit, stable=int(rc == 0 and ke < 1e-10), kinetic_end_J=ke))
        print(rows[-1], flush=True)
    msimrun.write_csv(os.path.join(HERE, "stability.csv"), rows)


def friction(a, tmp):
    """a 5 x 5 cloth (0.2 m) on the plane z >= -d0 under gravity tilted by theta = 0.3 (an
    incline), implicit Euler h = 0.01, 60 steps: the mean x against t for mu below and above
    tan(theta) = 0.309, against g (sin - mu cos) t^2/2 (zero when mu > tan)"""
    sys.path.insert(0, os.path.join(HERE, "..", "..", "tests"))
    import contact as ct  # the test's equilibrium distance (the barrier holding m g cos at d0)
    theta, n, L, h, steps, dhat = 0.3, 5, 0.2, 0.01, 60, 0.002
    d0 = ct.equilibrium_distance(G * math.cos(theta), h, dhat)
    rows = []
    for mu in (0.0, 0.1, 0.2, 0.4, 0.6):
        out = os.path.join(tmp, f"f{mu}")
        rc, err, _, _ = run(a.msim, ["-msim_integrator", "implicit_euler", "-msim_cloth_n", n, "-msim_cloth_size", L, "-msim_fix", "none", "-msim_gravity", f"{G * math.sin(theta)},0,{-G * math.cos(theta)}",
                                     "-msim_contact_plane", f"0,0,1,{-d0}", "-msim_contact_distance", dhat, "-msim_dt", h, "-msim_steps", steps, "-msim_friction", mu, "-msim_output", out, "-msim_output_every", "1"])
        if rc:
            print(f"mu {mu}: failed {err[-300:]}")
            continue
        x0 = None
        for t, f in vtu.read_pvd(os.path.join(out, "series.pvd")):
            x = float(vtu.read_vtu(f)["points"][:, 0].mean())
            x0 = x if x0 is None else x0
            acc = max(0.0, G * (math.sin(theta) - mu * math.cos(theta)))
            rows.append(dict(mu=mu, t=t, displacement_m=x - x0, analytic_m=0.5 * acc * t * t))
    msimrun.write_csv(os.path.join(HERE, "friction.csv"), rows)


def sphere_obj(path, level=5):
    """an icosphere of 20 4^level triangles (level 5: 20,480), radius 0.3 at (0.5, 0.5, -0.4)"""
    t = (1 + 5 ** 0.5) / 2
    v = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t), (0, -1, -t), (0, 1, -t), (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]
    v = [np.array(p) / np.linalg.norm(p) for p in v]
    f = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4), (11, 10, 2), (10, 7, 6), (7, 1, 8),
         (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8), (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    for _ in range(level):
        cache, nf = {}, []

        def mid(i, j):
            key = (min(i, j), max(i, j))
            if key not in cache:
                m = v[i] + v[j]
                v.append(m / np.linalg.norm(m))
                cache[key] = len(v) - 1
            return cache[key]
        for a_, b, c in f:
            ab, bc, ca = mid(a_, b), mid(b, c), mid(c, a_)
            nf += [(a_, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        f = nf
    with open(path, "w") as out:
        for p in v:
            q = np.array([0.5, 0.5, -0.4]) + 0.3 * p
            out.write(f"v {q[0]:.9f} {q[1]:.9f} {q[2]:.9f}\n")
        for a_, b, c in f:
            out.write(f"f {a_ + 1} {b + 1} {c + 1}\n")
    return len(f)


def targets(a, tmp):
    """the cloth (--bench-n, 101 the benchmark) at h = 1/30 dropped on the ball of
    examples/cloth_sphere.opts, 24 steps (in contact from step 5): CPU ms per step over steps 5-24 of PD (10 fixed
    iterations, examples/cloth_pd.opts) and Newton-CG (examples/cloth_newton_fast.opts) with no
    obstacle, the analytic sphere and a 20,480-triangle mesh of the same sphere (inscribed: its
    faces 0.1% inside the analytic one)"""
    obj = os.path.join(tmp, "sphere.obj")
    ntri = sphere_obj(obj)
    cloth = ["-msim_cloth_n", a.bench_n, "-msim_fix", "none", "-msim_integrator", "implicit_euler", "-msim_dt", 1 / 30, "-msim_steps", "24", "-msim_friction", "0.3"]
    solvers = {"pd10": ["-snes_type", "pd", "-snes_max_it", "10", "-snes_pd_fixed"],
               "newton_cg": ["-snes_type", "newtonls", "-ksp_type", "cg", "-msim_pc_pd", "-snes_ksp_ew", "-msim_step_atol", "1e-3", "-snes_rtol", "0", "-snes_atol", "0", "-snes_max_it", "20"]}
    obstacles = {"none": [], "sphere": ["-msim_contact_sphere", "0.5,0.5,-0.4,0.3"], f"mesh{ntri}": ["-msim_contact_mesh", obj]}
    rows = []
    for s, sopts in solvers.items():
        if a.solvers and s not in a.solvers.split(","):
            continue
        for o, oopts in obstacles.items():
            if a.obstacles and o.rstrip("0123456789") not in a.obstacles.split(","):
                continue
            args = cloth + sopts + oopts
            if o == "none":
                args = [x for x in args if x not in ("-msim_friction", "0.3")]
            csv = os.path.join(tmp, "t.csv")
            rc, err, log, cpu = run(a.msim, args + ["-msim_monitor_csv", csv])
            # CPU time of steps 5-24 (in contact): the run less the same run stopped at step 4,
            # which also takes out the setup (wall times are meaningless on this loaded machine)
            _, _, _, cpu4 = run(a.msim, [x if x != "24" else "4" for x in args])
            n_step, t_step = msimrun.event(log, "MSimStep")
            mon = read_csv(csv) if rc == 0 else []
            rows.append(dict(n=a.bench_n, solver=s, obstacle=o, ok=int(rc == 0), cpu_ms_per_step=1e3 * (cpu - cpu4) / 20, ms_per_step=1e3 * t_step / max(n_step, 1), cpu_s=cpu,
                             its_per_step=np.mean([int(r["nonlinear_its"]) for r in mon[1:]]) if mon else float("nan"),
                             contact_n_last=int(mon[-1]["contact_n"]) if mon else -1, note="" if rc == 0 else err.strip().splitlines()[-1][:150]))
            print(rows[-1], flush=True)
    for r in rows:
        base = next((b for b in rows if b["solver"] == r["solver"] and b["obstacle"] == "none"), dict(cpu_ms_per_step=0))
        r["added_fraction"] = r["cpu_ms_per_step"] / base["cpu_ms_per_step"] - 1 if base["cpu_ms_per_step"] > 0 else float("nan")
    msimrun.write_csv(os.path.join(HERE, f"targets_n{a.bench_n}{'_' + a.solvers if a.solvers else ''}.csv"), rows)


def meshcheck(a, tmp):
    """no vertex inside the mesh ball in any frame: the targets' mesh runs (--bench-n, 24 steps, each
    solver) with every step written, and over every frame and vertex the largest of the signed
    distances to the 20,480 faces' planes (the icosphere is convex, so a point is outside it iff that
    largest is > 0, and it is a lower bound of the point's distance to the surface)"""
    obj = os.path.join(tmp, "sphere.obj")
    sphere_obj(obj)
    v, f = [], []
    for line in open(obj):
        (v if line[0] == "v" else f).append([float(t) for t in line.split()[1:]])
    v, f = np.array(v), np.array(f, dtype=int) - 1
    n = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    n /= np.linalg.norm(n, axis=1)[:, None]
    n *= np.sign(np.einsum("ij,ij->i", n, v[f[:, 0]] - np.array([0.5, 0.5, -0.4])))[:, None]  # outward
    off = np.einsum("ij,ij->i", n, v[f[:, 0]])
    cloth = ["-msim_cloth_n", a.bench_n, "-msim_fix", "none", "-msim_integrator", "implicit_euler", "-msim_dt", 1 / 30, "-msim_steps", "24", "-msim_friction", "0.3",
             "-msim_contact_mesh", obj]
    solvers = {"pd10": ["-snes_type", "pd", "-snes_max_it", "10", "-snes_pd_fixed"],
               "newton_cg": ["-snes_type", "newtonls", "-ksp_type", "cg", "-msim_pc_pd", "-snes_ksp_ew", "-msim_step_atol", "1e-3", "-snes_rtol", "0", "-snes_atol", "0", "-snes_max_it", "20"]}
    for s, sopts in solvers.items():
        if a.solvers and s not in a.solvers.split(","):
            continue
        out = os.path.join(tmp, "frames_" + s)
        rc, err, _, _ = run(a.msim, cloth + sopts + ["-msim_output", out, "-msim_output_every", "1"])
        least, frames = np.inf, 0
        for _, fr in vtu.read_pvd(os.path.join(out, "series.pvd")):
            x = vtu.read_vtu(fr)["points"]
            x = x[np.linalg.norm(x - np.array([0.5, 0.5, -0.4]), axis=1) < 0.35]  # the others are far outside
            for k in range(0, len(x), 256):
                least = min(least, float((x[k:k + 256] @ n.T - off).max(axis=1).min()) if len(x[k:k + 256]) else np.inf)
            frames += 1
        print(f"meshcheck {s}: rc {rc}, {frames} frames, least outside margin over every frame and vertex near the ball {least:.3e} m"
              f" ({'no vertex inside' if least > 0 else 'A VERTEX IS INSIDE'})" + ("" if rc == 0 else " " + err.strip().splitlines()[-1][:150]), flush=True)


def spring_compression(x):
    """median and 90th percentile over the vertices of the cloth's (msim_cloth_n: vertex j N + i,
    structural, shear and bending springs, k = 1000 N/m, 1 kg, h = 1/30 s) compressed springs'
    transverse curvature h^2 k (L/l - 1), summed at each vertex, in units of the vertex mass m:
    what the PSD-projected spring Hessian drops (msim::SpringHessian clamps 1 - L/l at 0), against
    the m I it keeps"""
    n = int(round(len(x) ** 0.5))
    dx, h, k, m = 1.0 / (n - 1), 1.0 / 30, 1000.0, 1.0 / n ** 2
    i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    vid = j * n + i
    pairs = [(vid[:-1, :], vid[1:, :], dx), (vid[:, :-1], vid[:, 1:], dx), (vid[:-1, :-1], vid[1:, 1:], 2 ** 0.5 * dx),
             (vid[1:, :-1], vid[:-1, 1:], 2 ** 0.5 * dx), (vid[:-2, :], vid[2:, :], 2 * dx), (vid[:, :-2], vid[:, 2:], 2 * dx)]
    drop = np.zeros(len(x))
    for a, b, L in pairs:
        a, b = a.ravel(), b.ravel()
        l = np.linalg.norm(x[a] - x[b], axis=1)
        c = np.maximum(L / l - 1, 0) * k * h * h
        np.add.at(drop, a, c)
        np.add.at(drop, b, c)
    return float(np.median(drop) / m), float(np.percentile(drop, 90) / m)


def newton(a, tmp):
    """why Newton-CG needs ~10 x the iterations on the ball (issue 34): the cloth (--bench-n) of
    `targets`, Newton-CG (examples/cloth_newton_fast.opts's options) falling freely, hanging from
    two corners, landing on a plane and draped on the ball, and on the ball with the candidate
    changes; the same with MUMPS (exact linear solves); at --bench-n <= 41 a reference (MUMPS,
    |dx| < 1e-6, 300 iterations) for the final state's distance. Per case: CPU ms per step over
    steps 5-24 (24-step run less the 4-step run, user time), Newton and CG iterations per step,
    the fraction of Newton iterations whose step max_step cut (the line search's PetscInfo), steps
    at the iteration cap (20; 300 for the converged cases), mean |g| at the steps' ends, the contact force (mean of the last 5
    steps; m g = 9.81 N), vertices within dhat, the least gap to the ball at the end, and the
    compressed springs' dropped curvature (spring_compression). The ntr cases: the trust region
    (Steihaug-CG in the PD factor's norm) on the PSD-projected and on the true Hessian, their cut
    share counted from ntr's -info lines (trial steps cut by max_step over trial steps).
    --cases picks cases by name; --repeat R takes each CPU time as the min of R alternated runs"""
    cloth = ["-msim_cloth_n", a.bench_n, "-msim_fix", "none", "-msim_integrator", "implicit_euler", "-msim_dt", 1 / 30, "-msim_steps", "24"]
    cg = ["-snes_type", "newtonls", "-ksp_type", "cg", "-msim_pc_pd", "-snes_ksp_ew", "-msim_step_atol", "1e-3", "-snes_rtol", "0", "-snes_atol", "0", "-snes_max_it", "20"]
    mumps = ["-msim_pc_pd", "0", "-ksp_type", "preonly", "-pc_type", "cholesky", "-pc_factor_mat_solver_type", "mumps", "-snes_ksp_ew", "0"]
    ball = ["-msim_contact_sphere", "0.5,0.5,-0.4,0.3", "-msim_friction", "0.3"]
    kappa10 = ["-msim_contact_kappa", str(10 * 30 ** 2 / 6.3863)]  # 10 x the default 1/(h^2 b''(dhat/2)), b''(dhat/2) = 2 ln 2 + 5
    cases = {"none": [], "corners (no contact)": ["-msim_fix", "corners"], "plane": ["-msim_contact_plane", "0,0,1,-0.1", "-msim_friction", "0.3"],
             "sphere": ball, "sphere -msim_contact_pc_pd_weight": ball + ["-msim_contact_pc_pd_weight"], "sphere kappa x 10": ball + kappa10,
             "sphere kappa x 10 -msim_contact_pc_pd_weight": ball + kappa10 + ["-msim_contact_pc_pd_weight"], "sphere -msim_step_atol 1e-2 -msim_contact_pc_pd_weight": ball + ["-msim_step_atol", "1e-2", "-msim_contact_pc_pd_weight"],
             "sphere -snes_ksp_ew_rtolmax 0.1 -snes_ksp_ew_rtol0 0.1": ball + ["-snes_ksp_ew_rtolmax", "0.1", "-snes_ksp_ew_rtol0", "0.1"],
             "sphere MUMPS": ball + mumps, "corners (no contact) MUMPS": ["-msim_fix", "corners"] + mumps, "plane MUMPS": ["-msim_contact_plane", "0,0,1,-0.1", "-msim_friction", "0.3"] + mumps}
    # the trust region (-snes_type ntr: Steihaug-CG, the PD factor as its norm; src/solvers/ntr.cpp)
    # with the same rule (|dx| < 1e-3, 20 iterations), on the PSD-projected Hessian (-msim_psd 1)
    # and on the true, indefinite one (ntr's default, -msim_psd 0)
    ntr = ["-snes_type", "ntr", "-ksp_type", "stcg", "-snes_ksp_ew", "0"]
    pdw = ["-msim_contact_pc_pd_weight"]
    cases.update({"sphere ntr -msim_psd 1": ball + ntr + ["-msim_psd", "1"], "sphere ntr (true Hessian)": ball + ntr + ["-msim_psd", "0"],
                  "sphere ntr -msim_psd 1 -msim_contact_pc_pd_weight": ball + ntr + ["-msim_psd", "1"] + pdw,
                  "sphere ntr (true Hessian) -msim_contact_pc_pd_weight": ball + ntr + ["-msim_psd", "0"] + pdw,
                  "sphere ntr (true Hessian) kappa x 10 -msim_contact_pc_pd_weight": ball + ntr + ["-msim_psd", "0"] + kappa10 + pdw,
                  "sphere ntr -msim_psd 1 kappa x 10 -msim_contact_pc_pd_weight": ball + ntr + ["-msim_psd", "1"] + kappa10 + pdw,
                  "none ntr (true Hessian)": ntr + ["-msim_psd", "0"], "plane ntr (true Hessian)": ["-msim_contact_plane", "0,0,1,-0.1", "-msim_friction", "0.3"] + ntr + ["-msim_psd", "0"]})
    # converged steps: |g| <= 1% of |h^2 m g|_2, the residual gravity alone leaves at the first
    # iterate (h^2 g M / sqrt(nv) for nv equal masses M / nv), no step rule, 300 iterations at most
    conv = ["-msim_step_atol", "0", "-snes_atol", f"{0.01 * G * (1 / 30) ** 2 / int(a.bench_n):.3g}", "-snes_max_it", "300"]
    cases.update({"converged: sphere -msim_contact_pc_pd_weight": ball + pdw + conv, "converged: sphere ntr (true Hessian) -msim_contact_pc_pd_weight": ball + ntr + ["-msim_psd", "0"] + pdw + conv,
                  "converged: sphere ntr -msim_psd 1 -msim_contact_pc_pd_weight": ball + ntr + ["-msim_psd", "1"] + pdw + conv,
                  "converged: sphere ntr (true Hessian)": ball + ntr + ["-msim_psd", "0"] + conv, "converged: sphere": ball + conv,
                  "converged: corners (no contact)": ["-msim_fix", "corners"] + conv, "converged: corners (no contact) ntr (true Hessian)": ["-msim_fix", "corners"] + ntr + ["-msim_psd", "0"] + conv})
    # PD's local-global iterations as Newton's right nonlinear preconditioner (each Newton iteration
    # starts from k fixed PD iterations): PD follows the springs' rotations, which the quadratic
    # model of a compressed drape does not (the "why the first phase is slow" reading)
    for k in (1, 3):
        npc = ["-npc_snes_type", "pd", "-npc_snes_max_it", str(k), "-npc_snes_pd_fixed"]
        cases[f"sphere -msim_contact_pc_pd_weight, {k} PD iterations as NPC"] = ball + pdw + npc
        cases[f"corners (no contact), {k} PD iterations as NPC"] = ["-msim_fix", "corners"] + npc
        cases[f"sphere kappa x 10 -msim_contact_pc_pd_weight, {k} PD iterations as NPC"] = ball + kappa10 + pdw + npc
    if int(a.bench_n) <= 41:
        cases["reference: sphere MUMPS |dx| < 1e-6"] = ball + mumps + ["-msim_step_atol", "1e-6", "-snes_max_it", "300"]
    pick = [c for c in cases if not a.cases or any(c == want for want in a.cases.split(";"))]
    ref = None
    rows = []
    for name in sorted(pick, key=lambda c: not c.startswith("reference")):
        args = cloth + cg + cases[name]
        csv, fin = os.path.join(tmp, "n.csv"), os.path.join(tmp, "final.bin")
        # CPU: the min over --repeat runs of each length, alternated (this host is shared)
        cpu, cpu4 = np.inf, np.inf
        for _ in range(a.repeat):
            rc, err, log, c24 = run(a.msim, args + ["-msim_monitor_csv", csv, "-msim_view_final", "binary:" + fin, "-info", ":snes"])
            _, _, _, c4 = run(a.msim, [x if x != "24" else "4" for x in args])
            cpu, cpu4 = min(cpu, c24), min(cpu4, c4)
        mon = [r for r in read_csv(csv) if int(r["step"]) >= 5] if rc == 0 else []
        col = lambda k: np.array([float(r[k]) for r in mon]) if mon else np.array([np.nan])
        # Newton iterations whose step max_step cut: the energy line search's lines (newtonls),
        # ntr's accepted steps and the trial steps it cut
        searches = [ln for ln in log.splitlines() if "energy line search: lambda" in ln]
        if "ntr" in cases[name]:
            trials = [ln for ln in log.splitlines() if "SNESSolve_NTR(): ntr: rho" in ln or "ntr: step rejected" in ln]
            ncut = sum("ntr: trial step cut to" in ln for ln in log.splitlines())
            searches = ["max_step 1.)"] * (len(trials) - ncut) + ["cut"] * ncut
        x = np.array(msimtest_read(fin)).reshape(-1, 3) if rc == 0 else None
        if name.startswith("reference"):
            ref = x
        gap = float((np.linalg.norm(x - [0.5, 0.5, -0.4], axis=1) - 0.3).min()) if x is not None and "-msim_contact_sphere" in args else float("nan")
        comp = spring_compression(x) if x is not None else (float("nan"),) * 2
        rows.append(dict(n=a.bench_n, case=name, ok=int(rc == 0), cpu_ms_per_step=round(1e3 * (cpu - cpu4) / 20, 2), newton_its_per_step=round(col("nonlinear_its").mean(), 2),
                         cg_its_per_step=round(col("linear_its").mean(), 1), cut_by_max_step=round(sum("max_step 1.)" not in ln for ln in searches) / max(len(searches), 1), 3),
                         steps_at_cap=int((col("nonlinear_its") >= int([x for i, x in enumerate(args) if i and args[i - 1] == "-snes_max_it"][-1])).sum()), mean_gnorm=f"{col('residual').mean():.2e}", contact_fz=round(col("contact_fz")[-5:].mean(), 3),
                         contact_n_last=int(col("contact_n")[-1]) if mon else -1, least_gap_mm=round(1e3 * gap, 4),
                         dropped_curvature_median_m=round(comp[0], 2), dropped_curvature_p90_m=round(comp[1], 2),
                         dist_ref_rms_mm=round(1e3 * float(np.sqrt(((x - ref) ** 2).sum(axis=1).mean())), 2) if ref is not None and x is not None else float("nan"),
                         note="" if rc == 0 else err.strip().splitlines()[-1][:150]))
        print(rows[-1], flush=True)
    path = os.path.join(HERE, a.out or f"newton_n{a.bench_n}.csv")
    if a.cases and os.path.exists(path):  # the rows of the cases run replace theirs, the others stay
        done = {r["case"] for r in rows}
        rows = [r for r in read_csv(path) if r["case"] not in done] + rows
    msimrun.write_csv(path, rows)


def msimtest_read(path):
    """-msim_view_final binary:PATH's numbers (tests/msimtest.read_binary_vec)"""
    sys.path.insert(0, os.path.join(HERE, "..", "..", "tests"))
    import msimtest
    return msimtest.read_binary_vec(path)


def plot(a):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.2))
    if os.path.exists(os.path.join(HERE, "rest.csv")):
        rows = read_csv(os.path.join(HERE, "rest.csv"))
        for name in dict.fromkeys(r["method"] for r in rows):
            rs = [r for r in rows if r["method"] == name and r["ok"] == "1"]
            h = [float(r["h"]) for r in rs]
            axes[0].loglog(h, [max(float(r["force_rel_error"]), 1e-16) for r in rs], "o-", label=name)
            axes[1].semilogx(h, [1e3 * float(r["min_gap_m"]) for r in rs], "o-", label=name)
        axes[0].set(xlabel="h (s)", ylabel="|F_contact - m g| / m g at t = 2 s", title="resting force")
        axes[1].axhline(0, color="k", lw=0.5)
        axes[1].set(xlabel="h (s)", ylabel="least gap to the plane over all frames (mm)", title="penetration: none below 0 but the penalty's")
        axes[0].legend(fontsize=7)
    if os.path.exists(os.path.join(HERE, "friction.csv")):
        rows = read_csv(os.path.join(HERE, "friction.csv"))
        for mu in dict.fromkeys(r["mu"] for r in rows):
            rs = [r for r in rows if r["mu"] == mu]
            t = [float(r["t"]) for r in rs]
            l, = axes[2].plot(t, [float(r["displacement_m"]) for r in rs], "o", ms=3, label=f"mu = {mu}")
            axes[2].plot(t, [float(r["analytic_m"]) for r in rs], "-", color=l.get_color(), lw=0.8)
        axes[2].set(xlabel="t (s)", ylabel="mean displacement down the incline (m)", title="friction, theta = 0.3 (tan = 0.309): dots msim, lines g(sin - mu cos) t^2/2")
        axes[2].title.set_fontsize(8)
        axes[2].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(os.path.join(HERE, "contact.png"), dpi=110)
    print("wrote", os.path.join(HERE, "contact.png"))


def main():
    p = argparse.ArgumentParser()
    p.add_argument("what", nargs="?", default="all")
    p.add_argument("--n", default="11")
    p.add_argument("--bench-n", default="41")
    p.add_argument("--msim", default=msimrun.MSIM)
    p.add_argument("--solvers", help="targets: pd10,newton_cg (default both)")
    p.add_argument("--obstacles", help="targets: none,sphere,mesh (default all)")
    p.add_argument("--cases", help="newton: the cases to run, by name, separated by ';' (default all); their rows replace theirs in the CSV")
    p.add_argument("--repeat", type=int, default=1, help="newton: CPU time as the min over this many runs")
    p.add_argument("--out", help="newton: the CSV to write here (default newton_n<bench-n>.csv)")
    a = p.parse_args()
    tmp = tempfile.mkdtemp(prefix="msim_contact_study_")
    for part, fn in (("rest", rest), ("stability", stability), ("friction", friction), ("targets", targets), ("meshcheck", meshcheck), ("newton", newton)):
        if a.what == part or (a.what == "all" and part != "newton"):  # newton: only by name (minutes at 101)
            fn(a, tmp)
    if a.what in ("plot", "all"):
        plot(a)


if __name__ == "__main__":
    main()
