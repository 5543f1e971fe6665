/* Transport defaults msim sets before MPI starts. A value the user gave on mpirun's command line
   (`--mca btl_vader_eager_limit 4096`, which reaches the ranks as OMPI_MCA_ variables) or in the
   environment stays; one in an MCA parameter file is overridden, since Open MPI ranks the
   environment above files.
   The ghost exchange of a distributed force sends each neighbour a few rows of 3 per boundary
   vertex: 12 KB per message on a cloth N = 256 cut in two, 24 KB at N = 512. Open MPI's shared-
   memory transport (vader) sends up to 4 KB eagerly; anything larger goes by rendezvous, which
   moves the data only once the receiver calls MPI again, i.e. after its whole sweep, then costs a
   round trip. Sent eagerly, the data are in the receiver's queue by then. Measured at N = 256 on
   two ranks: 20-22 -> 7-10 us in VecScatterEnd on the rank that waits, 4-6 -> 4 us in Begin, of a
   ~305-us force. */
#include <msim/init.h>
#include <cstdlib>

void MSimSetMPIDefaults(void)
{
  /* overwrite = 0: a value already in the environment stays. Open MPI 5 renamed vader to sm. */
  setenv("OMPI_MCA_btl_vader_eager_limit", "32768", 0);
  setenv("OMPI_MCA_btl_sm_eager_limit", "32768", 0);
}
