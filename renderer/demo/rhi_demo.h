// The RHI demo frame: the default job until the SDF renderer exists. One frame graph with
//   trace  (compute)  sphere-traces an analytic scene (spheres, a box, a plane and a sampled 3D
//                     distance texture) into a G-buffer (normal + material id, view depth),
//   depth  (raster)   converts the traced depth into a hardware depth buffer,
//   mesh   (raster)   draws an indexed triangle mesh with depth test into the same G-buffer,
//   shade  (raster)   full-screen deferred shading with sphere-traced soft shadows.
// It exercises compute, raster, 3D-texture trilinear sampling, barriers and readback.
#pragma once

#include <string>
#include <vector>

#include "engine/image/image.h"
#include "renderer/frame_graph/frame_graph.h"
#include "rhi/device.h"

namespace penumbra::demo {

struct DemoSettings {
    uint32_t width = 640;
    uint32_t height = 360;
    uint32_t volumeResolution = 32;  // edge of the sampled 3D distance texture
};

struct DemoResult {
    bool ok = false;
    std::string error;
    ImageRGBA8 image;
    std::vector<fg::PassTiming> timings;  // per executed pass, in order
    std::string graphviz;                 // the frame graph of the frame
};

// Renders one frame on `device` and reads it back. Never throws; on failure ok=false and `error`.
DemoResult renderDemoFrame(rhi::Device& device, const DemoSettings& settings = {});

// The CPU-side distance function stored in the demo's 3D texture (local box coordinates, world
// units); exposed for tests.
float demoVolumeDistance(float x, float y, float z);

}  // namespace penumbra::demo
