# Sourced by the scripts: Open MPI as root, more ranks than cores, single-threaded BLAS per rank.
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_rmaps_base_oversubscribe=1
export OPENBLAS_NUM_THREADS=${OPENBLAS_NUM_THREADS:-1}
# Ctrl-C or SIGTERM to mpirun: Open MPI forwards it to the ranks as SIGTERM and SIGKILLs them
# odls_base_sigkill_timeout seconds later (1 by default), before msim, which stops after the step
# in progress, can end a step longer than that and write its checkpoint. 60 s lets it finish.
export OMPI_MCA_odls_base_sigkill_timeout=${OMPI_MCA_odls_base_sigkill_timeout:-60}
