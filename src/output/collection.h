/* A series' collection file (series.pvd, series.xdmf) that grows by each frame's entry in place:
   see collection.cpp. Rank 0 only. */
#pragma once
#include <petscsys.h>
#include <string>
#include <sys/types.h>

struct MSimCollection {
  std::string path;
  std::string head, close; /* the document before the entries and after them; close begins with
                              a slot of 4 spaces (collection.cpp) */
  std::string entries;     /* the entries listed, in order: those a restart keeps, then this run's */
  int         fd   = -1;   /* open once the file has been written whole in this run */
  off_t       tail = 0;    /* where close begins in the file */
  off_t       end  = 0;    /* the file's size */
  bool        untidy = false; /* the file holds a frame added across a page (comments, a PI) */
};

/* The entry at the end of the list: the file is written whole at the first call in a run, later
   only the entry and close are written in place */
PetscErrorCode MSimCollectionAppend(MSimCollection *c, const std::string &entry);
/* At the end of a run: a file left untidy is written whole once more, then closed */
PetscErrorCode MSimCollectionClose(MSimCollection *c);
/* TEXT without its comments and processing instructions, for reading back the entries a file lists */
std::string MSimCollectionStripMarkup(const std::string &text);
