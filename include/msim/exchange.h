/* The two tools the distributed setup is built from.
   - A block layout of ids [0, n): rank r holds [start(r), start(r + 1)), the first n % size ranks
     one more than the others. For input vertex ids it is the scene's *directory*: the rank that
     knows a vertex's position, mass, fixed flag and, once partitioned, its owner and global
     number; other ranks ask it (MSimFetch).
   - A personalized all-to-all of plain records (MSimExchange): each record goes to its rank, and
     arrives grouped by source rank in rank order, in the sender's order within a source. Memory
     and messages grow with the records a rank sends and receives, never with the whole scene. */
#pragma once
#include <msim/petsc_compat.h>
#include <algorithm>
#include <initializer_list>
#include <vector>

struct MSimBlockLayout {
  PetscInt    n = 0;
  PetscMPIInt size = 1;
  PetscInt    base = 0, rem = 0; /* n = base * size + rem */
  void        Set(PetscInt n_, PetscMPIInt size_)
  {
    n    = n_;
    size = size_;
    base = n / size;
    rem  = n % size;
  }
  PetscInt    Start(PetscMPIInt r) const { return r * base + std::min<PetscInt>(r, rem); }
  PetscInt    Count(PetscMPIInt r) const { return base + (r < rem ? 1 : 0); }
  PetscMPIInt Owner(PetscInt id) const
  {
    const PetscInt big = rem * (base + 1);
    return id < big ? (PetscMPIInt)(id / (base + 1)) : (PetscMPIInt)(rem + (id - big) / base);
  }
};

/* Sends send[k] to rank dest[k]; recv gets what every rank sent here (src[k]: its source rank, if
   asked for). Collective. The moving form hands send's storage over where it can (one rank) and
   leaves send empty. */
template <typename T>
PetscErrorCode MSimExchange(MPI_Comm comm, const std::vector<PetscMPIInt> &dest, const std::vector<T> &send, std::vector<T> &recv, std::vector<PetscMPIInt> *src = nullptr)
{
  PetscMPIInt              size;
  MPI_Datatype             type;
  std::vector<PetscMPIInt> scount, rcount, sdispl, rdispl;
  std::vector<T>           sorted;

  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Comm_size(comm, &size));
  if (size == 1) { /* one rank: everything stays, one copy */
    recv.assign(send.begin(), send.end());
    if (src) src->assign(recv.size(), 0);
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  scount.assign(size, 0);
  rcount.assign(size, 0);
  sdispl.assign(size + 1, 0);
  rdispl.assign(size + 1, 0);
  for (PetscMPIInt d : dest) scount[d]++;
  for (PetscMPIInt r = 0; r < size; r++) sdispl[r + 1] = sdispl[r] + scount[r];
  sorted.resize(send.size());
  {
    std::vector<PetscMPIInt> next(sdispl.begin(), sdispl.end() - 1);
    for (size_t k = 0; k < send.size(); k++) sorted[next[dest[k]]++] = send[k];
  }
  PetscCallMPI(MPI_Alltoall(scount.data(), 1, MPI_INT, rcount.data(), 1, MPI_INT, comm));
  for (PetscMPIInt r = 0; r < size; r++) rdispl[r + 1] = rdispl[r] + rcount[r];
  recv.resize(rdispl[size]);
  PetscCallMPI(MPI_Type_contiguous((int)sizeof(T), MPI_BYTE, &type));
  PetscCallMPI(MPI_Type_commit(&type));
  PetscCallMPI(MPI_Alltoallv(sorted.data(), scount.data(), sdispl.data(), type, recv.data(), rcount.data(), rdispl.data(), type, comm));
  PetscCallMPI(MPI_Type_free(&type));
  if (src) {
    src->resize(recv.size());
    for (PetscMPIInt r = 0; r < size; r++)
      for (PetscMPIInt k = rdispl[r]; k < rdispl[r + 1]; k++) (*src)[k] = r;
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

template <typename T>
PetscErrorCode MSimExchange(MPI_Comm comm, const std::vector<PetscMPIInt> &dest, std::vector<T> &&send, std::vector<T> &recv, std::vector<PetscMPIInt> *src = nullptr)
{
  PetscMPIInt size;

  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Comm_size(comm, &size));
  if (size == 1) {
    recv.swap(send);
    send.clear();
    send.shrink_to_fit();
    if (src) src->assign(recv.size(), 0);
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  PetscCall(MSimExchange(comm, dest, (const std::vector<T> &)send, recv, src));
  send.clear();
  send.shrink_to_fit();
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* Questions to ranks, answers back: question k goes to rank dest[k]; there `answer(asked, replies)`
   fills one reply per question received (asked: every question received, grouped by source);
   replies[k] answers question k. Collective. */
template <typename Q, typename A, typename F>
PetscErrorCode MSimAsk(MPI_Comm comm, const std::vector<PetscMPIInt> &dest, const std::vector<Q> &questions, F &&answer, std::vector<A> &replies)
{
  PetscMPIInt              size;
  std::vector<PetscMPIInt> from;
  std::vector<Q>           asked;
  std::vector<A>           answers, got;

  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Comm_size(comm, &size));
  PetscCall(MSimExchange(comm, dest, questions, asked, &from));
  answers.resize(asked.size());
  PetscCall(answer(asked, answers));
  asked.clear();
  asked.shrink_to_fit();
  PetscCall(MSimExchange(comm, from, answers, got));
  /* answers come back grouped by the rank asked, in the order asked there: undo the grouping */
  std::vector<size_t> next(size + 1, 0);
  for (PetscMPIInt d : dest) next[d + 1]++;
  for (PetscMPIInt r = 0; r < size; r++) next[r + 1] += next[r];
  replies.resize(questions.size());
  for (size_t k = 0; k < questions.size(); k++) replies[k] = got[next[dest[k]]++];
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* Looks up ids in a table distributed by `layout` (rank r holds the records of its block, table[id
   - start(r)]): out[k] is the record of ids[k]. Collective. */
template <typename T>
PetscErrorCode MSimFetch(MPI_Comm comm, const MSimBlockLayout &layout, const std::vector<T> &table, const std::vector<PetscInt> &ids, std::vector<T> &out)
{
  PetscMPIInt              rank;
  std::vector<PetscMPIInt> dest(ids.size());

  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Comm_rank(comm, &rank));
  for (size_t k = 0; k < ids.size(); k++) dest[k] = layout.Owner(ids[k]);
  const PetscInt start = layout.Start(rank);
  PetscCall(MSimAsk(
    comm, dest, ids,
    [&](const std::vector<PetscInt> &asked, std::vector<T> &answers) {
      for (size_t k = 0; k < asked.size(); k++) answers[k] = table[asked[k] - start];
      return PETSC_SUCCESS;
    },
    out));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* The distinct ids of some lists (ascending, into unique) and a table over their range: pos[v - lo]
   is id v's index among them (-1: absent). Built only where the range is at most max_span wide
   (returns false otherwise, with nothing built): a marker array over the range then replaces
   sorting and binary search. */
inline bool MSimIdTable(std::initializer_list<const std::vector<PetscInt> *> lists, size_t max_span, PetscInt &lo, std::vector<PetscInt> &pos, std::vector<PetscInt> &unique)
{
  PetscInt hi = PETSC_MIN_INT;
  lo          = PETSC_MAX_INT;
  unique.clear();
  pos.clear();
  for (const auto *l : lists)
    if (!l->empty()) {
      const auto mm = std::minmax_element(l->begin(), l->end());
      lo            = std::min(lo, *mm.first);
      hi            = std::max(hi, *mm.second);
    }
  if (hi < lo || (size_t)(hi - lo) + 1 > max_span) return false;
  pos.assign(hi - lo + 1, -1);
  for (const auto *l : lists)
    for (PetscInt v : *l) pos[v - lo] = 0;
  for (PetscInt k = 0; k <= hi - lo; k++)
    if (pos[k] == 0) {
      pos[k] = (PetscInt)unique.size();
      unique.push_back(lo + k);
    }
  return true;
}

/* The distinct ids of a list (ascending) and each entry's index among them. Where the ids span a
   range not much wider than the list (the common case: a rank's cells name vertices near its
   block) the table of MSimIdTable answers; otherwise sorting and binary search. */
inline void MSimCompactIds(const std::vector<PetscInt> &list, std::vector<PetscInt> &unique, std::vector<PetscInt> &index)
{
  std::vector<PetscInt> pos;
  PetscInt              lo;

  index.resize(list.size());
  if (MSimIdTable({&list}, 4 * list.size() + 1024, lo, pos, unique)) {
    for (size_t q = 0; q < list.size(); q++) index[q] = pos[list[q] - lo];
  } else {
    unique = list;
    std::sort(unique.begin(), unique.end());
    unique.erase(std::unique(unique.begin(), unique.end()), unique.end());
    for (size_t q = 0; q < list.size(); q++) index[q] = (PetscInt)(std::lower_bound(unique.begin(), unique.end(), list[q]) - unique.begin());
  }
}
