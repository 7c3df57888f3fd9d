// Crash-safe file writes: the content goes to a temporary file in the same directory, is flushed
// to disk (fsync), and is renamed over the destination (atomic on POSIX file systems), after which
// the directory entry is synced. A reader sees either the old file or the complete new one, never
// a truncated one.
#pragma once

#include <string>

#include "homography_teach_repeat/common/status.h"

namespace homography_teach_repeat {

// Status kInvalidInput naming the path and the OS error (directory missing or read-only, disk
// full...). The temporary file is removed on failure.
Status writeFileAtomically(const std::string& path, const std::string& content);

// The whole file as a string; kInvalidInput naming the path when it cannot be read.
Expected<std::string> readWholeFile(const std::string& path);

}  // namespace homography_teach_repeat
