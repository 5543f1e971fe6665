/* From the scene's directory to each rank's part: free numbering in input order, the graph of free
   vertices (each row where its vertex has its directory), the partition, the owned vertices moved
   to their ranks and numbered there (by rank, input order within a rank), and every spring sent
   to the owner of its first free end, with a copy (a halo spring) to the owner of the other end
   where that differs. All exchanges are personalized all-to-alls of what each rank holds. */
#include "system_distribute.h"
#include <msim/errors.h>
#include <msim/log.h>
#include <algorithm>
#include <cstdint>

namespace {
struct Adjacency {
  PetscInt row, col; /* free numbers */
};
struct Migrant {
  PetscInt  vid;
  PetscReal x[3], mass;
};
struct Numbered {
  PetscInt vid, gnum;
};
typedef MSimVertexOwner VertexInfo;
struct Position {
  PetscReal x[3];
};
} // namespace

/* The distinct ends of the springs held here (ascending) and where each spring's two ends are
   among them. Where the ids span a range no wider than twice the springs (a generator's block, a
   rank's part of a mesh) a table over that range (MSimIdTable) answers, with no array per spring
   end (64 MB at 4 M springs: the pair list and the indices); otherwise the ends of spring s are
   at[s] and at[ns + s]. */
namespace {
struct SpringEnds {
  std::vector<PetscInt> ends, pos, at;
  PetscInt              lo = 0;
  size_t                ns = 0;

  void Build(const MSimSceneData &S)
  {
    ns = S.si.size();
    if (!ns || MSimIdTable({&S.si, &S.sj}, 2 * ns + 1024, lo, pos, ends)) return;
    std::vector<PetscInt> both(S.si);
    both.insert(both.end(), S.sj.begin(), S.sj.end());
    MSimCompactIds(both, ends, at);
  }
  PetscInt First(const MSimSceneData &S, size_t s) const { return pos.empty() ? at[s] : pos[S.si[s] - lo]; }
  PetscInt Second(const MSimSceneData &S, size_t s) const { return pos.empty() ? at[ns + s] : pos[S.sj[s] - lo]; }
  void     Free()
  {
    for (auto *v : {&ends, &pos, &at}) std::vector<PetscInt>().swap(*v);
  }
};
} // namespace

/* The owned vertices along a Z-order (Morton) curve through their rest positions, ties by input
   id: neighbours in space get nearby rows, so the spring sweep reads few cache lines per vertex.
   A refined mesh needs it: its new vertices are numbered by the edges they split, far from the
   old ones beside them (the explicit step of the bunny refined three times took 8.8 ns per spring
   in input order on one rank). */
static PetscErrorCode MortonOrder(std::vector<Migrant> &v)
{
  PetscReal lo[3] = {PETSC_MAX_REAL, PETSC_MAX_REAL, PETSC_MAX_REAL}, hi[3] = {-PETSC_MAX_REAL, -PETSC_MAX_REAL, -PETSC_MAX_REAL};

  PetscFunctionBeginUser;
  for (const Migrant &m : v)
    for (int c = 0; c < 3; c++) {
      lo[c] = std::min(lo[c], m.x[c]);
      hi[c] = std::max(hi[c], m.x[c]);
    }
  std::vector<std::pair<uint64_t, size_t>> key(v.size());
  for (size_t k = 0; k < v.size(); k++) {
    uint64_t code = 0;
    uint32_t q[3];
    for (int c = 0; c < 3; c++) q[c] = (uint32_t)(hi[c] > lo[c] ? (v[k].x[c] - lo[c]) / (hi[c] - lo[c]) * 2097151.0 : 0); /* 21 bits */
    for (int b = 20; b >= 0; b--)
      for (int c = 0; c < 3; c++) code = (code << 1) | ((q[c] >> b) & 1u);
    key[k] = {code, k};
  }
  std::sort(key.begin(), key.end(), [&](const std::pair<uint64_t, size_t> &a, const std::pair<uint64_t, size_t> &b) { return a.first < b.first || (a.first == b.first && v[a.second].vid < v[b.second].vid); });
  std::vector<Migrant> sorted(v.size());
  for (size_t k = 0; k < v.size(); k++) sorted[k] = v[key[k].second];
  v.swap(sorted);
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSystemDistribute(MPI_Comm comm, MSimSceneData &S, MSimPartitioner partitioner, PetscBool morton, MSimLocalPart &L)
{
  PetscMPIInt           rank, size;
  std::vector<PetscInt> fid, xadj, adjncy;
  SpringEnds            E;
  std::vector<PetscMPIInt> part, dest;

  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Comm_rank(comm, &rank));
  PetscCallMPI(MPI_Comm_size(comm, &size));
  const PetscInt start = S.dir.Start(rank), count = S.dir.Count(rank);

  /* free numbers: the free vertices in input order, block by block */
  PetscInt nfl = 0, fstart = 0;
  fid.assign(count, -1);
  for (PetscInt v = 0; v < count; v++)
    if (!S.fixed[v]) fid[v] = nfl++;
  PetscCallMPI(MPI_Exscan(&nfl, &fstart, 1, MPIU_INT, MPI_SUM, comm));
  if (rank == 0) fstart = 0;
  for (PetscInt &f : fid)
    if (f >= 0) f += fstart;
  PetscCallMPI(MPI_Allreduce(&nfl, &L.nfree, 1, MPIU_INT, MPI_SUM, comm));
  PetscCheck(L.nfree > 0, comm, PETSC_ERR_ARG_WRONG, "every vertex of the %s scene is fixed: nothing to simulate", S.name.c_str());
  /* every rank must own a free vertex (checked again below, after partitioning): said here, before
     the partitioner runs, because METIS asked for more parts than vertices prints its own lines
     ("Cannot bisect a graph with 0 vertices") on stdout ahead of msim's */
  PetscCheck(L.nfree >= size, comm, PETSC_ERR_ARG_WRONG, "the %s scene has %" PetscInt_FMT " free %s for %d ranks: every rank must own one; use at most %" PetscInt_FMT " rank%s", S.name.c_str(), L.nfree, L.nfree == 1 ? "vertex" : "vertices", size, L.nfree, L.nfree == 1 ? "" : "s");
  {
    /* a scene without springs is a cloud of free particles: always a mistake in the scene's
       options (a spring family list that makes none, a mesh with no edges) */
    PetscInt64 mine = (PetscInt64)S.si.size(), all = 0;
    PetscCallMPI(MPI_Allreduce(&mine, &all, 1, MPIU_INT64, MPI_SUM, comm));
    PetscCheck(all > 0, comm, PETSC_ERR_ARG_WRONG, "the %s scene has no springs: nothing holds its vertices together (see -msim_springs)", S.name.c_str());
  }
  {
    PetscInt nfix = count - nfl;
    PetscCallMPI(MPI_Allreduce(&nfix, &L.nfix_global, 1, MPIU_INT, MPI_SUM, comm));
  }

  /* the graph: each spring between free vertices is a row entry of both, sent where the row is
     (natural blocks and one rank need none) */
  PetscCall(PetscLogStagePush(MSIM_StagePartition));
  E.Build(S);
  PetscBool uses_graph;
  PetscCall(MSimPartitionerUsesGraph(partitioner, &uses_graph));
  xadj.assign(nfl + 1, 0);
  if (uses_graph && size > 1) {
    std::vector<PetscInt>  efid;
    std::vector<Adjacency> send, got;
    PetscCall(MSimFetch(comm, S.dir, fid, E.ends, efid));
    for (size_t s = 0; s < S.si.size(); s++) {
      const PetscInt a = efid[E.First(S, s)], b = efid[E.Second(S, s)];
      if (a < 0 || b < 0) continue;
      send.push_back({a, b});
      dest.push_back(S.dir.Owner(S.si[s]));
      send.push_back({b, a});
      dest.push_back(S.dir.Owner(S.sj[s]));
    }
    PetscCall(MSimExchange(comm, dest, std::move(send), got));
    send.clear();
    send.shrink_to_fit();
    std::sort(got.begin(), got.end(), [](const Adjacency &u, const Adjacency &v) { return u.row < v.row || (u.row == v.row && u.col < v.col); });
    got.erase(std::unique(got.begin(), got.end(), [](const Adjacency &u, const Adjacency &v) { return u.row == v.row && u.col == v.col; }), got.end());
    adjncy.resize(got.size());
    for (size_t q = 0; q < got.size(); q++) {
      xadj[got[q].row - fstart + 1]++;
      adjncy[q] = got[q].col;
    }
    for (PetscInt k = 0; k < nfl; k++) xadj[k + 1] += xadj[k];
  }
  PetscCall(MSimPartitionerPartition(partitioner, L.nfree, fstart, nfl, xadj, adjncy, part));
  xadj.clear();
  xadj.shrink_to_fit();
  adjncy.clear();
  adjncy.shrink_to_fit();
  PetscCall(PetscLogStagePop());

  /* the free vertices to their owners, numbered there in input order */
  PetscCall(PetscLogStagePush(MSIM_StageDistribute));
  {
    std::vector<Migrant> send, got;
    dest.clear();
    for (PetscInt v = 0, k = 0; v < count; v++) {
      if (S.fixed[v]) continue;
      send.push_back({start + v, {S.x0[3 * v], S.x0[3 * v + 1], S.x0[3 * v + 2]}, S.mass[v]});
      dest.push_back(part[k++]);
    }
    PetscCall(MSimExchange(comm, dest, std::move(send), got));
    if (morton) PetscCall(MortonOrder(got));
    else {
      const auto by_vid = [](const Migrant &u, const Migrant &v) { return u.vid < v.vid; };
      if (!std::is_sorted(got.begin(), got.end(), by_vid)) std::sort(got.begin(), got.end(), by_vid); /* one rank: sorted already */
    }
    L.nown = (PetscInt)got.size();
    L.own_vid.resize(L.nown);
    L.own_x0.resize(3 * (size_t)L.nown);
    L.own_mass.resize(L.nown);
    for (PetscInt k = 0; k < L.nown; k++) {
      L.own_vid[k] = got[k].vid;
      for (int c = 0; c < 3; c++) L.own_x0[3 * k + c] = got[k].x[c];
      L.own_mass[k] = got[k].mass;
    }
  }
  PetscCall(MSimCollectiveCheck(comm, (PetscBool)(L.nown > 0), "rank " + std::to_string(rank) + " owns no vertex: " + std::to_string(L.nfree) + " free vertices on " + std::to_string(size) + " ranks; use fewer ranks"));
  L.rstart = 0;
  PetscCallMPI(MPI_Exscan(&L.nown, &L.rstart, 1, MPIU_INT, MPI_SUM, comm));
  if (rank == 0) L.rstart = 0;
  L.ranges.resize(size + 1);
  L.ranges[0] = 0;
  PetscCallMPI(MPI_Allgather(&L.nown, 1, MPIU_INT, L.ranges.data() + 1, 1, MPIU_INT, comm));
  for (PetscMPIInt r = 0; r < size; r++) L.ranges[r + 1] += L.ranges[r];

  /* the directory learns each vertex's owner and global number */
  std::vector<VertexInfo> table(count);
  {
    std::vector<Numbered> send(L.nown), got;
    dest.resize(L.nown);
    for (PetscInt k = 0; k < L.nown; k++) {
      send[k] = {L.own_vid[k], L.rstart + k};
      dest[k] = S.dir.Owner(L.own_vid[k]);
    }
    PetscCall(MSimExchange(comm, dest, std::move(send), got));
    std::vector<PetscMPIInt> from;
    for (PetscInt v = 0; v < count; v++) {
      table[v].owner = -1;
      table[v].gnum  = -1;
    }
    L.dir_gnum.assign(count, -1);
    for (const Numbered &n : got) {
      table[n.vid - start].gnum = n.gnum;
      L.dir_gnum[n.vid - start] = n.gnum;
    }
    /* the owner from the global number: ranks own ascending blocks */
    for (PetscInt v = 0; v < count; v++)
      if (table[v].gnum >= 0) table[v].owner = (PetscMPIInt)(std::upper_bound(L.ranges.begin(), L.ranges.end(), table[v].gnum) - L.ranges.begin() - 1);
  }

  if (S.volume && S.cell_size == 4) PetscCall(MSimSystemDistributeTets(comm, S, table, L));

  /* every spring to the owner of its first free end; a halo copy to the owner of the other */
  {
    std::vector<VertexInfo>   info;
    std::vector<MSimRoutedSpring> send, got;
    PetscInt                  counts[3] = {0, 0, 0}; /* springs with a free end, between free vertices, cut */
    PetscCall(MSimFetch(comm, S.dir, table, E.ends, info));
    /* one rank keeps everything: no destinations (16 MB of fresh memory at 4 M springs) */
    const bool route = size > 1;
    dest.clear();
    if (route) dest.reserve(S.si.size());
    send.reserve(S.si.size());
    for (size_t s = 0; s < S.si.size(); s++) {
      const VertexInfo &a = info[E.First(S, s)], &b = info[E.Second(S, s)];
      if (a.owner < 0 && b.owner < 0) continue; /* both ends fixed: no effect on the motion */
      MSimRoutedSpring r;
      r.va = S.si[s];
      r.vb = S.sj[s];
      r.ga = a.gnum;
      r.gb = b.gnum;
      r.k = S.sk[s];
      r.L = S.sL[s];
      const PetscMPIInt o = a.owner >= 0 ? a.owner : b.owner;
      send.push_back(r);
      if (route) dest.push_back(o);
      counts[0]++;
      if (a.owner >= 0 && b.owner >= 0) {
        counts[1]++;
        if (a.owner != b.owner) {
          counts[2]++;
          send.push_back(r);
          dest.push_back(b.owner);
        }
      }
    }
    /* the scene's springs are all in send now: freed before anything else is allocated (at
       4 M springs 96 MB, reused by what setup builds next) */
    for (auto *v : {&S.si, &S.sj}) std::vector<PetscInt>().swap(*v);
    for (auto *v : {&S.sk, &S.sL}) std::vector<PetscReal>().swap(*v);
    E.Free();
    std::vector<VertexInfo>().swap(info);
    PetscCall(MSimExchange(comm, dest, std::move(send), got));
    PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, counts, 3, MPIU_INT, MPI_SUM, comm));
    L.nspring_moving = counts[0];
    L.between_free   = counts[1];
    L.cut            = counts[2];
    /* an order that does not depend on the rank count: by input ids */
    send.clear();
    send.shrink_to_fit();
    /* generators emit their springs in this order, and the exchange keeps it (sources in rank
       order, each source's springs in its order): checking is one pass, sorting 4 M springs took
       0.08 s */
    const auto by_ids = [](const MSimRoutedSpring &u, const MSimRoutedSpring &v) { return u.va < v.va || (u.va == v.va && u.vb < v.vb); };
    if (!std::is_sorted(got.begin(), got.end(), by_ids)) std::sort(got.begin(), got.end(), by_ids);
    /* owned springs compacted in place (no second copy of every spring: fresh memory is the
       dearest part of setup), the few halo ones copied out */
    size_t nown = 0;
    for (size_t q = 0; q < got.size(); q++) {
      const PetscInt first = got[q].ga >= 0 ? got[q].ga : got[q].gb; /* decided the owner */
      if (first < L.rstart || first >= L.rstart + L.nown) L.halo.push_back(got[q]);
      else got[nown++] = got[q];
    }
    got.resize(nown);
    L.owned = std::move(got);
  }
  /* the rest positions of the fixed ends of owned springs, from the directory */
  {
    std::vector<Position> table(count), got;
    for (PetscInt v = 0; v < count; v++)
      for (int c = 0; c < 3; c++) table[v].x[c] = S.x0[3 * v + c];
    for (const MSimRoutedSpring &r : L.owned) {
      if (r.ga < 0) L.fixed_vid.push_back(r.va);
      if (r.gb < 0) L.fixed_vid.push_back(r.vb);
    }
    for (const MSimRoutedTet &t : L.tets)
      for (int q = 0; q < 4; q++)
        if (t.g[q] < 0) L.fixed_vid.push_back(t.v[q]);
    std::sort(L.fixed_vid.begin(), L.fixed_vid.end());
    L.fixed_vid.erase(std::unique(L.fixed_vid.begin(), L.fixed_vid.end()), L.fixed_vid.end());
    PetscCall(MSimFetch(comm, S.dir, table, L.fixed_vid, got));
    L.fixed_x0.resize(3 * got.size());
    for (size_t f = 0; f < got.size(); f++)
      for (int c = 0; c < 3; c++) L.fixed_x0[3 * f + c] = got[f].x[c];
  }
  PetscCall(PetscLogStagePop());
  PetscFunctionReturn(PETSC_SUCCESS);
}
