// Embedding penumbra: create an engine, build a World in code (or load a scene file), render it
// offscreen on a chosen backend, read the pixels back and print the per-pass timings.
//
//   embed_example [--backend vulkan|gl] [--scene file.json] [-o out.png]
//
// Exits 0 when the frame shows the lit sphere in front of the background, 1 otherwise.
#include <cstdio>
#include <cstring>
#include <string>

#include "engine/assets/primitives.h"
#include "engine/ecs/components.h"
#include "engine/engine.h"
#include "engine/image/image.h"
#include "engine/scene/mesh_sdf.h"
#include "renderer/renderer.h"

namespace {

using namespace penumbra;

// A ground plane, a red sphere, a camera looking at it and two lights.
bool buildWorld(Engine& engine, std::string& error) {
    ecs::World& world = engine.world();
    assets::AssetManager& assets = engine.assets();
    scene::Scene& scene = engine.scene();

    assets::MeshData sphereMesh, groundMesh;
    if (!assets::makeSphere(1.0f, 48, 24, sphereMesh, error) ||
        !assets::makePlane({6.0f, 6.0f}, groundMesh, error))
        return false;
    const assets::AssetId sphere = assets.addMesh("example:sphere", std::move(sphereMesh), error);
    const assets::AssetId ground = assets.addMesh("example:ground", std::move(groundMesh), error);
    if (!sphere || !ground) return false;
    ecs::Material red;
    red.baseColor = {0.8f, 0.1f, 0.08f, 1.0f};
    red.roughness = 0.35f;
    ecs::Material grey;
    grey.baseColor = {0.5f, 0.5f, 0.5f, 1.0f};
    const assets::AssetId redId = assets.addMaterial("example:red", red);
    const assets::AssetId greyId = assets.addMaterial("example:grey", grey);
    // The scene holds one reference per asset use and releases them when it is unloaded.
    scene.assetRefs.insert(scene.assetRefs.end(), {sphere, ground, redId, greyId});

    ecs::Entity ball = world.create();
    world.add<ecs::Transform>(ball)->position = {0.0f, 1.0f, 0.0f};
    world.add<ecs::MeshRenderer>(ball, ecs::MeshRenderer{sphere, redId});
    ecs::Entity floor = world.create();
    world.add<ecs::Transform>(floor);
    world.add<ecs::MeshRenderer>(floor, ecs::MeshRenderer{ground, greyId});

    ecs::Entity camera = world.create();
    ecs::Transform* ct = world.add<ecs::Transform>(camera);
    ct->position = {0.0f, 1.5f, 5.0f};
    ct->rotation = glm::angleAxis(-0.1f, glm::vec3(1, 0, 0));
    world.add<ecs::Camera>(camera)->name = "main";

    ecs::Entity sun = world.create();
    world.add<ecs::Transform>(sun)->rotation = glm::angleAxis(-0.9f, glm::normalize(glm::vec3(1, 0.3f, 0)));
    ecs::Light* sunLight = world.add<ecs::Light>(sun);
    sunLight->type = ecs::LightType::Directional;
    sunLight->intensity = 3.0f;
    ecs::Entity lamp = world.create();
    world.add<ecs::Transform>(lamp)->position = {2.0f, 2.5f, 2.0f};
    ecs::Light* lampLight = world.add<ecs::Light>(lamp);
    lampLight->intensity = 20.0f;
    lampLight->range = 12.0f;

    engine.settings().background = {0.02f, 0.03f, 0.05f};
    return true;
}

}  // namespace

int main(int argc, char** argv) {
    std::string backendName = "auto", scenePath, output = "embed_example.png";
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        if ((a == "--backend" || a == "--scene" || a == "-o") && i + 1 < argc) {
            (a == "--backend" ? backendName : a == "--scene" ? scenePath : output) = argv[++i];
        } else {
            std::fprintf(stderr, "usage: %s [--backend vulkan|gl] [--scene file.json] [-o out.png]\n",
                         argv[0]);
            return a == "--help" || a == "-h" ? 0 : 2;
        }
    }

    std::string error;
    std::unique_ptr<Engine> engine = Engine::create({}, error);
    if (!engine) {
        std::fprintf(stderr, "engine: %s\n", error.c_str());
        return 1;
    }
    // A loaded scene's render.meshSdf (default auto: with shadows or AO on, its meshes get coarse
    // baked fields so that they cast SDF shadows and AO; engine/scene/mesh_sdf.h).
    const bool ok = scenePath.empty() ? buildWorld(*engine, error)
                                      : engine->loadScene(scenePath, error) &&
                                            scene::applyMeshSdf(engine->scene(), engine->assets(),
                                                                engine->settings().meshSdf, error);
    if (!ok) {
        std::fprintf(stderr, "scene: %s\n", error.c_str());
        return 1;
    }

    RendererDesc desc;
    if (!rhi::parseBackend(backendName, desc.backend)) {
        std::fprintf(stderr, "unknown backend '%s'\n", backendName.c_str());
        return 2;
    }
    desc.width = 160;
    desc.height = 120;
    std::unique_ptr<Renderer> renderer = Renderer::create(*engine, desc, error);
    if (!renderer) {
        std::fprintf(stderr, "renderer: %s\n", error.c_str());
        return 1;
    }
    engine->update(0.0);  // transforms
    ImageRGBA8 image;
    if (!renderer->renderFrame(*engine, error) || !renderer->readPixels(image, error)) {
        std::fprintf(stderr, "frame: %s\n", error.c_str());
        return 1;
    }
    std::printf("%s on %s: %ux%u\n", rhi::toString(renderer->device().info().backend),
                renderer->device().info().deviceName.c_str(), image.width, image.height);
    for (const auto& pass : renderer->stats().passes)
        std::printf("  %-14s GPU %8.3f ms  CPU %8.3f ms\n", pass.name.c_str(), pass.gpuMs, pass.cpuMs);
    if (!writePng(output, image, &error)) {
        std::fprintf(stderr, "%s\n", error.c_str());
        return 1;
    }
    if (scenePath.empty()) {
        // The sphere covers the image centre and is lit red; the top-left corner is background.
        const uint8_t* centre = image.at(image.width / 2, image.height / 2);
        const uint8_t* corner = image.at(0, 0);
        std::printf("centre %u %u %u, corner %u %u %u\n", centre[0], centre[1], centre[2], corner[0],
                    corner[1], corner[2]);
        if (!(centre[0] > corner[0] + 40 && centre[0] > centre[1] + 30)) {
            std::fprintf(stderr, "the sphere is not where it should be\n");
            return 1;
        }
    }
    std::printf("wrote %s\n", output.c_str());
    return 0;
}
