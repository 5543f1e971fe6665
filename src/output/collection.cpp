/* A series' collection file (series.pvd, series.xdmf) to which a frame adds O(1) bytes, and which
   is, whenever a kill -9 stops the run, a well-formed XML document listing the frames added so
   far: a frame is listed from one write on, and stays listed.

   The file is HEAD ENTRIES CLOSE, CLOSE beginning with a slot of 4 spaces ("    \n  </Collection>
   \n</VTKFile>\n"). The first frame a run writes rewrites it whole (a temporary file renamed, as
   every file msim writes; this also drops what a restart leaves out); after that a frame writes
   only near the end, and its entry E goes in one of two ways.

   What a kill can leave of a write(): Linux copies a write to a regular file page by page and
   checks for a fatal signal only before each page (generic_perform_write, iomap's likewise), so a
   write that lies within one page of the file lands whole or not at all, and a longer one may stop
   at a page boundary, leaving a prefix. A write of spaces after the root element, or of text inside
   it, is harmless at any prefix. Nothing here relies on more (no fsync: a crash of the machine is
   not covered, as for every other file msim writes).

   In the page: when E CLOSE, written at CLOSE's offset, stays within one page, that one write turns
   the old document into the new one (whole or not at all). It is as long as what it covers, or
   padded with spaces to it, so nothing of the old ending stays behind.

   Across a page, E CLOSE in one write could stop at the boundary, leaving part of E over part of
   the old closing tags; instead, four writes, each leaving a well-formed document:
   1. spaces from the end of the file to the next page boundary, where needed so that 2. fits in one
      page: trailing whitespace, allowed after the root element;
   2. after them, in one page (so whole or not at all), the processing instruction
      "<?msim -->" E CLOSE "<?msim ?>": after the root, a processing instruction is allowed, and its
      content (E and CLOSE hold no "?>") ends at the first "?>";
   3. "!--" into the slot's last 3 bytes: text inside the root element;
   4. "<" into the slot's first byte, one byte: the slot is now "<!--", opening a comment that runs
      over the old closing tags, the "<?msim ?>" an earlier crossing left after them, the spaces
      and the "<?msim " of 2. (none holds "--") to the "-->" there. E is now inside the root,
      CLOSE closes it, and "<?msim ?>" is a processing instruction after it.
   Until 4. the document lists the old entries; from 4. on, the new one too. The next frame's write
   in the page covers the "<?msim ?>" left after CLOSE. The comments and instructions are dropped by
   a rewrite at the run's end (MSimCollectionClose), and by a restart, which reads the entries
   through MSimCollectionStripMarkup. An entry that would not fit in one page or would end the
   instruction early (none does) is written with the whole file instead. What this gives up: a
   program reading the file while a write is being copied (ParaView reloading mid-run) may see it
   half done and have to read again, where the rename it replaces was atomic for readers too. */
#include "collection.h"
#include <msim/output.h>
#include <algorithm>
#include <cerrno>
#include <fcntl.h>
#include <unistd.h>

static PetscErrorCode WriteAt(const MSimCollection *c, const std::string &s, off_t at)
{
  size_t done = 0;

  PetscFunctionBeginUser;
  while (done < s.size()) {
    const ssize_t w = pwrite(c->fd, s.data() + done, s.size() - done, at + (off_t)done);
    if (w < 0 && errno == EINTR) continue;
    PetscCheck(w > 0, PETSC_COMM_SELF, PETSC_ERR_FILE_WRITE, "write to %s failed (disk full?)", c->path.c_str());
    done += (size_t)w;
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* the document written whole under a temporary name and renamed, then opened for the writes in place */
static PetscErrorCode Rewrite(MSimCollection *c)
{
  const std::string doc = c->head + c->entries + c->close;

  PetscFunctionBeginUser;
  PetscCall(MSimWriteFileAtomic(c->path.c_str(), doc.data(), doc.size()));
  if (c->fd >= 0) close(c->fd);
  c->fd = open(c->path.c_str(), O_WRONLY | O_CLOEXEC);
  PetscCheck(c->fd >= 0, PETSC_COMM_SELF, PETSC_ERR_FILE_OPEN, "cannot open %s for writing", c->path.c_str());
  c->tail   = (off_t)(c->head.size() + c->entries.size());
  c->end    = (off_t)doc.size();
  c->untidy = false;
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimCollectionAppend(MSimCollection *c, const std::string &entry)
{
  const off_t page = (off_t)sysconf(_SC_PAGESIZE);

  PetscFunctionBeginUser;
  c->entries += entry;
  if (c->fd < 0) {
    PetscCall(Rewrite(c));
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  std::string here = entry + c->close;
  if (c->tail + (off_t)here.size() < c->end) here.append((size_t)(c->end - c->tail) - here.size(), ' ');
  if (c->tail / page == (c->tail + (off_t)here.size() - 1) / page) { /* in the page */
    PetscCall(WriteAt(c, here, c->tail));
    c->end = std::max(c->end, c->tail + (off_t)here.size());
    c->tail += (off_t)entry.size();
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  const std::string staged = "<?msim -->" + entry + c->close + "<?msim ?>";
  if ((off_t)staged.size() > page || entry.find("?>") != std::string::npos) {
    PetscCall(Rewrite(c));
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  off_t at = c->end;
  if (at / page != (at + (off_t)staged.size() - 1) / page) {
    const off_t next = (at / page + 1) * page;
    PetscCall(WriteAt(c, std::string((size_t)(next - at), ' '), at)); /* 1. */
    at = next;
  }
  PetscCall(WriteAt(c, staged, at));           /* 2. */
  PetscCall(WriteAt(c, "!--", c->tail + 1));   /* 3. */
  PetscCall(WriteAt(c, "<", c->tail));         /* 4. */
  c->tail   = at + (off_t)(sizeof("<?msim -->") - 1 + entry.size());
  c->end    = at + (off_t)staged.size();
  c->untidy = true;
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimCollectionClose(MSimCollection *c)
{
  PetscFunctionBeginUser;
  if (c->fd >= 0 && c->untidy) PetscCall(Rewrite(c));
  if (c->fd >= 0) close(c->fd);
  c->fd = -1;
  PetscFunctionReturn(PETSC_SUCCESS);
}

std::string MSimCollectionStripMarkup(const std::string &text)
{
  std::string out;
  size_t      at = 0;
  while (at < text.size()) {
    const size_t lt = text.find('<', at);
    if (lt == std::string::npos) {
      out.append(text, at, std::string::npos);
      break;
    }
    out.append(text, at, lt - at);
    const bool   comment = text.compare(lt, 4, "<!--") == 0, pi = text.compare(lt, 2, "<?") == 0;
    const size_t stop    = comment ? text.find("-->", lt + 4) : pi ? text.find("?>", lt + 2) : lt;
    if (comment || pi) at = stop == std::string::npos ? text.size() : stop + (comment ? 3 : 2);
    else {
      out += '<';
      at = lt + 1;
    }
  }
  return out;
}
