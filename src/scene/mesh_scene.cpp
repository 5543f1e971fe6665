/* Meshes become scenes: springs on the unique edges, masses lumped by volume or area, the cells
   kept for output. */
#include <msim/scene.h>
#include <algorithm>
#include <cmath>

static void CopyVertices(const MSimMesh *m, MSimSceneData *s)
{
  s->nv = m->nv;
  s->x0 = m->x;
  s->cell_size = m->nper;
  s->cells     = m->cell;
  s->source    = m->file;
}

PetscErrorCode MSimSceneFromTets(const MSimMesh *m, PetscReal k, PetscReal young, MSimSceneData *s)
{
  std::vector<PetscInt>  ei, ej;
  std::vector<PetscReal> around;

  PetscFunctionBeginUser;
  PetscCheck(m->nper == 4, PETSC_COMM_SELF, PETSC_ERR_ARG_WRONG, "%s: not tets", m->file.c_str());
  CopyVertices(m, s);
  PetscCall(MSimMeshVertexMeasure(m, s->share, &s->measure));
  PetscCall(MSimMeshEdges(m, ei, ej, young > 0 ? &around : NULL, NULL));
  s->si.reserve(ei.size());
  s->sj.reserve(ei.size());
  s->sk.reserve(ei.size());
  s->sL.reserve(ei.size());
  for (size_t e = 0; e < ei.size(); e++) {
    MSimSceneAddSpring(s, ei[e], ej[e], k);
    /* Young's modulus: k = E V_e / L^2, V_e the volume of the tets around the edge. Under any
       uniform strain eps of the lattice, sum_e k_e (eps L_e)^2 / 2 = E eps^2 sum_e V_e / 2 =
       3 E eps^2 V (every tet has 6 edges): the strain energy of an isotropic solid of modulus E
       and Poisson ratio 1/4 dilated by eps, the ratio a central-spring lattice has. */
    if (young > 0) s->sk.back() = young * around[e] / (s->sL.back() * s->sL.back());
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSceneFromSurface(const MSimMesh *m, PetscReal kedge, PetscReal kbend, MSimSceneData *s)
{
  std::vector<PetscInt> ei, ej, opp;

  PetscFunctionBeginUser;
  PetscCheck(m->nper == 3, PETSC_COMM_SELF, PETSC_ERR_ARG_WRONG, "%s: not a surface", m->file.c_str());
  CopyVertices(m, s);
  PetscCall(MSimMeshVertexMeasure(m, s->share, &s->measure));
  PetscCall(MSimMeshEdges(m, ei, ej, NULL, kbend > 0 ? &opp : NULL));
  for (size_t e = 0; e < ei.size(); e++) MSimSceneAddSpring(s, ei[e], ej[e], kedge);
  if (kbend > 0) {
    /* one bending spring per pair of opposite vertices, none where an edge already joins them
       (a pair can face two edges, e.g. on a tetrahedron's surface) */
    std::vector<std::pair<PetscInt, PetscInt>> pairs;
    for (size_t q = 0; q < opp.size(); q += 2) pairs.emplace_back(std::min(opp[q], opp[q + 1]), std::max(opp[q], opp[q + 1]));
    std::sort(pairs.begin(), pairs.end());
    pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
    for (auto &p : pairs) {
      auto lo = std::lower_bound(ei.begin(), ei.end(), p.first);
      auto hi = std::upper_bound(lo, ei.end(), p.first);
      if (std::binary_search(ej.begin() + (lo - ei.begin()), ej.begin() + (hi - ei.begin()), p.second)) continue;
      MSimSceneAddSpring(s, p.first, p.second, kbend);
      PetscCheck(s->sL.back() > 0, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: vertices %lld and %lld, opposite across an edge, are at the same place (a bending spring of zero length: the surface folds onto itself)", m->file.c_str(), (long long)p.first, (long long)p.second);
    }
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

template <typename T>
static PetscErrorCode BcastVector(MPI_Comm comm, std::vector<T> &v)
{
  long long n = (long long)v.size();

  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Bcast(&n, 1, MPI_LONG_LONG, 0, comm));
  v.resize((size_t)n);
  /* in pieces: MPI counts are int */
  for (long long off = 0; off < n; off += (1 << 27)) PetscCallMPI(MPI_Bcast(v.data() + off, (int)(std::min<long long>(n - off, 1 << 27) * sizeof(T)), MPI_BYTE, 0, comm));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSceneDataBcast(MPI_Comm comm, MSimSceneData *s)
{
  std::vector<char> src(s->source.begin(), s->source.end());

  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Bcast(&s->nv, 1, MPIU_INT, 0, comm));
  PetscCallMPI(MPI_Bcast(&s->cell_size, 1, MPI_INT, 0, comm));
  PetscCallMPI(MPI_Bcast(&s->measure, 1, MPIU_REAL, 0, comm));
  PetscCall(BcastVector(comm, s->x0));
  PetscCall(BcastVector(comm, s->si));
  PetscCall(BcastVector(comm, s->sj));
  PetscCall(BcastVector(comm, s->sk));
  PetscCall(BcastVector(comm, s->sL));
  PetscCall(BcastVector(comm, s->cells));
  PetscCall(BcastVector(comm, s->share));
  PetscCall(BcastVector(comm, src));
  s->source.assign(src.begin(), src.end());
  PetscFunctionReturn(PETSC_SUCCESS);
}
