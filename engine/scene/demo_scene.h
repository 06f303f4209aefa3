// The built-in demo scene of `penumbra demo`: built in code, needs no scene or mesh file. A grey
// ground plane with a red sphere, a blue box, a gold (metallic) torus and a green cylinder on it,
// lit by a warm directional sun and two coloured point lights, seen by the camera "main";
// Cook-Torrance shading, ACES tone mapping, a dark blue background. Every entity is named
// (ecs::Name): "main", "sun", "warm lamp", "cool lamp", "ground", "sphere", "box", "torus",
// "cylinder".
//
//   if (!scene::buildDemoScene(engine.assets(), engine.scene(), error)) { report(error); }
//   renderer->renderFrame(engine, error);  // through the camera "main"
//
// Meshes are procedural primitives keyed by assets::primitiveKey (shared with identical
// primitives of scene files), materials are keyed "demo:<name>". Atomic like scene::loadScene: on
// failure `out` and the asset manager are unchanged; on success the scene that was in `out` is
// unloaded (its references released) and replaced.
#pragma once

#include <string>

#include "engine/assets/asset_manager.h"
#include "engine/scene/scene.h"

namespace penumbra::scene {

// The demo scene's camera name (also its RenderSettings::camera).
inline constexpr const char* kDemoCameraName = "main";

// Replaces `out` by the demo scene, which holds one reference per asset use (released by
// unloadScene). World transforms are computed; RenderSettings are the defaults but for shading,
// tone mapper, ambient, background and camera (640x360 unless the caller changes it).
bool buildDemoScene(assets::AssetManager& assets, Scene& out, std::string& error);

}  // namespace penumbra::scene
