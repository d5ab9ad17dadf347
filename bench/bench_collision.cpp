// Collision-handling cost per triangle per step, on I-Cloth's Sphere, Twisting and Funnel scenes at
// 20k-50k triangles, 1 and 2 threads. One benchmark iteration = one frame of the scene; the manual time is
// the frame's body_collision + self_collision stage time (the solver and the census are not counted). After
// every step an exact census counts intersecting triangle pairs (`intersections`, the largest count seen).
//   build/bench/loom_bench_collision --benchmark_counters_tabular=true
// I-Cloth (Tang et al. 2018, GTX 1080) for comparison: 0.33-3 us per triangle per step (collision handling
// 0.066-0.654 s per step at 90k-215k triangles, Tang et al. 2018, Table 2).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cstdio>
#include <string>
#include <vector>

#include "loom/collision/MultiClothCensus.h"
#include "loom/scene/Scene.h"
#include "loom/scene/ScenePipeline.h"

namespace {

using namespace loom;

class CensusStage final : public cloth::Stage {
 public:
  const char* name() const override { return "census"; }
  void run(cloth::StageContext& ctx) override {
    std::vector<collision::CensusInput> in;
    for (const auto& c : ctx.cloths) in.push_back({&c->mesh(), &c->state().x});
    worst = std::max(worst, collision::count_all_intersections(in, ctx.threads));
    ++steps;
  }
  long worst = 0, steps = 0;
};

// `frames` frames of `scene` (with `overrides`), the first `warmup` of them not timed (the cloth falling onto
// the obstacle before any contact).
void run(benchmark::State& state, const std::string& scene_name, std::vector<std::string> overrides,
         int warmup) {
  const int threads = static_cast<int>(state.range(0));
  overrides.push_back("threads=" + std::to_string(threads));
  const scene::Scene sc = scene::load_scene(std::string(LOOM_SOURCE_DIR) + "/" + scene_name, overrides);
  auto pipeline = scene::build_pipeline(sc);
  cloth::Simulation* sim = &pipeline->simulation();
  auto census = std::make_unique<CensusStage>();
  CensusStage* c = census.get();
  sim->add_stage(std::move(census));
  long triangles = 0;
  for (const auto& cl : sim->cloths()) triangles += cl->mesh().num_triangles();
  const std::vector<std::string> names = sim->stage_names();
  std::vector<int> rows;
  int body_row = -1, self_row = -1;
  for (size_t k = 0; k < names.size(); ++k) {
    if (names[k] == "body_collision" || names[k] == "self_collision") rows.push_back(static_cast<int>(k));
    if (names[k] == "body_collision") body_row = static_cast<int>(k);
    if (names[k] == "self_collision") self_row = static_cast<int>(k);
  }
  for (int f = 0; f < warmup; ++f) sim->step_frame();
  const long steps0 = c->steps;
  double collision_ms = 0.0, total_ms = 0.0, body_ms = 0.0, self_ms = 0.0;
  bool finite = true;
  for (auto _ : state) {
    const cloth::FrameStats s = sim->step_frame();
    double ms = 0.0;
    for (int k : rows) ms += s.stage_ms[k];
    collision_ms += ms;
    if (body_row >= 0) body_ms += s.stage_ms[body_row];
    if (self_row >= 0) self_ms += s.stage_ms[self_row];
    total_ms += s.total_ms;
    finite = finite && s.finite;
    state.SetIterationTime(ms * 1e-3);
  }
  const double steps = static_cast<double>(c->steps - steps0);
  state.counters["triangles"] = static_cast<double>(triangles);
  state.counters["steps"] = steps;
  state.counters["us_per_tri_step"] = 1e3 * collision_ms / (static_cast<double>(triangles) * steps);
  state.counters["collision_share"] = collision_ms / total_ms;
  state.counters["body_share"] = body_ms / collision_ms;  // of the collision time: body_collision stage
  state.counters["self_share"] = self_ms / collision_ms;  // self_collision stage
  state.counters["intersections"] = static_cast<double>(c->worst);
  state.counters["finite"] = finite ? 1 : 0;
  // The collision stages' counters (whole run, warm-up included) on stderr, for profiling.
  std::fprintf(stderr, "%s/%d counters:", scene_name.c_str(), threads);
  for (const cloth::StageProfile& p : sim->profile())
    if (p.name == "body_collision" || p.name == "self_collision")
      for (const auto& [key, value] : p.counters)
        std::fprintf(stderr, " %s.%s=%.0f", p.name.c_str(), key.c_str(), value);
  std::fprintf(stderr, " steps=%ld\n", c->steps);
}

void Sphere(benchmark::State& s) {
  run(s, "scenes/sphere_spin.json", {"cloths[0].mesh.nodes=[101,101]"}, 12);
}
void Twisting(benchmark::State& s) { run(s, "bench/scenes/twisting_cloth_20k.json", {}, 0); }
void Funnel(benchmark::State& s) { run(s, "scenes/funnel.json", {"cloths[0].mesh.nodes=[101,101]"}, 12); }
// The top of the range: ~50k triangles (159x159 nodes: 49,928; twisting 225x113: 50,176).
void Sphere50k(benchmark::State& s) {
  run(s, "scenes/sphere_spin.json", {"cloths[0].mesh.nodes=[159,159]"}, 12);
}
void Twisting50k(benchmark::State& s) { run(s, "bench/scenes/twisting_cloth_50k.json", {}, 0); }
void Funnel50k(benchmark::State& s) { run(s, "scenes/funnel.json", {"cloths[0].mesh.nodes=[159,159]"}, 12); }

}  // namespace

BENCHMARK(Sphere)->Arg(1)->Arg(2)->Iterations(24)->UseManualTime()->Unit(benchmark::kMillisecond);
BENCHMARK(Twisting)->Arg(1)->Arg(2)->Iterations(24)->UseManualTime()->Unit(benchmark::kMillisecond);
BENCHMARK(Funnel)->Arg(1)->Arg(2)->Iterations(24)->UseManualTime()->Unit(benchmark::kMillisecond);
BENCHMARK(Sphere50k)->Arg(1)->Arg(2)->Iterations(24)->UseManualTime()->Unit(benchmark::kMillisecond);
BENCHMARK(Twisting50k)->Arg(1)->Arg(2)->Iterations(24)->UseManualTime()->Unit(benchmark::kMillisecond);
BENCHMARK(Funnel50k)->Arg(1)->Arg(2)->Iterations(24)->UseManualTime()->Unit(benchmark::kMillisecond);

BENCHMARK_MAIN();
