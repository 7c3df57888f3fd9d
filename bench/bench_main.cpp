// The main of every benchmark: the process's memory set up as the nodes set it
// (common/process_memory.h: freed frame buffers stay in the process), so a benchmark times what
// the robot runs. `--keep_freed_memory=0` leaves glibc's defaults, for comparison; the JSON's
// context says which (keep_freed_memory: "true", "false", or "unavailable").
#include <benchmark/benchmark.h>

#include <cstring>
#include <string>

#include "homography_teach_repeat/common/process_memory.h"

int main(int argc, char** argv) {
  bool keep = true;
  int kept_args = 1;
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--keep_freed_memory=0") == 0) {
      keep = false;
    } else if (std::strcmp(argv[i], "--keep_freed_memory=1") != 0) {
      argv[kept_args++] = argv[i];
    }
  }
  argc = kept_args;
  const std::string kept =
      !keep ? "false" : (homography_teach_repeat::keepFreedMemoryForReuse() ? "true" : "unavailable");
  benchmark::AddCustomContext("keep_freed_memory", kept);
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
