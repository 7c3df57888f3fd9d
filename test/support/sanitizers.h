// Whether the test runs instrumented (AddressSanitizer, `HTR_SANITIZE=1 scripts/test`). A few long
// scenario tests skip there: the plain pass runs them, and the same code runs instrumented in the
// shorter tests of their suite (each such skip says so; docs/development.md).
#pragma once

namespace homography_teach_repeat::test_support {

#if defined(__SANITIZE_ADDRESS__)
inline constexpr bool kUnderSanitizers = true;
#else
inline constexpr bool kUnderSanitizers = false;
#endif

}  // namespace homography_teach_repeat::test_support
