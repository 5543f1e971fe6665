/* An option given twice in one options file. PETSc's options database holds one value per name and
   keeps the last, so the earlier lines vanish without a word: two -msim_contact_sphere lines made
   one sphere where the user meant two (the documented form is one option, 4 values per sphere).
   The database cannot tell (it never saw the first value), so the files themselves are read again,
   on rank 0, after PetscInitialize has read them (its syntax errors come first, in its words).
   An option whose value is a list of items is refused, naming the file and the lines; any other
   option repeated gets one warning line saying which value is used. A command-line option that
   overrides a file's (given after it) is PETSc's ordinary rule and is left alone, with the file's
   repeats of it, and so is an option repeated across two files. A list option given twice on the
   command line itself is refused the same way: the first obstacle vanished just as silently. */
#include <msim/errors.h>
#include <msim/options.h>
#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <vector>

/* msim's options whose value is a list of items (obstacles, vertex ids, spring families, terms):
   a second line is one more item the user meant to add, never a change of mind */
static const char *const kListOptions[] = {"msim_contact_plane", "msim_contact_sphere", "msim_contact_box", "msim_contact_mesh", "msim_contact_velocity", "msim_fix_list", "msim_springs", "msim_implicit_terms"};

/* whether the name (no dash, lower case) is one of kListOptions */
static bool IsList(const std::string &name)
{
  return std::any_of(std::begin(kListOptions), std::end(kListOptions), [&](const char *o) { return name == o; });
}

/* the option name of a command-line argument (no dash, lower case), or "" for a value: as
   PETSc's PetscOptionsValidKey, a key is a dash (or two) and a letter, and not a number such as
   -1e3 or -inf */
static std::string KeyName(const char *arg)
{
  if (arg[0] != '-') return "";
  const char *key = arg[1] == '-' ? arg + 1 : arg;
  char       *end;
  if (!isalpha((unsigned char)key[1])) return "";
  (void)strtod(key, &end);
  if (end != key && !(*end == '_' || isalnum((unsigned char)*end))) return "";
  std::string name(key + 1);
  std::transform(name.begin(), name.end(), name.begin(), ::tolower);
  return name;
}

/* "3 and 7", "3, 5 and 7" */
static std::string LineList(const std::vector<int> &lines)
{
  std::string s;
  for (size_t i = 0; i < lines.size(); i++) s += (i == 0 ? "" : i + 1 == lines.size() ? " and " : ", ") + std::to_string(lines[i]);
  return s;
}

/* "twice", "3 times" */
static std::string Times(const std::vector<int> &lines)
{
  return lines.size() == 2 ? "twice" : std::to_string(lines.size()) + " times";
}

/* whether PETSc reads the file as YAML (-options_file F.yml, F.yaml or F:yaml), whose keys are a
   mapping's and cannot repeat */
static bool IsYAML(const std::string &f)
{
  auto ends = [&](const char *e) { return f.size() >= strlen(e) && !strcasecmp(f.c_str() + f.size() - strlen(e), e); };
  return ends(".yml") || ends(".yaml") || ends(":yaml");
}

/* One plain options file, read as PetscOptionsInsertFile does (PETSc 3.18): '#' starts a comment
   anywhere on a line; a line holds one option and its value, or "alias -new -old"; -prefix_push P
   and -prefix_pop change the names that follow; -options_file F reads F, checked on its own. Names
   compare without regard to case, as in PETSc's database. The warnings are added to warnings.
   later: the names the command line gives after this file, whose values replace the file's. */
static PetscErrorCode CheckFile(const std::string &file, const std::set<std::string> &later, std::string &warnings)
{
  struct Given {
    std::string      typed, value;
    std::vector<int> lines;
  };
  std::ifstream                      in(file);
  std::map<std::string, Given>       given;
  std::map<std::string, std::string> alias;
  std::vector<std::string>           prefixes, order, nested;
  std::string                        line;

  /* a name as the database compares it: no dash, lower case */
  auto name_of = [](const std::string &token) {
    std::string name = token.substr(token.empty() || token[0] != '-' ? 0 : 1);
    std::transform(name.begin(), name.end(), name.begin(), ::tolower);
    return name;
  };

  PetscFunctionBeginUser;
  for (int n = 1; std::getline(in, line); n++) {
    std::istringstream ss(line.substr(0, line.find('#')));
    std::string        key, value;
    if (!(ss >> key)) continue;
    ss >> value;
    if (!strcasecmp(key.c_str(), "alias")) {
      std::string to;
      ss >> to;
      alias[name_of(value)] = name_of(to);
      continue;
    }
    const std::string lower = name_of(key);
    if (lower == "prefix_push") prefixes.push_back((prefixes.empty() ? "" : prefixes.back()) + value); /* pushed prefixes add up */
    else if (lower == "prefix_pop") {
      if (!prefixes.empty()) prefixes.pop_back();
    } else if (lower == "options_file") nested.push_back(value);
    else if (lower != "options_file_yaml") {
      const std::string typed = "-" + (prefixes.empty() ? "" : prefixes.back()) + key.substr(1);
      const std::string name  = name_of(typed);
      Given            &g     = given[name];
      if (g.lines.empty()) order.push_back(name);
      g.typed = typed;
      g.value = value;
      g.lines.push_back(n);
    }
  }
  /* an alias's two names are one option (PETSc sets the aliases before the file's values) */
  for (const auto &a : alias) {
    auto from = given.find(a.first), to = given.find(a.second);
    if (from == given.end() || to == given.end()) continue;
    Given &t = to->second;
    t.lines.insert(t.lines.end(), from->second.lines.begin(), from->second.lines.end());
    std::sort(t.lines.begin(), t.lines.end());
    if (from->second.lines.back() == t.lines.back()) t.value = from->second.value;
    given.erase(from);
  }
  std::vector<const Given *> repeated;
  for (const std::string &name : order) {
    auto it = given.find(name);
    if (it == given.end() || it->second.lines.size() < 2 || later.count(name)) continue; /* the command line's value counts */
    const Given &g = it->second;
    PetscCheck(!IsList(name), PETSC_COMM_SELF, PETSC_ERR_ARG_WRONG, "%s lines %s: %s is given %s, and only the last would be used: give all of them in one %s, comma-separated", file.c_str(), LineList(g.lines).c_str(), g.typed.c_str(), Times(g.lines).c_str(), g.typed.c_str());
    repeated.push_back(&g);
  }
  for (const Given *g : repeated)
    warnings += "msim: warning: " + file + " lines " + LineList(g->lines) + ": " + g->typed + " is given " + Times(g->lines) + "; only the last, " + (g->value.empty() ? "without a value" : g->value) + " (line " + std::to_string(g->lines.back()) + "), counts\n";
  for (const std::string &f : nested)
    if (!IsYAML(f)) PetscCall(CheckFile(f, later, warnings));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimCheckOptionsFileRepeats(MPI_Comm comm)
{
  int    argc;
  char **argv;

  PetscFunctionBeginUser;
  PetscCall(PetscGetArgs(&argc, &argv));
  PetscCall(MSimCallOnRankZero(comm, [&]() -> PetscErrorCode {
    std::string warnings; /* said once every file has passed: a refusal is the run's one line */
    std::map<std::string, int> given; /* the command line's list options: how often each is given */
    PetscFunctionBeginUser;
    for (int a = 1; a < argc; a++) {
      const std::string name = KeyName(argv[a]);
      if (!IsList(name)) continue;
      PetscCheck(++given[name] < 2, PETSC_COMM_SELF, PETSC_ERR_ARG_WRONG, "the command line gives %s twice, and only the last would be used: give all of them in one %s, comma-separated", argv[a], argv[a]);
    }
    for (int a = 1; a + 1 < argc; a++) {
      if (strcasecmp(argv[a], "-options_file") || IsYAML(argv[a + 1])) continue;
      std::set<std::string> later; /* PETSc inserts the arguments in order: those after the file replace its values */
      for (int b = a + 2; b < argc; b++)
        if (!KeyName(argv[b]).empty()) later.insert(KeyName(argv[b]));
      PetscCall(CheckFile(argv[a + 1], later, warnings));
    }
    PetscCall(PetscFPrintf(PETSC_COMM_SELF, PETSC_STDERR, "%s", warnings.c_str()));
    PetscFunctionReturn(PETSC_SUCCESS);
  }));
  PetscFunctionReturn(PETSC_SUCCESS);
}
