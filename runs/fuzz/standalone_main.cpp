/* Runs a fuzz harness over the files named (or every file of the directories named), once each:
   the seed corpus in ctest, in a build without libFuzzer. Prints how many ran. */
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <vector>

extern "C" int LLVMFuzzerInitialize(int *, char ***);
extern "C" int LLVMFuzzerTestOneInput(const uint8_t *, size_t);

int main(int argc, char **argv)
{
  std::vector<std::filesystem::path> files; /* absolute: a harness may change directory */
  for (int a = 1; a < argc; a++) {
    if (std::filesystem::is_directory(argv[a])) {
      for (const auto &e : std::filesystem::directory_iterator(argv[a]))
        if (e.is_regular_file()) files.push_back(std::filesystem::absolute(e.path()));
    } else files.push_back(std::filesystem::absolute(argv[a]));
  }
  if (LLVMFuzzerInitialize(&argc, &argv)) return 1;
  for (const auto &f : files) {
    std::ifstream        in(f, std::ios::binary);
    std::vector<uint8_t> data((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    LLVMFuzzerTestOneInput(data.data(), data.size());
  }
  std::printf("%zu inputs ran without a crash\n", files.size());
  return 0;
}
