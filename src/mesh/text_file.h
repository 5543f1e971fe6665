/* A text file read whole into memory and walked line by line, its tokens parsed in place: the
   readers of OFF, OBJ, ASCII STL and TetGen files share it, so every one of them names the file
   and line of a fault the same way, and none of them pays for streams (a 10^7-tet .ele file is
   about 400 MB of text). Lines may end in LF or CRLF; '#' starts a comment where the format has
   them. Every check is a PETSc error on PETSC_COMM_SELF. */
#pragma once
#include <msim/petsc_compat.h>
#include <algorithm>
#include <cstdint>
#include <string>
#include <vector>

struct MSimToken {
  const char *p;
  size_t      n;
};

class MSimTextFile {
public:
  std::string            name; /* as given, for messages */
  std::string            data; /* the whole file */
  PetscInt               line = 0;  /* number of the current line (1-based) */
  std::vector<MSimToken> tok;  /* tokens of the current line */

  /* Reads the whole file; a file that does not open is an error naming it and the reason. */
  PetscErrorCode Load(const char file[]);
  /* Next line that has a token (comment text after `comment` removed; 0: none). False at the end. */
  bool NextLine(char comment);
  /* The bytes not yet read (to bound counts by what the file can hold). */
  size_t Remaining() const { return data.size() - pos; }

  /* Token k of the current line as an integer, a finite real, or a count of records (>= 0, and
     small enough for this build's indices); `what` names it in the message. */
  PetscErrorCode Int(size_t k, const char what[], int64_t *v) const;
  PetscErrorCode Real(size_t k, const char what[], PetscReal *v) const;
  PetscErrorCode Count(size_t k, const char what[], PetscInt *n) const;
  /* Whether token k is an integer, a real (without raising an error: for telling one kind of
     line from another) */
  bool IsInt(size_t k) const;
  bool IsReal(size_t k) const;
  /* What to reserve for n records of at least min_bytes each: no more than the rest of the file
     can hold, so a corrupt count never allocates gigabytes (the reader then finds the file short
     and says so). */
  size_t Reserve(PetscInt n, size_t min_bytes) const { return std::min((size_t)n, Remaining() / min_bytes + 1); }
  /* Token k printed safely (control bytes as \xNN, at most 32 characters). */
  std::string Show(size_t k) const;
  bool        Is(size_t k, const char word[]) const; /* case-insensitive */
  /* Fails unless the current line has between lo and hi tokens. */
  PetscErrorCode NeedTokens(size_t lo, size_t hi, const char what[]) const;

private:
  size_t pos = 0;
};

/* n bytes from p printed safely for a message: control and other bytes as \xNN, at most 32
   characters, "..." after a longer run */
std::string MSimShowBytes(const char *p, size_t n);

/* "FILE line N" for messages */
#define MSIM_AT(tf) (tf).name.c_str(), (tf).line
