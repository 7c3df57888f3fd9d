#include <gtest/gtest.h>

#include <cstdlib>
#include <cstring>

#include "homography_teach_repeat/common/process_memory.h"

#if defined(__GLIBC__)
#include <malloc.h>
#endif

using namespace homography_teach_repeat;

#if defined(__GLIBC__) && !defined(__SANITIZE_ADDRESS__)
// A freed image-sized block stays in the process (glibc's default would return it to the kernel:
// a 16 MB block is above its initial 128 KiB mmap threshold).
TEST(ProcessMemory, AFreedFrameBufferStaysInTheProcess) {
  ASSERT_TRUE(keepFreedMemoryForReuse());
  constexpr std::size_t kBytes = 16 * 1024 * 1024;
  const std::size_t mapped_before = mallinfo2().hblkhd;
  auto* buffer = static_cast<char*>(std::malloc(kBytes));
  ASSERT_NE(buffer, nullptr);
  std::memset(buffer, 1, kBytes);
  EXPECT_EQ(mallinfo2().hblkhd, mapped_before) << "the block was mapped on its own, not taken from the heap";
  std::free(buffer);
  EXPECT_GE(mallinfo2().fordblks, kBytes) << "the freed block was given back to the kernel";
}
#else
TEST(ProcessMemory, AFreedFrameBufferStaysInTheProcess) {
  GTEST_SKIP() << "glibc's malloc is not this process's allocator (another C library or a sanitizer)";
}
#endif

TEST(ProcessMemory, CallingAgainIsHarmless) {
  const bool first = keepFreedMemoryForReuse();
  EXPECT_EQ(keepFreedMemoryForReuse(), first);
}
