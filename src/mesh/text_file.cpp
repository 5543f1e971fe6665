#include "text_file.h"
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>
#include <sys/stat.h>

PetscErrorCode MSimTextFile::Load(const char file[])
{
  FILE       *fp;
  struct stat st;

  PetscFunctionBeginUser;
  name = file;
  fp   = fopen(file, "rb");
  PetscCheck(fp, PETSC_COMM_SELF, PETSC_ERR_FILE_OPEN, "%s: cannot open (%s)", file, strerror(errno));
  if (fstat(fileno(fp), &st) != 0 || !S_ISREG(st.st_mode)) {
    fclose(fp);
    SETERRQ(PETSC_COMM_SELF, PETSC_ERR_FILE_READ, "%s: not a regular file", file);
  }
  data.resize((size_t)st.st_size);
  size_t got = data.empty() ? 0 : fread(&data[0], 1, data.size(), fp);
  fclose(fp);
  PetscCheck(got == data.size(), PETSC_COMM_SELF, PETSC_ERR_FILE_READ, "%s: read %zu of %zu bytes", file, got, data.size());
  pos  = 0;
  line = 0;
  PetscFunctionReturn(PETSC_SUCCESS);
}

static inline bool IsSpace(char c)
{
  return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f';
}

bool MSimTextFile::NextLine(char comment)
{
  const char *base = data.data();
  const size_t end = data.size();
  while (pos < end) {
    const char *eol = (const char *)memchr(base + pos, '\n', end - pos);
    size_t      stop = eol ? (size_t)(eol - base) : end;
    size_t      q    = pos;
    line++;
    tok.clear();
    while (q < stop) {
      while (q < stop && IsSpace(base[q])) q++;
      if (q >= stop || (comment && base[q] == comment)) break;
      size_t s = q;
      while (q < stop && !IsSpace(base[q]) && !(comment && base[q] == comment)) q++;
      tok.push_back({base + s, q - s});
    }
    pos = eol ? stop + 1 : end;
    if (!tok.empty()) return true;
  }
  tok.clear();
  return false;
}

std::string MSimShowBytes(const char *p, size_t n)
{
  std::string s;
  for (size_t i = 0; i < n && s.size() < 32; i++) {
    unsigned char c = (unsigned char)p[i];
    if (c >= 32 && c < 127) s += (char)c;
    else {
      char hex[8];
      snprintf(hex, sizeof(hex), "\\x%02X", c);
      s += hex;
    }
  }
  if (n > 32) s += "...";
  return s;
}

std::string MSimTextFile::Show(size_t k) const
{
  return k < tok.size() ? MSimShowBytes(tok[k].p, tok[k].n) : "(nothing)";
}

bool MSimTextFile::Is(size_t k, const char word[]) const
{
  return k < tok.size() && strlen(word) == tok[k].n && !strncasecmp(tok[k].p, word, tok[k].n);
}

PetscErrorCode MSimTextFile::NeedTokens(size_t lo, size_t hi, const char what[]) const
{
  PetscFunctionBeginUser;
  if (lo == hi) PetscCheck(tok.size() == lo, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": %s needs %zu values, found %zu", MSIM_AT(*this), what, lo, tok.size());
  else PetscCheck(tok.size() >= lo && tok.size() <= hi, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": %s needs %zu to %zu values, found %zu", MSIM_AT(*this), what, lo, hi, tok.size());
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* Token k as a T by std::from_chars (a leading '+' allowed): 0 if it is one, 1 if it is not a
   number, 2 if it is out of T's range */
template <typename T>
static int ParseToken(const MSimToken &t, T *v)
{
  const char *p = t.p, *e = t.p + t.n;
  if (p < e && *p == '+') p++;
  auto r = std::from_chars(p, e, *v);
  if (r.ec == std::errc::result_out_of_range) return 2;
  return r.ec == std::errc() && r.ptr == e ? 0 : 1;
}

bool MSimTextFile::IsInt(size_t k) const
{
  int64_t v;
  return k < tok.size() && ParseToken(tok[k], &v) == 0;
}

bool MSimTextFile::IsReal(size_t k) const
{
  PetscReal v;
  return k < tok.size() && ParseToken(tok[k], &v) == 0;
}

/* token k as a T, or an error naming what: missing, out of T's range (overflow says how), or
   not a T at all (kind says what it should have been) */
template <class T>
static PetscErrorCode ParseAt(const MSimTextFile &tf, size_t k, const char what[], T *v, const char overflow[], const char kind[])
{
  PetscFunctionBeginUser;
  PetscCheck(k < tf.tok.size(), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": %s is missing", MSIM_AT(tf), what);
  const int bad = ParseToken(tf.tok[k], v);
  PetscCheck(bad != 2, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": %s %s is %s", MSIM_AT(tf), what, tf.Show(k).c_str(), overflow);
  PetscCheck(!bad, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": %s '%s' is not %s", MSIM_AT(tf), what, tf.Show(k).c_str(), kind);
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimTextFile::Int(size_t k, const char what[], int64_t *v) const
{
  return ParseAt(*this, k, what, v, "too large", "an integer");
}

PetscErrorCode MSimTextFile::Real(size_t k, const char what[], PetscReal *v) const
{
  PetscFunctionBeginUser;
  PetscCall(ParseAt(*this, k, what, v, "out of the range of a double", "a number"));
  PetscCheck(std::isfinite(*v), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": %s %s is not finite", MSIM_AT(*this), what, Show(k).c_str());
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimTextFile::Count(size_t k, const char what[], PetscInt *n) const
{
  int64_t v;

  PetscFunctionBeginUser;
  PetscCall(Int(k, what, &v));
  PetscCheck(v >= 0, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": %s %lld is negative", MSIM_AT(*this), what, (long long)v);
  PetscCheck(v <= PETSC_MAX_INT / 12, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": %s %lld is too large for this build's %d-bit indices", MSIM_AT(*this), what, (long long)v, (int)(8 * sizeof(PetscInt)));
  *n = (PetscInt)v;
  PetscFunctionReturn(PETSC_SUCCESS);
}
