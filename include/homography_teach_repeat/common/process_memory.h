// The memory of a process that handles images frame after frame.
//
// Feature detection allocates and frees buffers of megabytes every frame (SIFT's scale space of a
// 640x480 image, doubled first: tens of MB). glibc's malloc returns a freed block above its mmap
// threshold to the kernel, and trims the heap's top above its trim threshold; the next frame's
// buffers are then fresh pages that the kernel maps and zeroes on first touch. Measured on the
// repeat's whole frame (bench_repeat_localizer BM_RepeatFrames, 2 cores): a frame that detects
// SIFT features took 2-3 times as long that way (docs/design.md, "Frame buffers").
#pragma once

namespace homography_teach_repeat {

// Keeps freed memory in the process for the next frame's buffers: blocks up to glibc's largest
// mmap threshold (32 MiB on 64-bit) come from the heap, and the heap is trimmed only above 1 GiB
// free at its top. The process's resident memory then stays at its peak working set instead of
// falling between frames. Affects the whole process (a nodelet manager included); call it once at
// start-up. Returns false where it cannot (a C library other than glibc, or an allocator that
// replaces malloc and refuses the settings, such as AddressSanitizer's): the process then runs as
// before.
bool keepFreedMemoryForReuse();

// The peak resident memory of this process so far [MiB] (VmHWM of /proc/self/status); -1 where
// the system does not tell (not Linux).
double peakResidentMiB();

}  // namespace homography_teach_repeat
