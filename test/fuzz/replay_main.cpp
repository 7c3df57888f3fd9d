// Corpus replay: runs a libFuzzer target's LLVMFuzzerTestOneInput on every file named on the command
// line (a folder: every file in it, in name order), once each, without the fuzzing engine. Built by
// the catkin build with the compiler of the build (g++; under HTR_SANITIZE=ON with AddressSanitizer
// and UBSan), registered as the ctests fuzz_corpus_<target> over test/fuzz/corpus/<target>/: the
// inputs fuzzing kept are regression tests of every build. Fuzzing itself is scripts/fuzz
// (clang, libFuzzer; docs/reliability.md).
//   fuzz_replay_<target> FILE_OR_FOLDER...
// Exit 0 after every input ran; 1 on an unreadable path or an empty corpus. A finding traps
// (SIGILL) or is a sanitizer report, as under libFuzzer; the input being run is printed first.
#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size);

namespace {

namespace fs = std::filesystem;

bool collectInputs(const fs::path& path, std::vector<fs::path>& inputs) {
  std::error_code error;
  if (fs::is_directory(path, error)) {
    std::vector<fs::path> files;
    for (const auto& entry : fs::directory_iterator(path, error)) {
      if (entry.is_regular_file()) files.push_back(entry.path());
    }
    if (error) return false;
    std::sort(files.begin(), files.end());
    inputs.insert(inputs.end(), files.begin(), files.end());
    return true;
  }
  if (fs::is_regular_file(path, error)) {
    inputs.push_back(path);
    return true;
  }
  return false;
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<fs::path> inputs;
  for (int k = 1; k < argc; ++k) {
    if (!collectInputs(argv[k], inputs)) {
      std::fprintf(stderr, "fuzz replay: %s is neither a readable file nor a folder\n", argv[k]);
      return 1;
    }
  }
  if (inputs.empty()) {
    std::fprintf(stderr, "usage: %s FILE_OR_FOLDER...  (no input found)\n", argc > 0 ? argv[0] : "fuzz_replay");
    return 1;
  }
  for (const auto& input : inputs) {
    std::ifstream in(input, std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    if (!in.good() && !in.eof()) {
      std::fprintf(stderr, "fuzz replay: cannot read %s\n", input.c_str());
      return 1;
    }
    std::fprintf(stderr, "fuzz replay: %s (%zu bytes)\n", input.c_str(), bytes.size());
    LLVMFuzzerTestOneInput(reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size());
  }
  std::printf("fuzz replay: %zu inputs ran\n", inputs.size());
  return 0;
}
