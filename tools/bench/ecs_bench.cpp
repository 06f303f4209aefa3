// ECS benchmarks (Google Benchmark): iterating 1M entities with two components, creating 1M
// entities. Counters report time per entity ("per_entity", in seconds with SI prefix).
#include <benchmark/benchmark.h>

#include <memory>

#include "engine/ecs/components.h"
#include "engine/ecs/world.h"

namespace {

using namespace penumbra::ecs;

constexpr int64_t kEntities = 1'000'000;

struct Velocity {
    glm::vec3 value{0.0f};
};

// A compact transform-like component (position, rotation, scale: 40 bytes).
struct Pose {
    glm::vec3 position{0.0f};
    glm::quat rotation{1.0f, 0.0f, 0.0f, 0.0f};
    glm::vec3 scale{1.0f};
};

void perEntity(benchmark::State& state, int64_t n) {
    state.SetItemsProcessed(state.iterations() * n);
    state.counters["per_entity"] = benchmark::Counter(
        double(n), benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}

// Every `stride`-th entity gets a Velocity (1 = all of them).
template <typename T>
std::unique_ptr<World> makeWorld(int64_t n, int64_t stride) {
    auto world = std::make_unique<World>();
    for (int64_t i = 0; i < n; ++i) {
        const Entity e = world->create();
        world->add<T>(e)->position = glm::vec3(float(i), 0.0f, 0.0f);
        if (i % stride == 0) world->add<Velocity>(e, glm::vec3(1.0f, 0.5f, 0.25f));
    }
    return world;
}

template <typename T>
void BM_IterateRangeFor(benchmark::State& state) {
    const int64_t stride = state.range(0);
    auto world = makeWorld<T>(kEntities, stride);
    const float dt = 1.0f / 60.0f;
    for (auto _ : state) {
        for (auto [e, t, v] : world->template view<T, const Velocity>()) t.position += v.value * dt;
        benchmark::ClobberMemory();
    }
    perEntity(state, (kEntities + stride - 1) / stride);
}

template <typename T>
void BM_IterateEach(benchmark::State& state) {
    const int64_t stride = state.range(0);
    auto world = makeWorld<T>(kEntities, stride);
    const float dt = 1.0f / 60.0f;
    for (auto _ : state) {
        world->template view<T, const Velocity>().each(
            [dt](T& t, const Velocity& v) { t.position += v.value * dt; });
        benchmark::ClobberMemory();
    }
    perEntity(state, (kEntities + stride - 1) / stride);
}

// Reference point: the same update over two plain arrays (what a perfect SoA layout costs).
void BM_PlainArrays(benchmark::State& state) {
    std::vector<Pose> poses(kEntities);
    std::vector<Velocity> vels(kEntities, Velocity{glm::vec3(1.0f, 0.5f, 0.25f)});
    const float dt = 1.0f / 60.0f;
    for (auto _ : state) {
        for (size_t i = 0; i < poses.size(); ++i) poses[i].position += vels[i].value * dt;
        benchmark::ClobberMemory();
    }
    perEntity(state, kEntities);
}

void BM_CreateEntities(benchmark::State& state) {
    for (auto _ : state) {
        auto world = std::make_unique<World>();
        if (state.range(0)) world->reserveEntities(kEntities);
        for (int64_t i = 0; i < kEntities; ++i) benchmark::DoNotOptimize(world->create());
        state.PauseTiming();
        world.reset();
        state.ResumeTiming();
    }
    perEntity(state, kEntities);
}

// Arg 1: storage reserved up front (World::reserveEntities / reserve<T>), 0: grown on demand.
void BM_CreateEntitiesWithTwoComponents(benchmark::State& state) {
    const bool reserve = state.range(0) != 0;
    for (auto _ : state) {
        auto world = std::make_unique<World>();
        if (reserve) {
            world->reserveEntities(kEntities);
            world->reserve<Pose>(kEntities);
            world->reserve<Velocity>(kEntities);
        }
        for (int64_t i = 0; i < kEntities; ++i) {
            const Entity e = world->create();
            world->add<Pose>(e);
            world->add<Velocity>(e, glm::vec3(1.0f));
        }
        state.PauseTiming();
        world.reset();
        state.ResumeTiming();
    }
    perEntity(state, kEntities);
}

// The same into a cleared world: storage (and the memory pages behind it) is already there, so this
// measures the ECS work without the OS cost of first-touching fresh memory; indices come from the
// free list.
void BM_RecreateEntitiesWithTwoComponents(benchmark::State& state) {
    World world;
    auto fill = [&world] {
        for (int64_t i = 0; i < kEntities; ++i) {
            const Entity e = world.create();
            world.add<Pose>(e);
            world.add<Velocity>(e, glm::vec3(1.0f));
        }
    };
    fill();  // grow and touch the storage once
    for (auto _ : state) {
        state.PauseTiming();
        world.clear();
        state.ResumeTiming();
        fill();
    }
    perEntity(state, kEntities);
}

// Destroying 1M entities that have two components (each removal visits every pool).
void BM_DestroyEntitiesWithTwoComponents(benchmark::State& state) {
    for (auto _ : state) {
        state.PauseTiming();
        auto world = makeWorld<Pose>(kEntities, 1);
        std::vector<Entity> all;
        all.reserve(kEntities);
        world->eachEntity([&](Entity e) { all.push_back(e); });
        state.ResumeTiming();
        for (Entity e : all) world->destroy(e);
        state.PauseTiming();
        world.reset();
        state.ResumeTiming();
    }
    perEntity(state, kEntities);
}

// Hierarchy update of 1M transforms: 1000 roots with 999 children each.
void BM_UpdateTransforms(benchmark::State& state) {
    World world;
    Entity root = kNullEntity;
    for (int64_t i = 0; i < kEntities; ++i) {
        const Entity e = world.create();
        Transform* t = world.add<Transform>(e);
        t->position = glm::vec3(1.0f, 0.0f, 0.0f);
        if (i % 1000 == 0) {
            root = e;
        } else {
            t->parent = root;
        }
    }
    for (auto _ : state) {
        benchmark::DoNotOptimize(updateTransforms(world));
        benchmark::ClobberMemory();
    }
    perEntity(state, kEntities);
}

}  // namespace

// Arg: every N-th entity has a Velocity (1: both pools 1M; 2: the view leads with the 500k pool).
BENCHMARK_TEMPLATE(BM_IterateRangeFor, Pose)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond);
BENCHMARK_TEMPLATE(BM_IterateEach, Pose)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond);
BENCHMARK_TEMPLATE(BM_IterateRangeFor, Transform)->Arg(1)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_PlainArrays)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_CreateEntities)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_CreateEntitiesWithTwoComponents)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_RecreateEntitiesWithTwoComponents)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_DestroyEntitiesWithTwoComponents)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_UpdateTransforms)->Unit(benchmark::kMillisecond);

BENCHMARK_MAIN();
