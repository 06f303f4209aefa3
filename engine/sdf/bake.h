// Mesh -> signed distance grid. Exact unsigned point-to-triangle distance (Ericson's region tests)
// over a BVH, multithreaded over grid cells; the sign from the generalized winding number, angle-
// weighted pseudonormals or ray parity. See docs/FORMATS.md for the .psdf file and
// docs/BENCHMARKS.md for speed and error.
#pragma once

#include <functional>
#include <string>

#include "engine/assets/mesh.h"
#include "engine/sdf/mesh_topology.h"
#include "engine/sdf/psdf.h"
#include "engine/sdf/sdf_grid.h"

namespace penumbra::sdf {

enum class SignMethod { Auto, Winding, Pseudonormal, Parity };
const char* toString(SignMethod m);
bool parseSignMethod(const std::string& text, SignMethod& out);

enum class BakeQuality { Low, Medium, High };  // automatic resolution only
const char* toString(BakeQuality q);           // "low", "medium", "high"
// The .psdf flag for the sign method a bake used (Auto, never a result, gives Unknown).
PsdfSign psdfSign(SignMethod m);

struct BakeSettings {
    uint32_t resolution = 0;  // voxels along the longest axis of the padded grid (0 = see voxelSize)
    double voxelSize = 0;     // used when resolution == 0; both 0 = automatic from quality
    uint32_t padding = 2;     // voxels added on every side of the mesh bounds
    SignMethod sign = SignMethod::Auto;
    BakeQuality quality = BakeQuality::Medium;
    uint32_t threads = 0;  // 0 = hardware concurrency
    // A closed mesh whose triangles all face inward (MeshDiagnostics::inwardOriented) is flipped
    // before the sign is computed, with a warning in the log, so its inside bakes negative.
    bool flipInsideOut = true;
    // Called from the baking threads' coordinator with progress in [0,1] and a phase name.
    std::function<void(double progress, const char* phase)> progress;
};

struct BakeTimings {
    double cleanupMs = 0, bvhMs = 0, distanceMs = 0, signMs = 0;
};

struct BakeResult {
    bool ok = false;
    std::string error;
    SdfGrid grid;
    MeshDiagnostics diagnostics;
    SignMethod signUsed = SignMethod::Auto;
    std::string signReason;  // e.g. "closed manifold -> pseudonormal"
    BakeTimings timings;
    float minDistance = 0, maxDistance = 0;
    uint64_t windingEvaluations = 0;  // winding-number (or parity) evaluations made by the sign phase
    bool flippedInsideOut = false;    // the mesh was inward-oriented and flipped (flipInsideOut)
};

// Grid resolution chosen when neither resolution nor voxelSize is set (documented in FORMATS.md).
uint32_t automaticResolution(const MeshDiagnostics& diagnostics, BakeQuality quality);

BakeResult bake(const assets::MeshData& mesh, const BakeSettings& settings);

}  // namespace penumbra::sdf
