#!/usr/bin/env python3
"""Bad input: each case must exit non-zero with exactly one line on stderr, 'msim: error: ...',
naming the option (and the allowed range) or the options file (and its line), and must not create
the output directory. A misspelled option must be named in one warning line, and so must implicit
steps cut off by -snes_max_it; an implicit solve that fails is named with PETSc's reason, and its convergence history is kept. A run that diverges must keep the frames written before it and the
last finite state. Every case runs at 1 rank, and at 2 all but those ONE_RANK lists (each refused by
the same check as a case kept there); with `--np N` at N alone (ctest's bad_input_np1 and _np2: the
1-rank half runs beside other tests); the diverging run at 1 rank only.
Usage: bad_input.py path/to/msim [--np N]"""
import os
import re
import sys
import tempfile

import msimtest as mt

MSIM = mt.msim_path()
CASES = [
    (["-msim_dt", "0"], "-msim_dt must be > 0"),
    (["-msim_dt", "-1e-3"], "-msim_dt must be > 0"),
    (["-msim_steps", "0"], "-msim_steps must be >= 1"),
    (["-msim_mass", "0"], "-msim_mass must be > 0"),
    (["-msim_mass", "-2"], "-msim_mass must be > 0"),
    (["-msim_stiffness", "0"], "-msim_stiffness must be > 0"),
    (["-msim_stiffness_shear", "-5"], "-msim_stiffness_shear must be > 0"),
    (["-msim_scene", "torus"], "-msim_scene torus is not known (use cloth, chain, tet, mesh or box)"),
    (["-msim_integrator", "leapfrog"], "-msim_integrator leapfrog is not known (use explicit_euler, symplectic_euler, rk4, ts, implicit_euler"),
    (["-msim_fix", "list", "-msim_fix_list", "3,400"], "-msim_fix_list: vertex 400 is out of range [0, 399]"),
    (["-msim_fix", "list", "-msim_fix_list", "-1"], "-msim_fix_list: vertex -1 is out of range"),
    (["-msim_fix", "list"], "-msim_fix list needs -msim_fix_list"),
    (["-msim_cloth_n", "1"], "-msim_cloth_n must be >= 2"),
    (["-msim_scene", "chain", "-msim_chain_n", "1"], "-msim_chain_n must be >= 2"),
    (["-msim_springs", "structural,twist"], "-msim_springs: unknown family 'twist'"),
    (["-msim_gravity", "0,1"], "-msim_gravity needs three"),
    # extra values were dropped silently (PETSc reads as many as the array holds)
    (["-msim_gravity", "0,0,-9.81,1"], "-msim_gravity needs three comma-separated numbers x,y,z (got 4 or more)"),
    (["-msim_fix_velocity", "1,2,3,4"], "-msim_fix_velocity needs three comma-separated numbers x,y,z (got 4 or more)"),
    (["-msim_wind", "1,2,3,4", "-msim_drag", "1"], "-msim_wind needs three comma-separated numbers x,y,z (got 4 or more)"),
    (["-msim_scene", "box", "-msim_box_size", "1,1,1,7"], "-msim_box_size needs three comma-separated numbers lx,ly,lz (got 4 or more)"),
    (["-msim_scene", "box", "-msim_box_n", "2,2,2,2"], "-msim_box_n needs three comma-separated integers nx,ny,nz (got 4 or more)"),
    (["-msim_fix_box", "0,0.1,0,1,0,1,9"], "-msim_fix_box needs six comma-separated numbers x0,x1,y0,y1,z0,z1 (got 7 or more)"),
    (["-msim_wind", "1,0,0"], "-msim_wind acts through air drag"),
    (["-msim_drag", "-1"], "-msim_drag must be >= 0"),
    (["-msim_partition", "random"], "-msim_partition random is not known"),
    (["-msim_output_every", "0"], "-msim_output_every must be >= 1"),
    # values PETSc cannot convert: the line names the option
    (["-msim_dt", "abc"], "-msim_dt: 'abc' is not a number"),
    # a numeric option with no value (PETSc would leave it unset and run on silently)
    (["-msim_integrator", "implicit_euler", "-snes_type", "pd", "-snes_pd_anderson"], "-snes_pd_anderson needs a value (an integer)"),
    (["-msim_steps", "3", "-msim_dt"], "-msim_dt needs a value (a number)"),
    (["-msim_cloth_n", "2.5"], "-msim_cloth_n: '2.5' is not an integer"),
    (["-msim_integrator", "implicit_euler", "-msim_psd", "maybe"], "-msim_psd: 'maybe' is not true or false"),
    # numbers PETSc would take: infinities, NaN, integers past PetscInt; an item of a list
    (["-msim_dt", "inf"], "-msim_dt: 'inf' is not a finite number"),
    (["-msim_stiffness", "nan"], "-msim_stiffness: 'nan' is not a finite number"),
    (["-msim_gravity", "0,0,-1e999"], "-msim_gravity: '-1e999' is not a finite number"),
    (["-msim_steps", "99999999999999999999"], "-msim_steps: '99999999999999999999' is too large"),
    (["-msim_wind", "a,b,c", "-msim_drag", "1"], "-msim_wind: 'a' is not a number"),
    (["-msim_fix", "list", "-msim_fix_list", "1,x"], "-msim_fix_list: 'x' is not an integer"),
    (["-msim_checkpoint_every", "10"], "-msim_checkpoint_every needs -msim_checkpoint F"),
    # found at set-up, not at the first checkpoint after -msim_checkpoint_every steps of output
    (["-msim_checkpoint", "no_such_dir/run.ck", "-msim_checkpoint_every", "200"], "-msim_checkpoint no_such_dir/run.ck: cannot write no_such_dir/run.ck.tmp"),
    (["-msim_progress", "-1"], "-msim_progress must be >= 0 s"),
    # scene data with nothing to simulate; output that cannot be written
    (["-msim_scene", "chain", "-msim_chain_n", "2", "-msim_fix", "corners"], "every vertex of the chain scene is fixed: nothing to simulate"),
    (["-msim_cloth_n", "2", "-msim_springs", "bending"], "the cloth scene has no springs"),
    (["-msim_output", "/proc/msim_cannot/out"], "-msim_output: cannot create or write directory /proc/msim_cannot/out"),
    # monitor files are opened after the output directory is made (they may live in it), and a
    # refusal takes the new directory away again
    (["-msim_monitor_csv", "/proc/msim_cannot/m.csv"], "-msim_monitor_csv: cannot write /proc/msim_cannot/m.csv"),
    (["-msim_integrator", "implicit_euler", "-msim_monitor_convergence", "/proc/msim_cannot/c.csv"], "-msim_monitor_convergence: cannot write /proc/msim_cannot/c.csv"),
    (["-msim_integrator", "implicit_euler", "-msim_step_atol", "-1"], "-msim_step_atol must be >= 0"),
    # inertia correction reads the inertia of MUMPS's LDL^T of the exact Hessian: nothing else has it
    (["-msim_integrator", "implicit_euler", "-msim_inertia_correction"], "-msim_inertia_correction needs Newton on the exact Hessian factored by MUMPS"),
    # msim's options that only some SNES types read, set for one that does not: pd, or pd as the
    # nonlinear preconditioner of a type with no linear solves, ran the same steps without them
    (["-msim_integrator", "implicit_euler", "-snes_type", "pd", "-msim_psd", "1"], "-msim_psd with -snes_type pd is not supported: it projects the Hessian's blocks, and this SNES assembles none"),
    (["-msim_integrator", "implicit_euler", "-snes_type", "pd", "-msim_pc_pd"], "-msim_pc_pd with -snes_type pd is not supported: it preconditions the SNES's linear solves, and this one solves none"),
    (["-msim_integrator", "implicit_euler", "-snes_type", "anderson", "-npc_snes_type", "pd", "-msim_psd", "0"], "-msim_psd with -snes_type anderson -npc_snes_type pd is not supported"),
    (["-msim_integrator", "implicit_euler", "-snes_type", "qn", "-snes_qn_scale_type", "jacobian", "-msim_psd", "1"], "-msim_psd with -snes_type qn is not supported: it projects the Hessian's blocks, and this SNES assembles none (qn's Jacobian is the constant PD matrix unless a -pc_type is given)"),
    (["-msim_integrator", "implicit_euler", "-msim_psd_fallback"], "-msim_psd_fallback with -snes_type newtonls and -msim_psd 1 is not supported"),
    # the PD factor takes the preconditioner's place: a -pc_type given with it went unused
    (["-msim_integrator", "implicit_euler", "-ksp_type", "cg", "-pc_type", "jacobi", "-msim_pc_pd"], "-msim_pc_pd replaces the preconditioner: drop -pc_type jacobi or -msim_pc_pd"),
    (["-msim_integrator", "implicit_euler", "-snes_type", "qn", "-snes_qn_scale_type", "jacobian", "-pc_type", "lu", "-msim_pc_pd", "1"], "-msim_pc_pd replaces the preconditioner: drop -pc_type lu or -msim_pc_pd"),
    (["-msim_integrator", "implicit_euler", "-snes_type", "pd", "-msim_check_saddle", "0"], "-msim_check_saddle with -snes_type pd is not supported here: it reads the inertia of Newton's factor"),
    # a type's own options (PETSc's and msim's) given for another type, or under -npc_ with no
    # nonlinear preconditioner: nothing read them
    (["-msim_integrator", "implicit_euler", "-snes_type", "newtonls", "-snes_pd_fixed"], "-snes_pd_fixed with -snes_type newtonls is not supported: only the type pd reads it"),
    (["-msim_integrator", "implicit_euler", "-snes_type", "anderson", "-npc_snes_type", "pd", "-snes_pd_anderson", "2"], "-snes_pd_anderson with -snes_type anderson is not supported: only the type pd reads it (the nonlinear preconditioner's take its prefix: -npc_snes_pd_anderson)"),
    (["-msim_integrator", "implicit_euler", "-npc_snes_pd_fixed"], "-npc_snes_pd_fixed is not supported without a nonlinear preconditioner"),
    (["-msim_integrator", "implicit_euler", "-snes_type", "anderson", "-npc_snes_type", "newtonls", "-npc_snes_pd_fixed"], "-npc_snes_pd_fixed with -npc_snes_type newtonls is not supported: only the type pd reads it"),
    (["-msim_integrator", "implicit_euler", "-snes_type", "pd", "-snes_qn_m", "3"], "-snes_qn_m with -snes_type pd is not supported: only the type qn reads it"),
    (["-msim_integrator", "implicit_euler", "-snes_type", "pd", "-snes_anderson_m", "3"], "-snes_anderson_m with -snes_type pd is not supported: only the type anderson reads it"),
    (["-msim_integrator", "implicit_euler", "-snes_type", "qn", "-snes_ntr_eta", "0.1"], "-snes_ntr_eta with -snes_type qn is not supported: only the type ntr reads it"),
    (["-msim_integrator", "implicit_euler", "-snes_type", "pd", "-snes_pd_lbfgs_fused", "0"], "-snes_pd_lbfgs_fused without -snes_pd_lbfgs m > 0 is not supported"),
    # solver types and solver options, PD's global step's among them, are read while the
    # integrator sets up, before any output; a type PETSc does not know is named with its option
    (["-msim_integrator", "implicit_euler", "-snes_type", "newton"], "-snes_type: 'newton' is not a SNES type"),
    (["-msim_integrator", "implicit_euler", "-ksp_type", "cgg"], "-ksp_type: 'cgg' is not a KSP type"),
    (["-msim_integrator", "implicit_euler", "-snes_type", "pd", "-pd_ksp_type", "cgg"], "-pd_ksp_type: 'cgg' is not a KSP type"),
    (["-msim_integrator", "implicit_euler", "-snes_type", "anderson", "-npc_snes_type", "pd", "-pd_pc_type", "lu2"], "-pd_pc_type: 'lu2' is not a PC type"),
    # SNES types that need what msim's problem does not give are named before any output (PETSc
    # stopped at the first solve with its own words)
    (["-msim_integrator", "implicit_euler", "-snes_type", "ngs"], "-snes_type ngs is not supported: it needs a coloring of an AIJ Jacobian"),
    (["-msim_integrator", "implicit_euler", "-snes_type", "aspin"], "the nonlinear preconditioner's type (-npc_snes_type, or -snes_type aspin's) nasm is not supported"),
    (["-msim_integrator", "implicit_euler", "-snes_type", "composite"], "-snes_type composite needs its solvers: -snes_composite_sneses"),
    (["-msim_integrator", "implicit_euler", "-snes_type", "composite", "-snes_composite_sneses", "pd,ngs"], "-snes_composite_sneses's ngs is not supported"),
    # sub-solvers that solve linear systems got PETSc's dense finite-difference Jacobian, not msim's
    (["-msim_integrator", "implicit_euler", "-snes_type", "composite", "-snes_composite_sneses", "pd,newtonls"], "-snes_composite_sneses's newtonls is not supported: msim gives its analytic Jacobian to the outer solver only"),
    (["-msim_integrator", "implicit_euler", "-snes_type", "anderson", "-npc_snes_type", "newtonls"], "newtonls is not supported: msim gives its analytic Jacobian to the outer solver only"),
    (["-msim_integrator", "implicit_euler", "-snes_type", "fas"], "-snes_type fas is not supported: msim's problem has one level"),
    (["-msim_integrator", "implicit_euler", "-npc_snes_type", "pd", "-snes_npc_side", "left"], "-snes_npc_side left with -snes_type newtonls is not supported"),
    (["-msim_integrator", "ts", "-ts_type", "beuler", "-snes_type", "nasm"], "-snes_type nasm is not supported: it needs subdomains of a DM"),
    (["-msim_integrator", "ts", "-ts_type", "bdf", "-snes_type", "anderson", "-npc_snes_type", "pd"], "-snes_type pd needs a problem that provides projective-dynamics steps"),
    (["-msim_integrator", "ts", "-ts_type", "beuler", "-snes_type", "ngmres", "-npc_snes_type", "nrichardson"], "-npc_snes_type with -msim_integrator ts is not supported"),
    # PETSc makes a nonlinear preconditioner for any type; pd, ntr and ksponly would ignore it
    (["-msim_integrator", "implicit_euler", "-snes_type", "pd", "-npc_snes_type", "newtonls"], "-npc_snes_type newtonls with -snes_type pd is not supported: pd runs no nonlinear preconditioner"),
    (["-msim_integrator", "implicit_euler", "-snes_type", "ntr", "-npc_snes_type", "pd"], "-npc_snes_type pd with -snes_type ntr is not supported: ntr runs no nonlinear preconditioner"),
    (["-msim_integrator", "implicit_euler", "-snes_type", "pd", "-pd_pc_msimllt_relax", "-1"], "-pd_pc_msimllt_relax must be >= 0"),
    (["-msim_integrator", "implicit_euler", "-snes_type", "pd", "-pd_pc_msimllt_relax", "abc"], "-pd_pc_msimllt_relax: 'abc' is not a number"),
    (["-msim_integrator", "implicit_euler", "-snes_type", "qn", "-snes_qn_scale_type", "jacobian", "-pd_pc_msimllt_max_width", "0"], "-pd_pc_msimllt_max_width must be >= 1"),
    # a friction coefficient with nothing to act on was dropped silently,
    (["-msim_integrator", "implicit_euler", "-msim_friction", "0.5"], "-msim_friction 0.5 acts on nothing"),
    # and so were VI bounds with no obstacle, and a thickness with no mesh obstacle
    (["-msim_integrator", "implicit_euler", "-msim_contact_bounds"], "-msim_contact_bounds has no obstacle to take as bounds"),
    # the penalty integrators ran the penalty and said only that the option was never used
    (["-msim_integrator", "symplectic_euler", "-msim_contact_plane", "0,0,1,-0.1", "-msim_contact_bounds"], "-msim_contact_bounds with -msim_integrator symplectic_euler is not supported"),
    (["-msim_integrator", "ts", "-msim_contact_plane", "0,0,1,-0.1", "-msim_contact_bounds"], "-msim_contact_bounds with -msim_integrator ts is not supported"),
    (["-msim_contact_plane", "0,0,1,-1", "-msim_contact_thickness", "0.01"], "-msim_contact_thickness 0.01 acts on mesh obstacles (-msim_contact_mesh) only"),
    # contact options that act nowhere: read, they escaped the unused-option warning: with no
    # obstacle, the barrier's with the penalty or VI bounds, the penalty's with the barrier,
    # friction's smoothing with no friction
    (["-msim_integrator", "implicit_euler", "-msim_contact_kappa", "10"], "-msim_contact_kappa has no effect without an obstacle (-msim_contact_plane, _sphere, _box or _mesh)"),
    (["-msim_contact_distance", "0.1"], "-msim_contact_distance has no effect without an obstacle"),
    (["-msim_integrator", "implicit_euler", "-msim_contact_pd_refactor", "2"], "-msim_contact_pd_refactor has no effect without an obstacle"),
    (["-msim_integrator", "symplectic_euler", "-msim_contact_plane", "0,0,1,-0.1", "-msim_contact_kappa", "10"], "-msim_contact_kappa with -msim_integrator symplectic_euler is not supported: it tunes the barrier of implicit_euler and bdf2"),
    (["-msim_integrator", "ts", "-msim_contact_plane", "0,0,1,-0.1", "-msim_contact_pd_weight", "0"], "-msim_contact_pd_weight with -msim_integrator ts is not supported"),
    (["-msim_integrator", "implicit_euler", "-msim_contact_plane", "0,0,1,-0.1", "-msim_contact_stiffness", "10"], "-msim_contact_stiffness with -msim_integrator implicit_euler is not supported: it is the penalty's stiffness"),
    (["-msim_integrator", "implicit_euler", "-msim_contact_plane", "0,0,1,-0.1", "-msim_contact_bounds", "-msim_contact_kappa", "5"], "-msim_contact_kappa with obstacles as variable bounds (-msim_contact_bounds, or a VI -snes_type) is not supported"),
    (["-msim_integrator", "implicit_euler", "-msim_contact_plane", "0,0,1,-0.1", "-msim_friction_eps", "0.5"], "-msim_friction_eps has no effect without -msim_friction"),
    # the barrier's PD and Newton options where the run's solver takes none of them (exit 0 without
    # a word): decided from what the run uses (-msim_pc_pd is ntr's default; ACCEPTED keeps the uses)
    (["-msim_integrator", "implicit_euler", "-msim_contact_plane", "0,0,1,-0.1", "-msim_contact_pc_pd_weight"], "-msim_contact_pc_pd_weight with -snes_type newtonls is not supported: it puts the barrier's weights in the PD factor"),
    (["-msim_integrator", "implicit_euler", "-msim_contact_plane", "0,0,1,-0.1", "-snes_type", "pd", "-msim_contact_pc_pd_weight"], "-msim_contact_pc_pd_weight with -snes_type pd is not supported"),
    (["-msim_integrator", "implicit_euler", "-msim_contact_plane", "0,0,1,-0.1", "-msim_pc_pd", "-msim_contact_pc_pd_weight", "-msim_contact_pd_weight", "0"], "-msim_contact_pc_pd_weight with -msim_contact_pd_weight 0 is not supported"),
    (["-msim_integrator", "implicit_euler", "-msim_contact_plane", "0,0,1,-0.1", "-msim_contact_pd_weight", "0"], "-msim_contact_pd_weight with -snes_type newtonls is not supported: it sets the barrier's weights in PD's matrix"),
    (["-msim_integrator", "implicit_euler", "-msim_contact_plane", "0,0,1,-0.1", "-snes_type", "pd", "-msim_contact_psd_curvature", "0"], "-msim_contact_psd_curvature with -snes_type pd is not supported: it clamps the barrier's curvature in the PSD-projected Hessian"),
    (["-msim_integrator", "implicit_euler", "-msim_contact_plane", "0,0,1,-0.1", "-snes_type", "ntr", "-msim_contact_psd_curvature", "0"], "-msim_contact_psd_curvature with -snes_type ntr -msim_psd 0 is not supported"),
    (["-msim_integrator", "implicit_euler", "-msim_contact_plane", "0,0,1,-0.1", "-msim_contact_pd_refactor", "2"], "-msim_contact_pd_refactor with -snes_type newtonls is not supported: it says when the barrier's weights in PD's matrix are refactored"),
    (["-msim_integrator", "implicit_euler", "-msim_contact_plane", "0,0,1,-0.1", "-snes_type", "pd", "-msim_contact_pd_weight", "0", "-msim_contact_pd_refactor", "2"], "-msim_contact_pd_refactor with -snes_type pd -msim_contact_pd_weight 0 is not supported"),
    (["-msim_integrator", "implicit_euler", "-msim_contact_plane", "0,0,1,-0.1", "-msim_contact_pd_bound", "0"], "-msim_contact_pd_bound with -snes_type newtonls is not supported: it sets how PD's global step"),
    (["-msim_integrator", "implicit_euler", "-msim_contact_plane", "0,0,1,-0.1", "-msim_contact_pd_refactor_selective", "3"], "-msim_contact_pd_refactor_selective with -snes_type newtonls is not supported"),
    (["-msim_integrator", "implicit_euler", "-msim_contact_plane", "0,0,1,-0.1", "-snes_type", "pd", "-msim_contact_pd_refactor", "0", "-msim_contact_pd_refactor_selective", "3"], "-msim_contact_pd_refactor_selective with -snes_type pd -msim_contact_pd_refactor 0 is not supported"),
    # absurd but finite contact values: their products overflowed or fell below the coordinates'
    # roundoff, and the run failed steps later in the solver (DIVERGED_FNORM_NAN, "diverged"),
    # naming no option, its frames written
    (["-msim_integrator", "implicit_euler", "-msim_contact_sphere", "0.43,0.52,-0.35,0.3", "-msim_contact_kappa", "1e300"], "-msim_contact_kappa must be 0 (the default) or in ["),
    (["-msim_integrator", "implicit_euler", "-msim_contact_sphere", "0.43,0.52,-0.35,0.3", "-msim_friction", "1e300"], "-msim_friction must be in [0, 6.71089e+07]"),
    (["-msim_integrator", "implicit_euler", "-msim_contact_sphere", "0.43,0.52,-0.35,0.3", "-msim_friction", "0.3", "-msim_friction_eps", "1e-300"], "-msim_friction_eps must be >= "),
    (["-msim_integrator", "implicit_euler", "-msim_contact_plane", "0,0,1,-0.1", "-msim_contact_velocity", "0,0,1e300"], "-msim_contact_velocity: obstacle 0's speed must be <= "),
    # the penalty's integrators took it, and their state was not finite at step 10, the frames written
    (["-msim_integrator", "symplectic_euler", "-msim_contact_plane", "0,0,1,-0.1", "-msim_contact_velocity", "0,0,1e300"], "-msim_contact_velocity: obstacle 0's speed must be <= 4.74531e+09 m/s here, a travel in a step (h = 0.0002 s)"),
    (["-msim_integrator", "explicit_euler", "-msim_drag", "1", "-msim_contact_sphere", "0.5,0.5,-0.4,0.3", "-msim_contact_velocity", "-1e300,0,0"], "-msim_contact_velocity: obstacle 0's speed must be <= "),
    (["-msim_integrator", "rk4", "-msim_contact_box", "0,1,0,1,-1,-0.2", "-msim_contact_velocity", "0,1e20,0"], "-msim_contact_velocity: obstacle 0's speed must be <= "),
    (["-msim_integrator", "ts", "-ts_type", "beuler", "-msim_contact_plane", "0,0,1,-0.1", "-msim_contact_velocity", "0,0,1e300"], "-msim_contact_velocity: obstacle 0's speed must be <= "),
    (["-msim_integrator", "implicit_euler", "-msim_contact_sphere", "0.43,0.52,-0.35,0.3", "-msim_contact_distance", "1e-9"], "-msim_contact_distance must be >= 1.49012e-08 m here"),
    # a plane whose offset over its normal's length overflows (its normal, scaled by its largest
    # component, no longer does); a mesh obstacle whose lengths overflow was refused as of zero length
    (["-msim_contact_plane", "0,0,1e-200,1e200"], "-msim_contact_plane: obstacle 0's offset 1e+200 over its normal's length 1e-200 overflows"),
    (["-msim_contact_mesh", "huge.obj"], "huge.obj: the coordinates span [0., 1e+300] x [0., 1e+300] x [-0.5, -0.5], a diagonal beyond"),
    # a vertex on a box's edge (distance -0) was "inside" for the barrier, and on it for the penalty
    (["-msim_integrator", "implicit_euler", "-msim_fix", "none", "-msim_cloth_n", "11", "-msim_contact_box", "0.9,2,0.9,2,-1,0"], "vertex 108 starts at distance 0. from obstacle 0 (-msim_contact_box), below 1e-6 of the contact distance"),
    # qn's Broyden directions need not descend the energy the feasible line search backtracks on:
    # the run failed at step 2 of a cloth the plane had not yet met
    (["-msim_integrator", "implicit_euler", "-snes_type", "qn", "-snes_qn_type", "broyden", "-msim_contact_plane", "0,0,1,-0.1"], "-snes_qn_type broyden with obstacles (-msim_contact_*) is not supported: its directions need not descend the energy"),
    (["-msim_integrator", "implicit_euler", "-snes_type", "qn", "-snes_qn_type", "badbroyden", "-msim_contact_sphere", "0.5,0.5,-0.4,0.3"], "-snes_qn_type badbroyden with obstacles (-msim_contact_*) is not supported"),
    # a list option given twice on the command line kept the last only: the first plane vanished
    (["-msim_integrator", "implicit_euler", "-msim_contact_plane", "0,0,1,-0.1", "-msim_contact_plane", "0,0,1,-0.2"], "the command line gives -msim_contact_plane twice, and only the last would be used: give all of them in one -msim_contact_plane, comma-separated"),
    (["-msim_fix", "list", "-msim_fix_list", "3", "-msim_fix_list", "7"], "the command line gives -msim_fix_list twice"),
    # physics the scene or the integrator cannot take, and options that refine a flag not given:
    # read, they escaped the unused-option warning and did nothing
    (["-msim_volume"], "-msim_volume needs tets: use it with -msim_scene tet or box (scene 'cloth' has none)"),
    (["-msim_volume_stiffness", "5"], "-msim_volume_stiffness has no effect without -msim_volume"),
    (["-msim_scene", "box", "-msim_volume_kappa", "5"], "-msim_volume_kappa has no effect without -msim_volume"),
    (["-msim_self_contact_distance", "0.01"], "-msim_self_contact_distance has no effect without -msim_self_contact"),
    (["-msim_scene", "box", "-msim_volume", "-msim_volume_kappa", "-5"], "-msim_volume_kappa must be >= 0 Pa, or -1 for its default"),
    (["-msim_scene", "box", "-msim_volume", "-msim_volume_stiffness", "-3"], "-msim_volume_stiffness must be >= 0 Pa, or -1 for its default"),
    (["-msim_scene", "box", "-msim_volume", "-msim_integrator", "symplectic_euler"], "-msim_volume's inversion barrier with -msim_integrator symplectic_euler is not supported"),
    (["-msim_scene", "box", "-msim_volume", "-msim_integrator", "ts", "-ts_type", "beuler"], "-msim_volume's inversion barrier with -msim_integrator ts is not supported"),
    # an implicit -ts_type was told "an explicit step has no line search"
    (["-msim_self_contact", "-msim_integrator", "ts", "-ts_type", "beuler"], "-msim_self_contact with -msim_integrator ts is not supported: its steps, explicit or implicit -ts_type, have no line search"),
    (["-msim_self_contact", "-msim_integrator", "symplectic_euler"], "-msim_self_contact with -msim_integrator symplectic_euler is not supported: an explicit step has no line search"),
    (["-msim_integrator", "discrete_gradient", "-msim_psd", "0"], "-msim_psd with -msim_integrator discrete_gradient is not supported"),
    # its Jacobian is not symmetric: a symmetric factorization or CG ran without a word (Cholesky, as
    # examples/box.opts sets: Newton took 183 iterations where LU took 80, energy error 7e-7 for 9e-12)
    (["-msim_integrator", "discrete_gradient", "-ksp_type", "preonly", "-pc_type", "cholesky", "-pc_factor_mat_solver_type", "mumps"],
     "-pc_type cholesky with -msim_integrator discrete_gradient is not supported: it factors a symmetric matrix, and the Jacobian is not symmetric"),
    (["-msim_integrator", "discrete_gradient", "-ksp_type", "cg", "-pc_type", "icc"], "-ksp_type cg with -msim_integrator discrete_gradient is not supported: it needs a symmetric matrix"),
    (["-msim_integrator", "discrete_gradient", "-ksp_type", "minres", "-pc_type", "jacobi"], "-ksp_type minres with -msim_integrator discrete_gradient is not supported"),
    (["-msim_integrator", "discrete_gradient", "-pc_type", "icc"], "-pc_type icc with -msim_integrator discrete_gradient is not supported: it factors a symmetric matrix"),
    (["-msim_integrator", "discrete_gradient", "-pc_type", "bjacobi", "-sub_pc_type", "icc"], "-sub_pc_type icc with -msim_integrator discrete_gradient is not supported"),
    # nor is vinewtonssls's (the Fischer-Burmeister equation scales J's rows near a bound): under
    # examples/cloth_table.opts' Cholesky it diverged at step 6, the energy up by 2043 J, where LU ran
    (["-msim_integrator", "implicit_euler", "-msim_contact_plane", "0,0,1,-0.1", "-snes_type", "vinewtonssls", "-ksp_type", "preonly", "-pc_type", "cholesky", "-pc_factor_mat_solver_type", "mumps"],
     "-pc_type cholesky with -snes_type vinewtonssls is not supported: it factors a symmetric matrix, and the Jacobian is not symmetric"),
    (["-msim_integrator", "implicit_euler", "-msim_contact_plane", "0,0,1,-0.1", "-snes_type", "vinewtonssls", "-ksp_type", "cg"], "-ksp_type cg with -snes_type vinewtonssls is not supported: it needs a symmetric matrix"),
    (["-msim_integrator", "implicit_euler", "-msim_contact_plane", "0,0,1,-0.1", "-snes_type", "vinewtonssls", "-pc_type", "bjacobi", "-sub_pc_type", "icc"], "-sub_pc_type icc with -snes_type vinewtonssls is not supported"),
    # theta 0 failed at the first solve (a NaN residual), after the output was made
    (["-msim_integrator", "ts", "-ts_type", "theta", "-ts_theta_theta", "0"], "-ts_theta_theta must be in (0, 1] (got 0.)"),
    (["-msim_integrator", "ts", "-ts_type", "theta", "-ts_theta_theta", "1.5"], "-ts_theta_theta must be in (0, 1]"),
    # theta below 0.99 (cn: 0.5) weighs the penalty at x_n: a cloth dropped on a sphere gained 42 J from rest, exit 0
    (["-msim_integrator", "ts", "-ts_type", "theta", "-msim_contact_sphere", "0.5,0.5,-0.4,0.3"], "-ts_type theta with theta = 0.5 < 0.99 and an obstacle is not supported"),
    (["-msim_integrator", "ts", "-ts_type", "cn", "-msim_contact_plane", "0,0,1,-0.1"], "-ts_type cn with theta = 0.5 < 0.99 and an obstacle is not supported"),
    (["-msim_integrator", "ts", "-ts_type", "theta", "-ts_theta_theta", "0.95", "-ts_theta_endpoint", "-msim_contact_plane", "0,0,1,-0.1"], "-ts_type theta with theta = 0.95 < 0.99 and an obstacle is not supported"),
    # a negative tolerance turned bdf's error control off in effect (one internal step per -msim_dt)
    (["-msim_integrator", "ts", "-ts_type", "bdf", "-ts_atol", "-1"], "-ts_atol must be >= 0 (got -1.)"),
    # -msim_spectrum alone took the spectrum of inverted tets, whose barrier Hessian K holds (the check was the implicit term's only)
    (["-msim_scene", "box", "-msim_box_n", "3,2,2", "-msim_box_size", "0.3,0.1,0.1", "-msim_fix_plane", "x_min", "-msim_density", "1000", "-msim_young", "5e4",
      "-msim_perturb", "0.1", "-msim_volume", "1", "-msim_spectrum"], "-msim_volume: 32 tets are inverted or flat at the start"),
    # TSSolve's trajectory, adjoint and DM-VTK monitor: read by PETSc (no unused-option warning) and never acted on under msim's TSStep loop, no file, no word
    (["-msim_integrator", "ts", "-ts_type", "beuler", "-ts_save_trajectory"], "-ts_save_trajectory is not supported with -msim_integrator ts"),
    (["-msim_integrator", "ts", "-ts_type", "beuler", "-ts_trajectory_type", "visualization"], "-ts_trajectory_type is not supported with -msim_integrator ts"),
    (["-msim_integrator", "ts", "-ts_type", "beuler", "-ts_adjoint_solve"], "-ts_adjoint_solve is not supported with -msim_integrator ts"),
    (["-msim_integrator", "ts", "-ts_monitor_solution_vtk", "ts-%03d.vts"], "-ts_monitor_solution_vtk is not supported with -msim_integrator ts"),
    # a fixed-step TS reads no error tolerance: both 0 were refused as if an error control read them
    (["-msim_integrator", "ts", "-ts_type", "bdf", "-ts_adapt_type", "none", "-ts_atol", "0", "-ts_rtol", "0"], "-ts_atol is not read by a fixed-step TS"),
    (["-msim_integrator", "ts", "-ts_type", "beuler", "-ts_rtol", "1e-3"], "-ts_rtol is not read by a fixed-step TS"),
    # PETSc counts failed stage solves over the TS's whole life (the run; afresh at a restart), which
    # is not msim's retry count (was accepted: run-wide, and no word of it in the stop's message)
    # read by TSSetFromOptions after msim set it false: a failed step, or a stop signal inside one,
    # became PETSc's bare "TSStep has failed due to DIVERGED_STEP_REJECTED", nothing kept
    # rosw's stages are linear solves: qn iterated without them (1.9 million iterations in 9 steps)
    (["-msim_integrator", "ts", "-ts_type", "rosw", "-snes_type", "qn"], "-snes_type qn with -ts_type rosw is not supported: rosw's stages are linear systems"),
    (["-msim_integrator", "ts", "-ts_type", "beuler", "-ts_error_if_step_fails"], "-ts_error_if_step_fails is not supported by -msim_integrator ts"),
    (["-msim_integrator", "ts", "-ts_type", "beuler", "-ts_max_snes_failures", "3"], "-ts_max_snes_failures is not supported by -msim_integrator ts: PETSc counts failed stage solves over the whole run"),
    # -msim_implicit_terms leaving out a term the scene needs: the feature was dropped silently (a
    # cloth fell through the obstacle while the monitor reported its contact force)
    (["-msim_integrator", "implicit_euler", "-msim_fix", "none", "-msim_contact_plane", "0,0,1,-0.05", "-msim_implicit_terms", "springs"], "-msim_implicit_terms leaves out 'obstacles', the term of the obstacles (-msim_contact_*)"),
    (["-msim_integrator", "implicit_euler", "-msim_fix", "none", "-msim_contact_plane", "0,0,1,-0.05", "-msim_friction", "0.3", "-msim_implicit_terms", "springs,obstacles"], "-msim_implicit_terms leaves out 'friction', the term of -msim_friction with obstacles"),
    (["-msim_integrator", "implicit_euler", "-msim_self_contact", "-msim_implicit_terms", "springs"], "-msim_implicit_terms leaves out 'self_contact', the term of -msim_self_contact"),
    (["-msim_integrator", "implicit_euler", "-msim_self_contact", "-msim_friction", "0.3", "-msim_implicit_terms", "springs,self_friction,self_contact"], "-msim_implicit_terms: 'self_friction' must come after 'self_contact'"),
    (["-msim_scene", "box", "-msim_box_n", "3,2,2", "-msim_fix_plane", "x_min", "-msim_volume", "1", "-msim_integrator", "implicit_euler", "-msim_implicit_terms", "springs"], "-msim_implicit_terms leaves out 'volume', the term of the tets' volume (-msim_volume)"),
    (["-msim_integrator", "implicit_euler", "-msim_drag", "0.1", "-msim_implicit_terms", "springs"], "-msim_implicit_terms leaves out 'drag', the term of -msim_drag"),
    # the spectrum's counts name their option (the eigensolver's check named none; a negative
    # -msim_spectrum_lowest computed no mode without a word); the default cloth has 6 x 6 - 2 free
    (["-msim_spectrum", "-msim_cloth_n", "6", "-msim_spectrum_largest", "0"], "-msim_spectrum_largest must be in [1, 102], the scene's unknowns (got 0)"),
    (["-msim_spectrum", "-msim_cloth_n", "6", "-msim_spectrum_lowest", "-1"], "-msim_spectrum_lowest must be in [0, 102], the scene's unknowns (got -1)"),
    (["-msim_spectrum", "-msim_cloth_n", "6", "-msim_spectrum_lowest", "5000"], "-msim_spectrum_lowest must be in [0, 102]"),
    # the springs too: `-msim_implicit_terms drag -msim_drag 0.1` ran a cloth with drag alone, no note
    (["-msim_integrator", "implicit_euler", "-msim_drag", "0.1", "-msim_implicit_terms", "drag"], "-msim_implicit_terms leaves out 'springs', the term of the scene's springs"),
    # options files, read inside PetscInitialize (written by main() below)
    (["-options_file", "missing.opts"], "-options_file missing.opts: cannot open it"),
    (["-options_file", "malformed.opts"], "malformed.opts line 2: msim_steps"),
]
# preconditioners that cannot work on msim's AIJ matrices, named at set-up (PETSc stopped at the
# first solve in its own words, after the output had begun; cp gave a zero Newton step silently)
CASES += [(["-msim_integrator", "implicit_euler", "-pc_type", pc], f"-pc_type {pc} is not supported: {why}") for pc, why in (
    ("bddc", "it needs a MATIS matrix"), ("nn", "it needs a MATIS matrix"), ("lsc", "it preconditions a Schur complement"),
    ("vpbjacobi", "it needs variable block sizes"), ("shell", "a shell preconditioner's apply is set by code"),
    ("patch", "it needs a DMPlex discretization"), ("composite", "it needs its preconditioners: -pc_composite_pcs"), ("cp", ""))]
CASES.append((["-msim_integrator", "implicit_euler", "-snes_type", "pd", "-pd_pc_type", "bddc"], "-pd_pc_type bddc is not supported: it needs a MATIS matrix"))
# At 2 ranks the cases below are left out: each is refused by the same check (the same line of
# code on the same communicator, at the same stage of the set-up) as a case kept there, every rank
# deciding alike from the options every rank holds. Kept at 2 ranks, one case or more of each kind:
# a value out of range at each stage (integrator, scene, a generator, springs, output, partition,
# the fixed list, the options helper's comm), PETSc's and msim's own conversions (number, integer,
# logical, list, finite, too large, missing value), a type lookup of the run's SNES and of PD's KSP,
# the checks that read distributed data (nothing free, no springs) or rank 0's files (output,
# monitors, checkpoint, options files), each family of solver refusals (unread options, a SNES
# type or its sub-solvers, ts's path, msimllt's options, the implicit integrator's, factorizations
# and PCs on the run's and PD's KSP), the contact options, and PARALLEL_CASES (2 ranks only)
ONE_RANK = {tuple(a) for a in (
    ["-msim_dt", "-1e-3"], ["-msim_steps", "0"], ["-msim_mass", "-2"], ["-msim_stiffness", "0"], ["-msim_integrator", "leapfrog"],
    ["-msim_fix", "list", "-msim_fix_list", "-1"], ["-msim_fix", "list"], ["-msim_scene", "chain", "-msim_chain_n", "1"], ["-msim_springs", "structural,twist"],
    ["-msim_drag", "-1"], ["-msim_steps", "3", "-msim_dt"], ["-msim_cloth_n", "2.5"], ["-msim_stiffness", "nan"], ["-msim_gravity", "0,0,-1e999"],
    ["-msim_fix", "list", "-msim_fix_list", "1,x"], ["-msim_checkpoint_every", "10"], ["-msim_progress", "-1"],
    ["-msim_integrator", "explicit_euler", "-msim_drag", "1", "-msim_contact_sphere", "0.5,0.5,-0.4,0.3", "-msim_contact_velocity", "-1e300,0,0"],
    ["-msim_integrator", "rk4", "-msim_contact_box", "0,1,0,1,-1,-0.2", "-msim_contact_velocity", "0,1e20,0"],
    ["-msim_integrator", "implicit_euler", "-msim_step_atol", "-1"],
    ["-msim_integrator", "discrete_gradient", "-ksp_type", "minres", "-pc_type", "jacobi"], ["-msim_integrator", "discrete_gradient", "-pc_type", "icc"],
    ["-msim_integrator", "implicit_euler", "-snes_type", "pd", "-msim_pc_pd"],
    ["-msim_integrator", "implicit_euler", "-snes_type", "anderson", "-npc_snes_type", "pd", "-msim_psd", "0"],
    ["-msim_integrator", "implicit_euler", "-snes_type", "qn", "-snes_qn_scale_type", "jacobian", "-msim_psd", "1"],
    ["-msim_integrator", "implicit_euler", "-msim_psd_fallback"],
    ["-msim_integrator", "implicit_euler", "-snes_type", "pd", "-msim_check_saddle", "0"],
    ["-msim_integrator", "implicit_euler", "-snes_type", "anderson", "-npc_snes_type", "pd", "-snes_pd_anderson", "2"],
    ["-msim_integrator", "implicit_euler", "-snes_type", "anderson", "-npc_snes_type", "newtonls", "-npc_snes_pd_fixed"],
    ["-msim_integrator", "implicit_euler", "-snes_type", "pd", "-snes_qn_m", "3"],
    ["-msim_integrator", "implicit_euler", "-snes_type", "pd", "-snes_anderson_m", "3"],
    ["-msim_integrator", "implicit_euler", "-snes_type", "qn", "-snes_ntr_eta", "0.1"],
    ["-msim_integrator", "implicit_euler", "-snes_type", "pd", "-snes_pd_lbfgs_fused", "0"],
    ["-msim_integrator", "implicit_euler", "-ksp_type", "cgg"],
    ["-msim_integrator", "implicit_euler", "-snes_type", "anderson", "-npc_snes_type", "pd", "-pd_pc_type", "lu2"],
    ["-msim_integrator", "implicit_euler", "-snes_type", "aspin"],
    ["-msim_integrator", "implicit_euler", "-snes_type", "composite"],
    ["-msim_integrator", "implicit_euler", "-snes_type", "composite", "-snes_composite_sneses", "pd,ngs"],
    ["-msim_integrator", "implicit_euler", "-snes_type", "anderson", "-npc_snes_type", "newtonls"],
    ["-msim_integrator", "implicit_euler", "-snes_type", "fas"],
    ["-msim_integrator", "implicit_euler", "-npc_snes_type", "pd", "-snes_npc_side", "left"],
    ["-msim_integrator", "ts", "-ts_type", "bdf", "-snes_type", "anderson", "-npc_snes_type", "pd"],
    ["-msim_integrator", "ts", "-ts_type", "beuler", "-snes_type", "ngmres", "-npc_snes_type", "nrichardson"],
    ["-msim_integrator", "implicit_euler", "-snes_type", "pd", "-npc_snes_type", "newtonls"],
    ["-msim_integrator", "implicit_euler", "-snes_type", "ntr", "-npc_snes_type", "pd"],
    ["-msim_integrator", "implicit_euler", "-snes_type", "pd", "-pd_pc_msimllt_relax", "abc"],
    ["-msim_integrator", "implicit_euler", "-snes_type", "qn", "-snes_qn_scale_type", "jacobian", "-pd_pc_msimllt_max_width", "0"],
    ["-msim_integrator", "symplectic_euler", "-msim_contact_plane", "0,0,1,-0.1", "-msim_contact_bounds"],
    ["-msim_contact_plane", "0,0,1,-1", "-msim_contact_thickness", "0.01"],
    ["-msim_contact_distance", "0.1"], ["-msim_integrator", "implicit_euler", "-msim_contact_pd_refactor", "2"],
    ["-msim_integrator", "ts", "-msim_contact_plane", "0,0,1,-0.1", "-msim_contact_pd_weight", "0"],
    ["-msim_fix_velocity", "1,2,3,4"], ["-msim_wind", "1,2,3,4", "-msim_drag", "1"], ["-msim_scene", "box", "-msim_box_n", "2,2,2,2"],
    ["-msim_integrator", "implicit_euler", "-msim_contact_plane", "0,0,1,-0.1", "-snes_type", "pd", "-msim_contact_pc_pd_weight"],
    ["-msim_integrator", "implicit_euler", "-msim_contact_plane", "0,0,1,-0.1", "-snes_type", "ntr", "-msim_contact_psd_curvature", "0"],
    ["-msim_integrator", "implicit_euler", "-msim_contact_plane", "0,0,1,-0.1", "-snes_type", "pd", "-msim_contact_pd_weight", "0", "-msim_contact_pd_refactor", "2"],
    ["-msim_integrator", "implicit_euler", "-msim_contact_plane", "0,0,1,-0.1", "-msim_contact_pd_refactor_selective", "3"],
    ["-msim_integrator", "implicit_euler", "-msim_contact_plane", "0,0,1,-0.1", "-snes_type", "pd", "-msim_contact_pd_refactor", "0", "-msim_contact_pd_refactor_selective", "3"],
    ["-msim_integrator", "implicit_euler", "-snes_type", "qn", "-snes_qn_type", "badbroyden", "-msim_contact_sphere", "0.5,0.5,-0.4,0.3"],
    ["-msim_fix", "list", "-msim_fix_list", "3", "-msim_fix_list", "7"])}
# -msim_implicit_terms: the obstacles' and self_friction's order cases are kept at 2 ranks; the
# others are refused by the same line as the obstacles'
ONE_RANK |= {tuple(a) for a, _ in CASES if "-msim_implicit_terms" in a and ("-msim_friction" in a or "-msim_contact_plane" not in a) and "springs,self_friction,self_contact" not in a}
ONE_RANK |= {("-msim_integrator", "implicit_euler", "-pc_type", pc) for pc in ("nn", "lsc", "vpbjacobi", "shell", "patch", "composite", "cp")}
# the same options where a solver of the run reads them: msim's defaults for a type given
# explicitly, the nonlinear preconditioner's with its prefix; each must run without a word
ACCEPTED = [
    ["-snes_type", "anderson", "-npc_snes_type", "pd", "-npc_snes_pd_fixed", "-npc_snes_max_it", "1", "-npc_snes_pd_anderson", "2"],
    ["-snes_type", "newtonls", "-npc_snes_type", "pd", "-npc_snes_pd_fixed", "-npc_snes_max_it", "1", "-msim_psd", "1", "-msim_pc_pd"],
    ["-snes_type", "ntr", "-msim_psd", "1", "-snes_ntr_eta", "0.1"],
    ["-snes_type", "qn", "-snes_qn_scale_type", "jacobian", "-msim_pc_pd", "1", "-snes_qn_m", "5"],
    ["-snes_type", "qn", "-snes_qn_scale_type", "jacobian", "-pc_type", "jacobi"],
    # the discrete gradient's default direct solve (preonly) gives way to the PD factor's GMRES:
    # preonly took one application of the factor for Newton's direction, and every step stopped at
    # -snes_max_it 50
    ["-msim_integrator", "discrete_gradient", "-msim_pc_pd", "-snes_max_it", "50"],
    ["-snes_type", "pd", "-snes_pd_lbfgs", "3", "-snes_pd_lbfgs_scale_max", "2", "-snes_pd_lbfgs_fused", "0"],
    ["-snes_type", "newtonls", "-msim_psd", "0", "-msim_psd_fallback", "0", "-msim_pc_pd", "0"],
    ["-snes_type", "newtonls", "-msim_psd", "0", "-ksp_type", "preonly", "-pc_type", "cholesky", "-pc_factor_mat_solver_type", "mumps", "-msim_check_saddle", "0"],
    # the barrier's PD and Newton options where the run takes them: ntr's default PD preconditioner,
    # PD as Newton's nonlinear preconditioner, the PSD fallback's projected Hessian
    ["-msim_contact_plane", "0,0,1,-0.1", "-snes_type", "ntr", "-msim_contact_pc_pd_weight", "-msim_contact_pd_refactor", "2"],
    ["-msim_contact_plane", "0,0,1,-0.1", "-snes_type", "newtonls", "-ksp_type", "cg", "-msim_pc_pd", "-msim_contact_pc_pd_weight", "0"],
    ["-msim_contact_plane", "0,0,1,-0.1", "-snes_type", "newtonls", "-npc_snes_type", "pd", "-npc_snes_pd_fixed", "-npc_snes_max_it", "1", "-msim_psd", "1",
     "-msim_contact_pd_weight", "0", "-msim_contact_pd_bound", "0"],
    ["-msim_contact_plane", "0,0,1,-0.1", "-snes_type", "pd", "-msim_contact_pd_refactor", "4", "-msim_contact_pd_refactor_selective", "0", "-msim_contact_pd_bound", "0"],
    ["-msim_contact_plane", "0,0,1,-0.1", "-snes_type", "newtonls", "-msim_psd", "0", "-msim_psd_fallback", "-msim_contact_psd_curvature", "0"],
]
# factorizations a matrix spread over several ranks has no package for: checked at set-up, before
# any output (on one rank these run)
PARALLEL_CASES = [
    (["-msim_integrator", "implicit_euler", "-snes_type", "newtonls", "-ksp_type", "cg", "-pc_type", "icc"], "-pc_type icc: no ICC factorization of a mpiaij matrix"),
    (["-msim_integrator", "implicit_euler", "-snes_type", "newtonls", "-ksp_type", "preonly", "-pc_type", "lu", "-pc_factor_mat_solver_type", "superlu"], "-pc_factor_mat_solver_type superlu: no LU factorization"),
    (["-msim_integrator", "implicit_euler", "-snes_type", "pd", "-pd_ksp_type", "cg", "-pd_pc_type", "icc"], "-pd_pc_type icc: no ICC factorization of a mpiaij matrix in this PETSc (on several ranks: -pd_pc_type bjacobi -pd_sub_pc_type icc"),
]
# the corpus of bad options files (also the options fuzzer's seeds): each says on its first line,
# "# expect: TEXT", what its one error line must contain
CORPUS = os.path.join(mt.HERE, "data", "bad")
for name in sorted(os.listdir(CORPUS)):
    if name.endswith(".opts"):
        first = open(os.path.join(CORPUS, name)).readline()
        assert first.startswith("# expect: "), f"{name}: its first line must be '# expect: TEXT'"
        CASES.append((["-options_file", os.path.join(CORPUS, name)], first[len("# expect: "):].strip()))
# the corpus's files at 2 ranks: rank 0 reads an options file for all (a file with a bad value is
# then one of the inline cases' checks); kept there, a mesh file that does not open and one more
ONE_RANK |= {("-options_file", os.path.join(CORPUS, name)) for name in (
    "all_fixed.opts", "cloth_too_small.opts", "nonfinite_dt.opts", "overflow_steps.opts", "wind_not_numbers.opts", "wind_short_list.opts")}


def run(args, cwd, np=1):
    return mt.run(MSIM, args, np, cwd=cwd)


def main():
    check = mt.Checks(quiet=True)
    nps = mt.ranks()  # ctest runs each rank count as a test of its own (bad_input_np1, _np2)
    with tempfile.TemporaryDirectory() as tmp:
        with open(os.path.join(tmp, "malformed.opts"), "w") as f:
            f.write("-msim_cloth_n 8\nmsim_steps 3\n")  # the dash forgotten on line 2
        with open(os.path.join(tmp, "huge.obj"), "w") as f:
            f.write("v 0 0 -0.5\nv 1e300 0 -0.5\nv 0 1e300 -0.5\nf 1 2 3\n")
        for np in nps:
            todo = []  # (args, message, out, the command line's arguments)
            for i, (args, message) in enumerate(CASES + (PARALLEL_CASES if np > 1 else [])):
                if np > 1 and tuple(args) in ONE_RANK:
                    continue
                out = os.path.join(tmp, f"series_{np}_{i}")
                # options given in the case (or in its options file) are not overridden
                given = " ".join(args) + (open(os.path.join(tmp, args[1])).read() if args[0] == "-options_file" and os.path.exists(os.path.join(tmp, args[1])) else "")
                extra = ([] if "-msim_output" in given else ["-msim_output", out]) + ([] if "-msim_steps" in given else ["-msim_steps", "5"])
                todo.append((args, message, out, args + extra))
            # each case its own output directory, reading only files written above: run side by side
            for (args, message, out, _), r in zip(todo, mt.run_many(MSIM, [t[3] for t in todo], np, cwd=tmp)):
                lines = mt.lines(r.stderr)
                problems = []
                if r.returncode == 0:
                    problems.append("exit code 0")
                if len(lines) != 1 or not lines[0].startswith("msim: error: ") or message not in lines[0]:
                    problems.append(f"stderr {lines!r} does not say '{message}' on one line")
                if os.path.exists(out):
                    problems.append("output directory was created")
                check(not problems, f"np={np} {' '.join(args)}: " + "; ".join(problems))
        # fewer free vertices than ranks (a chain of n vertices, fixed at both ends, has n - 2):
        # refused before partitioning, so that METIS, which asked for more parts than vertices
        # prints lines of its own on stdout ("Cannot bisect a graph with 0 vertices"), is not called:
        # msim's one line alone, at 2 ranks and at 4 (where METIS spoke)
        if 2 in nps:
            for np, n in ((2, 3), (4, 3), (4, 5)):
                out = os.path.join(tmp, f"few_free_{np}_{n}")
                r = run(["-msim_scene", "chain", "-msim_chain_n", str(n), "-msim_steps", "2", "-msim_output", out], tmp, np)
                lines, free = mt.lines(r.stderr), n - 2
                want = f"msim: error: the chain scene has {free} free {'vertex' if free == 1 else 'vertices'} for {np} ranks: every rank must own one; use at most {free} rank"
                check(r.returncode != 0 and len(lines) == 1 and lines[0].startswith(want) and not r.stdout.strip() and not os.path.exists(out),
                      f"np={np} a chain of {n} ({free} free): rc {r.returncode}, stderr {lines!r}, stdout {r.stdout.strip()[-200:]!r}, want '{want}' alone")
        for np in nps:
            accepted = [["-msim_integrator", "implicit_euler", "-msim_cloth_n", "6", "-msim_dt", "0.01", "-msim_steps", "2", "-snes_max_it", "500"] + args for args in ACCEPTED]
            for args, r in zip(ACCEPTED, mt.run_many(MSIM, accepted, np, cwd=tmp)):
                check(r.returncode == 0 and not r.stderr.strip(), f"np={np} {' '.join(args)}: read by the run's solvers, runs without a word (rc {r.returncode}, stderr {r.stderr.strip()[-300:]!r})")
        # a misspelled option runs with the defaults, so it is named in a warning (one line, exit 0)
        for np in nps:
            r = run(["-msim_stifness", "10", "-msim_steps", "2"], tmp, np)
            lines = mt.lines(r.stderr)
            check(r.returncode == 0 and len(lines) == 1 and lines[0].startswith("msim: warning: -msim_stifness was set but never used"),
                  f"np={np} misspelled option: rc {r.returncode}, stderr {lines!r}")
        # the spectrum's options without -msim_spectrum: read (-help lists them), so PETSc's warning
        # never named them, and the run stepped without a word; each named in one warning line
        for np in nps:
            r = run(["-msim_cloth_n", "5", "-msim_steps", "1", "-msim_spectrum_lowest", "4", "-msim_spectrum_largest", "2", "-msim_spectrum_modes", "modes"], tmp, np)
            lines = mt.lines(r.stderr)
            check(r.returncode == 0 and lines == [f"msim: warning: -msim_spectrum_{o} has no effect without -msim_spectrum (which computes the spectrum instead of the run's steps)" for o in ("largest", "lowest", "modes")]
                  and not os.path.exists(os.path.join(tmp, "modes")), f"np={np} the spectrum's options without -msim_spectrum: rc {r.returncode}, stderr {lines!r}")
        # an option given on two lines of one options file keeps the last value only: named in one
        # warning line (a list option's repeat is an error: the corpus); a file's option given
        # again on the command line is PETSc's ordinary override, and says nothing
        with open(os.path.join(tmp, "repeated_dt.opts"), "w") as f:
            f.write("-msim_dt 0.001\n-msim_steps 2\n# a smaller step\n-msim_dt 0.0005\n")
        for np in nps:
            r = run(["-options_file", "repeated_dt.opts", "-msim_steps", "3"], tmp, np)
            lines = mt.lines(r.stderr)
            check(r.returncode == 0 and lines == ["msim: warning: repeated_dt.opts lines 1 and 4: -msim_dt is given twice; only the last, 0.0005 (line 4), counts"],
                  f"np={np} an option repeated in an options file: rc {r.returncode}, stderr {lines!r}")
        # the command line's -msim_dt after the file is the value that counts: the file's repeat is
        # not named (the warning said 0.0005 counted where 0.0002 did)
        r = run(["-options_file", "repeated_dt.opts", "-msim_dt", "0.0002", "-msim_monitor_csv", "dt.csv"], tmp, 1)
        t = [float(row["t"]) for row in mt.read_csv(os.path.join(tmp, "dt.csv"))] if r.returncode == 0 else []
        check(r.returncode == 0 and not mt.lines(r.stderr) and t and abs(t[-1] - 0.0004) < 1e-12,
              f"an options file's repeated option overridden on the command line: no warning ({mt.lines(r.stderr)!r}), t = {t[-1:]} (want 0.0004)")
        # a list option of the command line that replaces an options file's is PETSc's override:
        # one plane, the command line's
        with open(os.path.join(tmp, "plane.opts"), "w") as f:
            f.write("-msim_contact_plane 0,0,1,-0.1\n")
        r = run(["-options_file", "plane.opts", "-msim_contact_plane", "0,0,1,-0.2", "-msim_steps", "1", "-msim_scene_view"], tmp, 1)
        check(r.returncode == 0 and not mt.lines(r.stderr) and "1 obstacle(s)" in r.stdout and "n.x >= -0.2" in r.stdout,
              f"an options file's list option replaced on the command line: rc {r.returncode}, stderr {mt.lines(r.stderr)!r}, stdout {r.stdout[-400:]!r}")
        # plane normals whose squares overflow or underflow are normalised (they had become zero:
        # every vertex on the plane, or "a zero normal"); the scene view names the penalty's
        # stiffness only where the integrator has a penalty
        for integrator, plane, want in (("implicit_euler", "1e300,1e300,0,-1e300", "n = (0.707107, 0.707107, 0.), n.x >= -0.707107\n"),
                                        ("symplectic_euler", "0,0,1e-170,-1e-171", "n = (0., 0., 1.), n.x >= -0.1\n")):
            r = run(["-msim_integrator", integrator, "-msim_cloth_n", "5", "-msim_contact_plane", plane, "-msim_steps", "1", "-msim_dt", "1e-3", "-msim_scene_view", "-msim_output", os.path.join(tmp, "plane_" + integrator)], tmp, 1)
            kc = "contact: penalty kc" in r.stdout
            check(r.returncode == 0 and want in r.stdout and kc == (integrator == "symplectic_euler"),
                  f"-msim_contact_plane {plane} with {integrator}: rc {r.returncode}, stderr {mt.lines(r.stderr)!r}, stdout {r.stdout[-400:]!r} (want '{want.strip()}', the penalty's kc {'' if kc else 'not '}named)")
        # an implicit solve cut off by -snes_max_it before its tolerance: the run goes on, and one
        # warning line at its end says how many steps stopped short; a fixed count says nothing.
        # ntr's solve cut off so is a step cut short as newtonls's is (a drape that diverged after
        # such ntr steps runs to its end with a higher -snes_max_it, as the warning advises)
        implicit = ["-msim_integrator", "implicit_euler", "-msim_cloth_n", "8", "-msim_dt", "0.0333", "-msim_steps", "4"]
        for np in nps:
            r2 = run(implicit + ["-snes_type", "pd", "-snes_max_it", "3", "-snes_pd_fixed"], tmp, np)
            check(r2.returncode == 0 and not r2.stderr.strip(), f"np={np} fixed count: rc {r2.returncode}, stderr {r2.stderr.strip()!r}")
            for snes in ("newtonls", "ntr"):
                r = run(implicit + ["-snes_type", snes, "-snes_max_it", "1"], tmp, np)
                lines = mt.lines(r.stderr)
                check(r.returncode == 0 and len(lines) == 1 and lines[0].startswith(f"msim: warning: in 4 of 4 steps -snes_type {snes} stopped at -snes_max_it 1"),
                      f"np={np} {snes}'s unconverged steps: rc {r.returncode}, stderr {lines!r}")
                # a run that then fails names those steps too, before its error line (only runs that
                # ended said so: a failure after steps cut off by -snes_max_it said "diverged" alone);
                # here the divergence test made strict enough to stop the same run, its handles lifting
                # it (the energy rises only by their work), at its last step, the one checked
                r = run(implicit + ["-snes_type", snes, "-snes_max_it", "1", "-msim_fix_velocity", "0,0,1", "-msim_divergence_factor", "1e-3"], tmp, np)
                lines = mt.lines(r.stderr)
                check(r.returncode != 0 and len(lines) == 2 and lines[0].startswith(f"msim: warning: in 4 of 4 steps -snes_type {snes} stopped at -snes_max_it 1")
                      and lines[1].startswith("msim: error: diverged at step 4"),
                      f"np={np} {snes}'s unconverged steps, then a divergence: the warning and the error (rc {r.returncode}, stderr {lines!r})")
        # an implicit solve that fails (here a function-evaluation cap it cannot meet): one error
        # line naming the step, the SNES type and PETSc's reason
        # its per-iteration history up to the failure is kept under the name given
        for np in nps:
            hist = os.path.join(tmp, f"failed_history_{np}.csv")
            r = run(implicit + ["-snes_type", "qn", "-snes_qn_scale_type", "jacobian", "-snes_max_funcs", "5", "-msim_monitor_convergence", hist], tmp, np)
            lines = mt.lines(r.stderr)
            rows = open(hist).read().splitlines() if os.path.exists(hist) else []
            check(r.returncode != 0 and len(lines) == 1 and lines[0].startswith("msim: error: the nonlinear solver failed (-snes_type qn: DIVERGED_FUNCTION_COUNT) at step 1")
                  and len(rows) >= 2 and rows[0] == "step,iteration,wall_s,phi,gnorm" and rows[1].startswith("1,0,") and not os.path.exists(hist + ".tmp"),
                  f"np={np} failed implicit solve: rc {r.returncode}, stderr {lines!r}, history {rows[:2]!r}")
        # a solve that fails after steps the divergence check did not look at (it checks every 10th
        # step without a monitor): the step before the failure is the last finite state, saved as
        # the frame a run writing every step has of it (was the last checked one, step 0). qn on the
        # pinned cloth takes 31-40 evaluations in step 1 and over 50 in step 2: the cap fails step 2
        failing = ["-msim_cloth_n", "6", "-msim_steps", "3", "-msim_dt", "0.01", "-msim_integrator", "implicit_euler", "-snes_type", "qn", "-snes_max_funcs", "45"]
        for np in nps:
            sparse, every = os.path.join(tmp, f"failed_sparse_{np}"), os.path.join(tmp, f"failed_every_{np}")
            r = run(failing + ["-msim_output", sparse], tmp, np)
            r1 = run(failing + ["-msim_output", every, "-msim_output_every", "1"], tmp, np)
            lines = mt.lines(r.stderr)
            saved = [os.path.join(sparse, "last_finite.vtu"), os.path.join(every, "frame_000001.vtu")]
            check(r.returncode != 0 and r1.returncode != 0 and len(lines) == 1 and "at step 2" in lines[0] and lines[0].endswith("last finite state is step 1")
                  and all(os.path.exists(f) for f in saved) and open(saved[0], "rb").read() == open(saved[1], "rb").read(),
                  f"np={np} failed solve after an unchecked step: rc {r.returncode}, stderr {lines!r}; last_finite.vtu is step 1's frame")
        # msimllt given a matrix that is not positive definite (Newton's exact Hessian of a cloth
        # whose springs compress as it sags: negative transverse curvature): one error line naming
        # the matrix's row, a global row index (the factor's own numbering is AMD's), at 1 and 2
        # ranks (on 2, each rank's local factor; the row is the least failing one over the ranks)
        for np in nps:
            r = run(["-msim_cloth_n", "21", "-msim_integrator", "implicit_euler", "-msim_dt", "0.05", "-msim_steps", "20", "-snes_type", "newtonls",
                     "-msim_psd", "0", "-ksp_type", "preonly", "-pc_type", "msimllt", "-msim_output", os.path.join(tmp, f"pivot_{np}")], tmp, np)
            lines = mt.lines(r.stderr)
            m = re.search(r"msimllt: the matrix is not positive definite \(a non-positive pivot at its row (\d+)\)", lines[0]) if len(lines) == 1 else None
            check(r.returncode != 0 and m is not None and 0 <= int(m.group(1)) < 3 * 21 * 21,
                  f"np={np} msimllt on an indefinite matrix: rc {r.returncode}, stderr {lines!r}")
        # a diverging run: explicit Euler on a stiff cloth, frames every 10 steps (at 1 rank)
        if 1 in nps:
            out = os.path.join(tmp, "diverged")
            r = run(["-msim_integrator", "explicit_euler", "-msim_dt", "2e-3", "-msim_steps", "400", "-msim_output", out, "-msim_output_every", "10", "-msim_spectrum_check", "0"], tmp)
            frames = sorted(f for f in os.listdir(out) if f.startswith("frame_")) if os.path.isdir(out) else []
            err = [l for l in r.stderr.splitlines() if l.startswith("msim: error:")]
            ok = (r.returncode != 0 and len(err) == 1 and "diverged at step" in err[0] and "explicit_euler" in err[0] and "h = 0.002" in err[0]
                  and len(frames) >= 1 and os.path.exists(os.path.join(out, "last_finite.vtu")) and os.path.exists(os.path.join(out, "series.pvd"))
                  and not any(f.endswith(".tmp") for f in os.listdir(out)))
            if check(ok, f"divergence: rc {r.returncode}, stderr {r.stderr[-500:]!r}, frames {frames}"):
                print(f"divergence: '{err[0]}', {len(frames)} frames kept, last_finite.vtu written")
    sys.exit(check.exit_code())


if __name__ == "__main__":
    main()
