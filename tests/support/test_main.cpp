// Test main shared by every test executable: `--backend vulkan|gl` (or PENUMBRA_BACKEND) limits
// the GPU tests to one backend; everything else goes to GoogleTest.
#include <gtest/gtest.h>

#include "support/test_device.h"

int main(int argc, char** argv) {
    penumbra::test::parseTestArgs(argc, argv);
    testing::InitGoogleTest(&argc, argv);
    return RUN_ALL_TESTS();
}
