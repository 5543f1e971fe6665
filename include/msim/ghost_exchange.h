/* The forward ghost exchange of the hot loops: each rank's ghost rows (bs values per vertex) from
   their owners' rows. The plan (who sends which rows to whom) comes from a PetscSF over vertices;
   the transfer is one MPI_Irecv and one MPI_Isend per neighbour, straight into the ghost rows.
   VecScatter did the same with more calls around the bytes: on two ranks with a 3 KB message its
   Begin and End took 4.3-4.9 us of a 23-us force (cloth N = 64; the wait for the other rank
   included), these 2.2-2.7. */
#pragma once
#include <msim/petsc_compat.h>
#include <vector>

typedef struct {
  PetscBool                created;
  MPI_Comm                 comm; /* PETSc's inner communicator of the system's, with a tag of its own */
  PetscMPIInt              tag;
  PetscInt                 bs;
  std::vector<PetscMPIInt> to, from;   /* neighbours sent to, received from */
  std::vector<PetscInt>    to_off;     /* rows[to_off[n], to_off[n+1]) packed for to[n] */
  std::vector<PetscInt>    rows;       /* owned rows */
  std::vector<PetscInt>    from_off;   /* ghost rows [from_off[n], from_off[n+1]) come from from[n] */
  std::vector<PetscReal>   buf;        /* packed rows in flight */
  std::vector<MPI_Request> req;
} MSimGhostExchange;

/* Collective. ghosts: the global numbers of this rank's nghost ghost vertices, ascending; owners'
   blocks are contiguous, rank r owning [ranges[r], ranges[r+1]). */
PetscErrorCode MSimGhostExchangeCreate(MPI_Comm comm, PetscInt bs, PetscInt nown, PetscInt nghost, const PetscInt *ghosts, const PetscInt *ranges, MSimGhostExchange *x);
/* own: the owned rows (read and packed here); ghost: the first ghost row, written by End */
PetscErrorCode MSimGhostExchangeBegin(MSimGhostExchange *x, const PetscReal *own, PetscReal *ghost);
PetscErrorCode MSimGhostExchangeEnd(MSimGhostExchange *x);
PetscErrorCode MSimGhostExchangeDestroy(MSimGhostExchange *x);
