#!/usr/bin/env python3
"""Self-contact's start check and stall report (-msim_self_contact), at the rank count given:
- a start whose surface passes through itself is refused in one error line naming the elements,
  the same line at every rank count (compared with 1 rank's), with nothing written:
  * a mesh built here (an OFF file): a unit square (triangles (0, 1, 2), (0, 2, 3) in z = 0) and a
    vertical triangle (4, 5, 6) whose edges (4, 5) and (4, 6) cross z = 0 at (0.7, 0.3) and
    (0.8, 0.275), inside triangle (0, 1, 2) (y < x); the square's edges miss the vertical
    triangle. msim names the crossing with the least input ids: edge (4, 5) through (0, 1, 2);
  * examples/cloth_fold.opts at 41 x 41 with its 1 cm perturbation (an edge is 2.5 cm): the
    crossings of its start, found here by an independent segment-triangle test over the start's
    positions (frame 0 of a run without self-contact; runs/tools/intersections.py's test), and the
    one msim names is the least of them by input ids;
- a start closer than the contact distance: the vertical triangle lifted so that vertex 4 is
  0.1 m above the middle of triangle (0, 1, 2) (its closest point, the nearest edge 0.28 m away):
  refused with -msim_self_contact_distance 0.2 ("vertex 4 is 0.1 m from triangle (0, 1, 2)"), runs
  with 0.05 (the start gap follows the contact distance); a start gap above the contact distance
  is refused (the barrier acts only within it, and the halo holds other ranks' elements that far);
- a restart (-msim_restart) is checked at the checkpoint's state, not at the scene's start: the
  vertical triangle starts 0.2 m above the square (held by its corners) and falls through it
  under gravity in a run without self-contact; restarted with -msim_self_contact from its
  checkpoint at step 15 (vertex 4 0.27 m below the square, edges (4, 5) and (4, 6) through
  triangle (0, 1, 2)) it is refused in one line naming the checkpoint's state, its file and step,
  and the crossing (before the fix every restart ran, locked through itself); from step 5 (vertex 4
  0.14 m above the square) with -msim_self_contact_distance 0.2 it is refused with
  -msim_self_contact_start_gap 0.2 and runs without (a checkpoint of a run with self-contact
  rests in contact within dhat: at a restart the gap is 0 by default, tests/self_contact_restart.py);
- a gap of 0 (a restart's default, or given) finds only elements at distance 0, where no smaller gap
  exists: the vertical triangle with vertex 4 on triangle (0, 1, 2), at the start with
  -msim_self_contact_start_gap 0 and restarted from a checkpoint of it at rest (no gravity), is
  refused as touching itself "(distance 0)" without advising a smaller gap (it did: "closer than
  -msim_self_contact_start_gap 0 m ... give a smaller gap");
- a stall is reported: the 41 x 41 cloth with the start check off (-msim_self_contact_start_check
  0, a switch for this test) stays locked through itself; every step's CCD cuts Newton's step to
  nothing with |g| far above its tolerance, and msim must warn that the steps did not converge
  (before the fix they passed as converged on -snes_stol with the cloth frozen), not that they
  converged to a saddle; the same cloth perturbed 5 mm (no crossing: the check passes) has no stall.
Usage: self_contact_start.py path/to/msim [--np N]"""
import os
import sys
import tempfile

import numpy as np

import msimtest as mt

sys.path.insert(0, os.path.join(mt.ROOT, "runs", "tools"))
import intersections  # noqa: E402
import vtu  # noqa: E402

FOLD = ["-options_file", os.path.join(mt.ROOT, "examples", "cloth_fold.opts"), "-msim_cloth_n", "41"]
SQUARE = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)]
ON_SQUARE = (0.75, 0.25)  # vertex 4 there at z = 0: on triangle (0, 1, 2), its distance exactly 0


def restarts(check, exe, tmp, np_):
    """the falling triangle's checkpoints, written without self-contact, restarted with it"""
    fall = os.path.join(tmp, "fall.off")
    write_off(fall, 0.2)
    scene = ["-msim_scene", "mesh", "-msim_mesh_file", fall, "-msim_fix", "list", "-msim_fix_list", "0,1,2,3", "-msim_gravity", "0,0,-9.81",
             "-msim_integrator", "implicit_euler", "-msim_dt", "0.02"]
    for step in (5, 15):
        ck = os.path.join(tmp, f"fall_{step}_{np_}.ck")
        r = mt.run(exe, scene + ["-msim_steps", str(step), "-msim_checkpoint", ck], np_)
        if not check(r.returncode == 0 and os.path.exists(ck), f"np {np_}: the triangle falls {step} steps without self-contact ({r.stderr.strip()[-300:]})"):
            return
        restart = scene + ["-msim_steps", "20", "-msim_restart", ck, "-msim_self_contact"]
        state = f"in the checkpoint's state (-msim_restart {ck}: step {step}, t = "
        if step == 15:
            refused(check, exe, restart, np_, os.path.join(tmp, f"restart_cross_{np_}"),
                    ["-msim_self_contact: the surface passes through itself " + state, "edge (4, 5) passes through triangle (0, 1, 2)"], "restart through the square")
            continue
        restart += ["-msim_self_contact_distance", "0.2"]
        refused(check, exe, restart + ["-msim_self_contact_start_gap", "0.2"], np_, os.path.join(tmp, f"restart_touch_{np_}"),
                ["-msim_self_contact: the surface touches itself " + state, "vertex 4 is 0.14", "m from triangle (0, 1, 2)", "-msim_self_contact_start_gap 0.2"], "restart near the square")
        r = mt.run(exe, restart, np_)
        check(r.returncode == 0, f"np {np_}: the same restart without a start gap runs ({r.stderr.strip()[-300:]})")
    # vertex 4 on the square, at rest: its checkpoint touches at distance 0, the restart's default gap
    on = os.path.join(tmp, "on.off")
    write_off(on, 0.0, ON_SQUARE)
    scene = ["-msim_scene", "mesh", "-msim_mesh_file", on, "-msim_fix", "list", "-msim_fix_list", "0,1,2,3", "-msim_gravity", "0,0,0",
             "-msim_integrator", "implicit_euler", "-msim_dt", "0.02"]
    ck = os.path.join(tmp, f"on_{np_}.ck")
    r = mt.run(exe, scene + ["-msim_steps", "2", "-msim_checkpoint", ck], np_)
    if check(r.returncode == 0 and os.path.exists(ck), f"np {np_}: the triangle on the square rests 2 steps without self-contact ({r.stderr.strip()[-300:]})"):
        refused(check, exe, scene + ["-msim_steps", "4", "-msim_restart", ck, "-msim_self_contact"], np_, os.path.join(tmp, f"restart_on_{np_}"),
                ["-msim_self_contact: the surface touches itself (distance 0) in the checkpoint's state (-msim_restart " + ck + ": step 2", "vertex 4 is 0"],
                "restart touching at distance 0", absent=["smaller gap", "start_gap"])


def write_off(path, z0, xy=(0.7, 0.3)):
    """the square and the vertical triangle, its lowest vertex 4 at height z0 over xy"""
    pts = SQUARE + [(xy[0], xy[1], z0), (xy[0], xy[1], z0 + 1), (0.9, 0.25, z0 + 1)]
    with open(path, "w") as f:
        f.write(f"OFF\n{len(pts)} 3 0\n")
        f.writelines(f"{p[0]:.17g} {p[1]:.17g} {p[2]:.17g}\n" for p in pts)
        f.write("3 0 1 2\n3 0 2 3\n3 4 5 6\n")


def crossings(x, tris):
    """(edge, triangle) input-id tuples, sorted, of every edge that passes through a triangle it
    shares no vertex with"""
    found = set()
    P = intersections.candidate_pairs(x, tris)
    for s, o in ((0, 1), (1, 0)):
        A, B = tris[P[:, s]], tris[P[:, o]]
        for k in range(3):
            p, q = A[:, k], A[:, (k + 1) % 3]
            hit = intersections.segments_hit(x[p], x[q], x[B[:, 0]], x[B[:, 1]], x[B[:, 2]])
            for i in np.nonzero(hit)[0]:
                found.add(tuple(sorted((int(p[i]), int(q[i])))) + tuple(sorted(int(v) for v in B[i])))
    return sorted(found)


def refused(check, exe, args, np_, out, words, label, absent=()):
    """one error line holding words and none of absent, nothing written, and at np_ > 1 the same
    line as at 1 rank"""
    r = mt.run(exe, args + ["-msim_output", out], np_)
    err = mt.lines(r.stderr)
    check(r.returncode != 0 and len(err) == 1 and all(w in err[0] for w in words) and not any(w in err[0] for w in absent),
          f"np {np_}: {label}: refused in one line naming {words}{f', not {absent}' if absent else ''} ({err})")
    check(not os.path.exists(out), f"np {np_}: {label}: nothing written ({out})")
    if np_ > 1 and err:
        one = mt.lines(mt.run(exe, args + ["-msim_output", out], 1).stderr)
        check(one == err[:1], f"np {np_}: {label}: the same line as at 1 rank ({one})")


def main():
    exe = mt.msim_path()
    check = mt.Checks()
    tmp = tempfile.mkdtemp(prefix="msim_self_contact_start_")
    cross, touch = os.path.join(tmp, "cross.off"), os.path.join(tmp, "touch.off")
    write_off(cross, -0.5)
    write_off(touch, 0.1)
    mesh = ["-msim_scene", "mesh", "-msim_integrator", "implicit_euler", "-msim_steps", "2", "-msim_self_contact"]
    # the cloth's start, and its crossings, independently of msim's check
    r = mt.run(exe, FOLD + ["-msim_self_contact", "0", "-msim_steps", "1", "-msim_output", os.path.join(tmp, "start")])
    first_crossing = None
    if check(r.returncode == 0, f"the 41 x 41 cloth without self-contact runs ({r.stderr.strip()[-300:]})"):
        x0 = vtu.read_vtu(vtu.read_pvd(os.path.join(tmp, "start", "series.pvd"))[0][1])["points"]
        found = crossings(x0, intersections.cloth_triangles(len(x0)))
        if check(len(found) > 0, f"the 41 x 41 cloth's start crosses itself ({len(found)} edge-triangle crossings)"):
            first_crossing = found[0]
    for np_ in mt.ranks():
        refused(check, exe, mesh + ["-msim_mesh_file", cross], np_, os.path.join(tmp, f"cross_{np_}"),
                ["-msim_self_contact", "passes through itself at the start", "edge (4, 5) passes through triangle (0, 1, 2)"], "crossing mesh")
        refused(check, exe, mesh + ["-msim_mesh_file", touch, "-msim_self_contact_distance", "0.2"], np_, os.path.join(tmp, f"touch_{np_}"),
                ["touches itself at the start", "vertex 4 is 0.1 m from triangle (0, 1, 2)", "-msim_self_contact_start_gap 0.2"], "touching mesh")
        on = os.path.join(tmp, "on_start.off")
        write_off(on, 0.0, ON_SQUARE)
        refused(check, exe, mesh + ["-msim_mesh_file", on, "-msim_self_contact_start_gap", "0"], np_, os.path.join(tmp, f"on_{np_}"),
                ["touches itself (distance 0) at the start", "vertex 4 is 0", "from triangle (0, 1, 2)"], "vertex on a triangle, start gap 0", absent=["smaller gap"])
        r = mt.run(exe, mesh + ["-msim_mesh_file", touch, "-msim_self_contact_distance", "0.05"], np_)
        check(r.returncode == 0, f"np {np_}: the same mesh with a contact distance of 0.05 m (< 0.1 m) runs ({r.stderr.strip()[-300:]})")
        refused(check, exe, mesh + ["-msim_mesh_file", touch, "-msim_self_contact_distance", "0.05", "-msim_self_contact_start_gap", "0.2"], np_,
                os.path.join(tmp, f"gap_{np_}"), ["-msim_self_contact_start_gap", "above the contact distance"], "a start gap above dhat")
        if first_crossing:
            e, t = first_crossing[:2], first_crossing[2:]
            refused(check, exe, FOLD + ["-msim_steps", "1"], np_, os.path.join(tmp, f"cloth_{np_}"),
                    ["passes through itself at the start", f"edge ({e[0]}, {e[1]}) passes through triangle ({t[0]}, {t[1]}, {t[2]})"], "41 x 41 cloth")
        restarts(check, exe, tmp, np_)
        # the stall report
        r = mt.run(exe, FOLD + ["-msim_self_contact_start_check", "0", "-msim_steps", "2"], np_)
        err = mt.lines(r.stderr)
        stall = [l for l in err if "steps the solve stalled and did not converge" in l]
        check(r.returncode == 0 and len(stall) == 1 and "in 2 of 2 steps" in stall[0], f"np {np_}: the locked cloth's 2 steps are reported as stalled ({stall or err[-3:]})")
        check(not any("saddle" in l for l in err), f"np {np_}: and not as converged to a saddle point")
        r = mt.run(exe, FOLD + ["-msim_perturb", "0.005", "-msim_steps", "2"], np_)
        err = mt.lines(r.stderr)
        check(r.returncode == 0 and not any("stalled" in l for l in err), f"np {np_}: perturbed 5 mm (no crossing) it runs with no stall ({err[-3:]})")
    return check.exit_code()


if __name__ == "__main__":
    sys.exit(main())
