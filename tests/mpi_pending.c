/* An MPI interposer (LD_PRELOAD) for tests/step_error.py: counts the MPI_Iallreduce requests that
   no MPI_Wait, MPI_Waitall or MPI_Test completed, and says at MPI_Finalize how many are left
   pending, one line per rank ("mpi_pending: rank R: N MPI_Iallreduce pending at MPI_Finalize").
   msim's stop poll (src/util/stop_signal.cpp) is the only user of MPI_Iallreduce that waits on its
   requests this way; PETSc's own split reductions complete theirs with MPI_Wait too. */
#include <mpi.h>
#include <stdio.h>

#define MAXREQ 4096
static MPI_Request pending[MAXREQ];
static int         npending, overflow;

static void Completed(MPI_Request r)
{
  for (int i = 0; i < npending; i++)
    if (pending[i] == r) {
      pending[i] = pending[--npending];
      return;
    }
}

int MPI_Iallreduce(const void *send, void *recv, int count, MPI_Datatype type, MPI_Op op, MPI_Comm comm, MPI_Request *request)
{
  int err = PMPI_Iallreduce(send, recv, count, type, op, comm, request);
  if (err == MPI_SUCCESS) {
    if (npending < MAXREQ) pending[npending++] = *request;
    else overflow = 1;
  }
  return err;
}

int MPI_Wait(MPI_Request *request, MPI_Status *status)
{
  MPI_Request r   = *request;
  int         err = PMPI_Wait(request, status);
  Completed(r);
  return err;
}

int MPI_Waitall(int count, MPI_Request requests[], MPI_Status statuses[])
{
  MPI_Request r[64];
  for (int i = 0; i < count && i < 64; i++) r[i] = requests[i];
  int err = PMPI_Waitall(count, requests, statuses);
  for (int i = 0; i < count && i < 64; i++) Completed(r[i]);
  if (count > 64) overflow = 1;
  return err;
}

int MPI_Test(MPI_Request *request, int *flag, MPI_Status *status)
{
  MPI_Request r   = *request;
  int         err = PMPI_Test(request, flag, status);
  if (*flag) Completed(r);
  return err;
}

int MPI_Finalize(void)
{
  int rank = 0;
  PMPI_Comm_rank(MPI_COMM_WORLD, &rank);
  fprintf(stderr, "mpi_pending: rank %d: %d MPI_Iallreduce pending at MPI_Finalize%s\n", rank, npending, overflow ? " (count incomplete)" : "");
  fflush(stderr);
  return PMPI_Finalize();
}
