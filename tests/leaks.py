#!/usr/bin/env python3
"""No leak: PETSc's -malloc_debug -malloc_dump lists every block still allocated at PetscFinalize;
runs that go through each part of msim (explicit and implicit integrators, PD, Newton with MUMPS
and GAMG, SLEPc's spectrum, the .vtu and HDF5 series, monitors, checkpoint and restart, a Gmsh
mesh, refinement) at 1 and 2 ranks must list none (or with `--np N` at N alone: ctest's leaks_np1
and _np2, the 1-rank half beside other tests)."""
import os
import re
import sys
import tempfile

import msimtest as mt

MSIM = mt.msim_path()
ROOT = mt.ROOT
RUNS = {
    "explicit, vtu series, monitor": "-msim_cloth_n 8 -msim_steps 20 -msim_output {d}/a -msim_output_every 5 -msim_monitor_csv {d}/a.csv",
    "pd anderson, checkpoint": "-msim_cloth_n 8 -msim_integrator implicit_euler -snes_type pd -snes_pd_anderson 5 -msim_steps 4 -msim_checkpoint {d}/c.ck -msim_monitor_convergence {d}/conv.csv",
    "restart": "-msim_cloth_n 8 -msim_integrator implicit_euler -snes_type pd -snes_pd_anderson 5 -msim_steps 6 -msim_restart {d}/c.ck",
    "newton mumps, spectrum": "-msim_scene chain -msim_integrator implicit_euler -ksp_type preonly -pc_type cholesky -pc_factor_mat_solver_type mumps -msim_steps 3 -msim_spectrum",
    "tet box, newton cg gamg, hdf5": "-msim_scene box -msim_box_n 3,3,3 -msim_fix_plane x_min -msim_young 1e6 -msim_density 1000 -msim_integrator implicit_euler -ksp_type cg -pc_type gamg -msim_steps 2 -msim_output {d}/h -msim_output_format hdf5",
    "gmsh mesh, refined, pd mumps": "-msim_scene tet -msim_mesh_file " + os.path.join(ROOT, "examples", "meshes", "beam.msh") + " -msim_refine 1 -msim_fix_plane x_min -msim_integrator implicit_euler -snes_type pd -msim_steps 2",
}
LEAK = re.compile(r"^\[\s*\d+\]\s*\d+ bytes ", re.M)


def main():
    check = mt.Checks()
    for np in mt.ranks():
        with tempfile.TemporaryDirectory() as d:
            for name, args in RUNS.items():
                r = mt.run(MSIM, args.format(d=d).split() + ["-malloc_debug", "-malloc_dump"], np)
                leaks = LEAK.findall(r.stdout + r.stderr)
                if not check(r.returncode == 0 and not leaks, f"np={np} {name}: rc {r.returncode}, {len(leaks)} blocks left"):
                    print((r.stdout + r.stderr)[-1500:])
    return check.exit_code()


if __name__ == "__main__":
    sys.exit(main())
