// The stability suite's hard cases with collisions on: a collider spinning at 50 rad/s, a cloth
// crushed in a shrinking box (two sizes), a character clip played at 3x speed. Each is a scene (JSON below,
// built with loom::scene like `loom run`), self-collision on, run with every solver; invariants:
//   - after every pipeline step (a stage after the collision stages; rolled-back steps are forgotten with the
//     guard's snapshot): the exact census (loom::collision::count_all_intersections) finds 0 intersecting
//     triangle pairs, and every position is finite;
//   - after every frame: positions finite; the deepest cloth vertex inside a collider
//     (loom::collision::max_penetration) below the case's bound; max strain max(l/L - 1) below the case's
//     bound (the guard is given the same bound); E = E_kin + E_el + E_pot(t) - E_pot(0) never above 10
//     max(E(0), m|g|L) + W(t), W(t) an upper estimate of the work put in from outside: pinned vertices |f·v|
//     dt per frame (as in test_stability.cpp) and the colliders' push, per frame |ΔJ·v| + |ΔL·ω| (ΔJ, ΔL: the
//     change of the collider's reaction impulse and its moment about the collider's origin; v, ω: the
//     collider's velocity and spin over the frame, from its poses).
// The guard is given the same bounds (strain, energy budget with its own per-step estimate of the colliders'
// work, 1 mm penetration via collision::ContactGuardStage, no new intersecting pair after any step via
// collision::IntersectionGuardStage: `guard.intersections`), so a solver that cannot hold a case is rolled
// back, retried with smaller steps and stopped with a named cause instead of handing out a bad frame.
// Table kExpected says, per solver, whether it must survive every frame (S) or stop with a clean, named
// failure (F: the guard's cause, the last good frame kept, nothing non-finite handed out, every frame handed
// out within every invariant, the census included). Every row runs in ctest.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "StabilityExpect.h"
#include "loom/cloth/Error.h"
#include "loom/collision/MultiClothCensus.h"
#include "loom/scene/Build.h"
#include "loom/scene/Scene.h"

namespace loom {
namespace {

// After the collision stages: the census of every step's end state. Its counters are part of the guard's
// snapshot, so a step the guard rolls back does not count.
class CensusStage final : public cloth::Stage {
 public:
  const char* name() const override { return "census"; }
  void run(cloth::StageContext& ctx) override {
    std::vector<collision::CensusInput> in;
    bool finite = true;
    for (const auto& c : ctx.cloths) {
      in.push_back({&c->mesh(), &c->state().x});
      finite = finite && c->state().is_finite();
    }
    ++steps;
    if (!finite) return;  // the guard rejects this step; the census needs finite positions
    const long n = collision::count_all_intersections(in, ctx.threads);
    if (n > worst) worst = n, worst_step = steps;
  }
  void save_state(cloth::StateWriter& out) const override {
    out.tag("census");
    out.i64(steps);
    out.i64(worst);
    out.i64(worst_step);
  }
  void load_state(cloth::StateReader& in) override {
    in.tag("census");
    steps = in.i64();
    worst = in.i64();
    worst_step = in.i64();
  }
  long steps = 0, worst = 0, worst_step = -1;
};

struct CollisionCase {
  std::string name;
  std::string scene;  // JSON; "@SOLVER" is replaced by the solver's settings
  int frames = 30;
  double max_strain = 1.0;  // 1, bound of max(l/L - 1) per frame (also the guard's limit)
  double max_depth = 0.0;   // m, bound of max_penetration per frame (also the guard's limit)
  int max_halvings = 5;     // the guard's retries of a failed frame (2x, 4x, ... the substeps)
};

// Solver settings per solver: the explicit ones need small steps on cotton (stability limit), the others
// run at the scenes' usual 2-4 substeps per 60 Hz frame.
std::string solver_json(const std::string& solver) {
  const int substeps = solver == "explicit_euler"                           ? 100
                       : solver == "symplectic_euler" || solver == "verlet" ? 40
                                                                            : 4;
  return "{\"method\": \"" + solver + "\", \"substeps\": " + std::to_string(substeps) + "}";
}

std::string replace_all(std::string s, const std::string& from, const std::string& to) {
  for (size_t p = s.find(from); p != std::string::npos; p = s.find(from, p + to.size()))
    s.replace(p, from.size(), to);
  return s;
}

std::vector<CollisionCase> collision_cases() {
  std::vector<CollisionCase> cases;
  {  // a 1 m sheet dropped on a box spinning at 50 rad/s about the vertical (corners at 17.7 m/s)
    CollisionCase c;
    c.name = "collider_spinning_50_rad_s";
    c.scene = R"({
      "duration": 1, "fps": 60, "solver": @SOLVER,
      "collision": {"self": true},
      "cloths": [{"name": "sheet", "mesh": {"type": "grid", "size": [1, 1], "nodes": [13, 13], "plane": "xz", "origin": [-0.5, 0.45, -0.5]},
                  "material": {"preset": "cotton"}, "mass": 0.2}],
      "colliders": [{"name": "spinner", "shape": "box", "half_extents": [0.25, 0.1, 0.25], "position": [0, 0.3, 0],
                     "thickness": 0.005, "friction": 0.5, "static_friction": 0.6, "motion": {"spin": {"axis": [0, 1, 0], "rate": 50}}},
                    {"name": "ground", "shape": "plane", "thickness": 0.005}]
    })";
    c.frames = 40;
    c.max_strain = 1.0;
    c.max_depth = 1e-3;
    cases.push_back(c);
  }
  {  // a 1 m sheet dropped flat on a static 0.6 x 0.2 x 0.6 m box: it drapes over the four edges and corners
     // (the cloth edges crossing a box edge are pushed out along the shortest way, not across the box)
    CollisionCase c;
    c.name = "sheet_draped_over_box_corners";
    c.scene = R"({
      "duration": 1, "fps": 60, "solver": @SOLVER,
      "collision": {"self": true},
      "cloths": [{"name": "sheet", "mesh": {"type": "grid", "size": [1, 1], "nodes": [17, 17], "plane": "xz", "origin": [-0.5, 0.85, -0.5]},
                  "material": {"preset": "cotton"}, "mass": 0.2}],
      "colliders": [{"name": "box", "shape": "box", "half_extents": [0.3, 0.1, 0.3], "position": [0, 0.5, 0],
                     "thickness": 0.005, "friction": 0.5, "static_friction": 0.6},
                    {"name": "ground", "shape": "plane", "thickness": 0.005}]
    })";
    c.frames = 40;
    c.max_strain = 0.4;
    c.max_depth = 1e-3;
    cases.push_back(c);
  }
  // A sheet dropped into a box whose six walls close in at 0.75 m/s (lid and side walls; 3.1 mm per step at
  // 4 substeps of a 60 Hz frame, less than the walls' 5 mm thickness, so a step can resolve it). Two sizes:
  //  - to 0.5 x 0.25 x 0.5 m (at t = 0.47 s, then held): the 1 m sheet folds to half its width each way,
  //  about
  //    4 layers in 0.25 m: it fits;
  //  - to 0.3 x 0.15 x 0.3 m (at t = 0.6 s): 11x less area, with 83 mm edges (13x13 nodes) only 3.6 edges
  //    across the box: a hard fold for the coarse sheet.
  auto box = [](const std::string& name, double half, double lid, double t_end) {
    CollisionCase c;
    c.name = name;
    std::string s = R"({
      "duration": 1, "fps": 60, "solver": @SOLVER,
      "collision": {"self": true},
      "cloths": [{"name": "sheet", "mesh": {"type": "grid", "size": [1, 1], "nodes": [13, 13], "plane": "xz", "origin": [-0.5, 0.3, -0.5]},
                  "material": {"preset": "cotton"}, "mass": 0.2}],
      "colliders": [
        {"name": "floor", "shape": "plane", "thickness": 0.005},
        {"name": "lid", "shape": "plane", "thickness": 0.005, "rotation": {"axis": [1, 0, 0], "degrees": 180},
         "motion": {"keyframes": [{"t": 0, "position": [0, 0.6, 0]}, {"t": @T, "position": [0, @LID, 0]}]}},
        {"name": "east", "shape": "plane", "thickness": 0.005, "rotation": {"axis": [0, 0, 1], "degrees": 90},
         "motion": {"keyframes": [{"t": 0, "position": [0.6, 0, 0]}, {"t": @T, "position": [@H, 0, 0]}]}},
        {"name": "west", "shape": "plane", "thickness": 0.005, "rotation": {"axis": [0, 0, 1], "degrees": -90},
         "motion": {"keyframes": [{"t": 0, "position": [-0.6, 0, 0]}, {"t": @T, "position": [-@H, 0, 0]}]}},
        {"name": "north", "shape": "plane", "thickness": 0.005, "rotation": {"axis": [1, 0, 0], "degrees": -90},
         "motion": {"keyframes": [{"t": 0, "position": [0, 0, 0.6]}, {"t": @T, "position": [0, 0, @H]}]}},
        {"name": "south", "shape": "plane", "thickness": 0.005, "rotation": {"axis": [1, 0, 0], "degrees": 90},
         "motion": {"keyframes": [{"t": 0, "position": [0, 0, -0.6]}, {"t": @T, "position": [0, 0, -@H]}]}}]
    })";
    s = replace_all(replace_all(replace_all(s, "@T", std::to_string(t_end)), "@LID", std::to_string(lid)),
                    "@H", std::to_string(half));
    c.scene = s;
    c.frames = 48;
    c.max_strain = 1.0;
    c.max_depth = 1e-3;
    return c;
  };
  cases.push_back(box("crushed_in_shrinking_box_to_50_cm", 0.25, 0.25, 0.35 / 0.75));
  cases.push_back(box("crushed_in_shrinking_box_to_30_cm", 0.15, 0.15, 0.45 / 0.75));
#ifdef LOOM_HAVE_CHARACTERS
  {  // the CMU jump (tests/data/mocap/01_01.bvh) played at 3x with a cape: the root moves at up to ~6 m/s
    CollisionCase c;
    c.name = "character_clip_at_3x";
    c.scene = R"({
      "duration": 1, "fps": 60, "solver": @SOLVER,
      "collision": {"self": true},
      "constraints": {"tethers": {"slack": 0.1}},
      "character": {"bvh": "@MOCAP/01_01.bvh", "start": 1.0, "speed": 3.0,
                    "garments": [{"type": "cape", "name": "cape", "material": {"preset": "cotton", "damping": 1e-4}, "resolution": 0.08}]}
    })";
    c.frames = 60;  // the scene's whole second: 3 s of the clip
    c.max_strain = 1.0;
    c.max_depth = 1e-3;
    cases.push_back(c);
  }
#endif
  return cases;
}

const std::vector<std::string>& kSolvers = test::kStabilitySolvers;
using test::Expect;
using test::F;
using test::S;

// Which solvers must survive each case (S: every invariant after every step/frame) and which must stop with a
// clean, named failure (F: the guard's cause, the last good frame kept, every frame before it within every
// invariant). In the order of kSolvers:
//                                                       expl  sympl verlet impl  bdf2  pbd   xpbd  proj
//                                                       desbrun
const std::map<std::string, std::vector<Expect>> kExpected = {
    {"collider_spinning_50_rad_s", /* */ {F, S, S, S, S, S, S, S, S}},
    {"sheet_draped_over_box_corners", /* */ {F, S, S, S, S, S, S, S, S}},
    {"crushed_in_shrinking_box_to_50_cm", /* */ {F, S, S, S, S, S, S, S, S}},
    {"crushed_in_shrinking_box_to_30_cm", /* */ {F, S, S, S, S, S, S, S, S}},
    {"character_clip_at_3x", /* */ {F, S, S, S, S, S, S, S, S}},
};

struct Outcome {
  bool survived = false;
  int frames_done = 0;
  std::string failure;
  long intersections = 0, census_steps = 0;
  double max_depth = 0.0, max_strain = 0.0, max_energy_ratio = 0.0;
};

// Speed (m/s) of the collider's origin and spin (rad/s) over the frame from pose a to pose b.
void collider_motion(const collision::Transform& a, const collision::Transform& b, double dt, cloth::Vec3& v,
                     cloth::Vec3& w) {
  v = (b.translation() - a.translation()) / dt;
  const Eigen::AngleAxisd d(b.linear() * a.linear().transpose());
  w = d.axis() * d.angle() / dt;
}

Outcome run_case(const CollisionCase& cc, const std::string& solver, bool strict) {
  const std::string text = replace_all(replace_all(cc.scene, "@SOLVER", solver_json(solver)), "@MOCAP",
                                       std::string(LOOM_TEST_DATA) + "/mocap");
  nlohmann::json root = nlohmann::json::parse(text);
  // The guard enforces the invariants below (Guard.h): the strain bound, the energy budget 10x start + work
  // (its own estimate of the work: per step, from the colliders' reaction impulses) and the penetration bound
  // (collision::ContactGuardStage), so a solver that breaks one stops cleanly instead of handing the frame
  // out.
  root["guard"] = {
      {"max_strain", cc.max_strain},
      {"energy_bound", 10.0},
      {"max_penetration", cc.max_depth},
      {"intersections", true},
      {"max_halvings", solver == "explicit_euler" ? std::min(cc.max_halvings, 1) : cc.max_halvings}};
  const scene::Scene sc = scene::parse_scene(root, cc.name + ".json");
  collision::ColliderSetPtr colliders;
  std::unique_ptr<cloth::Simulation> sim = scene::build_simulation(sc, &colliders);
  auto census = std::make_unique<CensusStage>();
  CensusStage* cs = census.get();
  sim->add_stage(std::move(census));

  auto census_input = [&] {
    std::vector<collision::CensusInput> in;
    for (const auto& c : sim->cloths()) in.push_back({&c->mesh(), &c->state().x});
    return in;
  };
  const cloth::FrameStats s0 = sim->measure();
  double mass = 0.0, size = 0.0;
  for (const auto& c : sim->cloths()) {
    for (double m : c->state().mass) mass += m;
    const cloth::Vec3s& X = c->mesh().rest_positions();
    cloth::Vec3 lo = X[0], hi = X[0];
    for (const cloth::Vec3& p : X) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
    size = std::max(size, (hi - lo).norm());
  }
  const double scale = 10.0 * std::max(s0.kinetic + s0.elastic, mass * sim->setup().gravity.norm() * size);
  const double dt = sim->setup().frame_dt;
  std::vector<collision::Collider> before = colliders ? *colliders : std::vector<collision::Collider>{};
  double work = 0.0;
  Outcome out;
  out.max_depth = colliders ? collision::max_penetration(census_input(), *colliders) : 0.0;
  for (int f = 1; f <= cc.frames; ++f) {
    const cloth::FrameStats s = sim->step_frame();
    for (const auto& c : sim->cloths())
      EXPECT_TRUE(c->state().is_finite()) << cc.name << " " << solver << " frame " << f;
    if (!s.finite) {
      out.failure = sim->failure();
      EXPECT_FALSE(out.failure.empty())
          << cc.name << " " << solver << ": a failed frame must carry its cause";
      EXPECT_EQ(sim->frame(), f - 1) << "the simulation must hold the last good frame";
      break;
    }
    // Work put in: pinned (attached) vertices, then the colliders' push over the frame.
    for (auto& c : sim->cloths()) {
      const cloth::ClothState& st = c->state();
      cloth::Vec3s force;
      c->compute_forces(st.x, st.v, sim->time(), 1, force);
      for (int i = 0; i < st.size(); ++i)
        if (st.inv_mass[i] == 0.0) work += std::abs(force[i].dot(st.v[i])) * dt;
    }
    if (colliders) {
      for (size_t k = 0; k < colliders->size(); ++k) {
        const collision::Collider& now = (*colliders)[k];
        cloth::Vec3 v, w;
        collider_motion(before[k].curr, now.curr, dt, v, w);
        work += std::abs((now.reaction_impulse - before[k].reaction_impulse).dot(v)) +
                std::abs((now.reaction_angular_impulse - before[k].reaction_angular_impulse).dot(w));
      }
      before = *colliders;
      const double depth = collision::max_penetration(census_input(), *colliders);
      out.max_depth = std::max(out.max_depth, depth);
      if (strict) {
        EXPECT_LE(depth, cc.max_depth)
            << cc.name << " " << solver << " frame " << f << ": a vertex inside a collider";
      }
    }
    const double e = s.kinetic + s.elastic + s.potential - s0.potential;
    out.max_energy_ratio = std::max(out.max_energy_ratio, e / (scale + work));
    if (strict) {
      EXPECT_LE(e, scale + work) << cc.name << " " << solver << " frame " << f
                                 << ": energy above 10x start + work";
    }
    if (strict) {
      EXPECT_LE(s.max_strain, cc.max_strain) << cc.name << " " << solver << " frame " << f;
    }
    out.max_strain = std::max(out.max_strain, s.max_strain);
    out.frames_done = f;
  }
  out.survived = out.frames_done == cc.frames;
  out.intersections = cs->worst;
  out.census_steps = cs->steps;
  if (strict) {
    EXPECT_EQ(cs->worst, 0) << cc.name << " " << solver << ": intersecting triangle pairs at step "
                            << cs->worst_step;
  }
  EXPECT_GE(cs->steps, out.frames_done * sim->setup().substeps) << "the census must see every step";
  return out;
}

class StabilityWithCollisions : public ::testing::TestWithParam<std::tuple<int, int>> {};

TEST_P(StabilityWithCollisions, SurvivesOrFailsCleanly) {
  static const std::vector<CollisionCase> cases = collision_cases();
  const CollisionCase& cc = cases[std::get<0>(GetParam())];
  const std::string& solver = kSolvers[std::get<1>(GetParam())];
  const Expect want = kExpected.at(cc.name)[std::get<1>(GetParam())];
  const Outcome o = run_case(cc, solver, true);
  std::printf(
      "%-27s %-17s %s after %d frames, census 0/%ld steps: worst %ld, depth %.3g m, strain %.3g, max E/bound "
      "%.3g %s\n",
      cc.name.c_str(), solver.c_str(), o.survived ? "survived" : "FAILED", o.frames_done, o.census_steps,
      o.intersections, o.max_depth, o.max_strain, o.max_energy_ratio, o.failure.c_str());
  if (want == S) {
    EXPECT_TRUE(o.survived) << cc.name << " " << solver << ": " << o.failure;
  } else {
    EXPECT_FALSE(o.survived) << cc.name << " " << solver << " was expected to fail cleanly (table kExpected)";
  }
}

int num_cases() { return static_cast<int>(collision_cases().size()); }

// The outcome of each row is table kExpected's. The F rows show an engine limit: explicit Euler does not
// hold cotton at 100-200 substeps.
std::string row_name(const std::tuple<int, int>& row) {
  static const std::vector<CollisionCase> cases = collision_cases();
  return cases[std::get<0>(row)].name + "_" + kSolvers[std::get<1>(row)];
}

std::vector<std::tuple<int, int>> rows() {
  std::vector<std::tuple<int, int>> out;
  for (int c = 0; c < num_cases(); ++c)
    for (int k = 0; k < static_cast<int>(kSolvers.size()); ++k) out.emplace_back(c, k);
  return out;
}

INSTANTIATE_TEST_SUITE_P(HardCases, StabilityWithCollisions, ::testing::ValuesIn(rows()),
                         [](const ::testing::TestParamInfo<std::tuple<int, int>>& info) {
                           return row_name(info.param);
                         });

}  // namespace
}  // namespace loom
