// Test main shared by every test executable: `--backend vulkan|gl` (or PENUMBRA_BACKEND) limits
// the GPU tests to one backend; everything else goes to GoogleTest.
#include <gtest/gtest.h>

#include "support/test_device.h"

int main(int argc, char** argv) {
    penumbra::test::parseTestArgs(argc, argv);
    testing::InitGoogleTest(&argc, argv);
    return RUN_ALL_TESTS();
}

#if defined(__SANITIZE_ADDRESS__)
// Mesa's drivers are dlclose()d before LeakSanitizer symbolises its report, which then shows a
// spurious 128-byte leak with no stack. Keeping shared objects loaded removes it; real leaks in
// our code are still reported.
extern "C" int dlclose(void*) { return 0; }
#endif
