// GarmentInstance: the game-loop facade (skinned garment, fixed-step accumulator, teleports, inertia,
// buffers).
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <random>

#include "TestCape.h"
#include "loom/characters/GarmentInstance.h"
#include "loom/cloth/ClothMesh.h"
#include "loom/cloth/Error.h"

using namespace loom::characters;
using loom::cloth::Vec3;
using loom::cloth::Vec3s;
using Iso = Eigen::Isometry3d;

namespace {

using Cape = loom::test::TestCape;

Cape make_cape() { return loom::test::make_test_cape({11, 13, 0.02, true, 0.05}); }

// The bones at a character frame F: both bones carried rigidly, the neck also turned by `bend` about z.
std::vector<Affine> pose_at(const Cape& c, const Iso& frame, double bend = 0.0) {
  std::vector<Affine> p = {frame * c.bind_pose[0], frame * c.bind_pose[1]};
  p[1].rotate(Eigen::AngleAxisd(bend, Vec3::UnitZ()));
  return p;
}

// A clip: the character sways along x and turns about y; the neck bends.
Iso clip_frame(double t) {
  Iso f = Iso::Identity();
  f.translate(Vec3(0.4 * std::sin(2 * M_PI * 0.5 * t), 0, 0.2 * t));
  f.rotate(Eigen::AngleAxisd(0.6 * std::sin(2 * M_PI * 0.7 * t), Vec3::UnitY()));
  return f;
}
double clip_bend(double t) { return 0.3 * std::sin(2 * M_PI * 0.9 * t); }

std::vector<float> positions_of(const GarmentInstance& g) {
  std::vector<float> out(3 * g.num_vertices());
  g.write_positions(out.data(), 3);
  return out;
}

// Plays the clip with the given frame times (s) and samples the render positions whenever the clock reaches
// one of `samples` (s).
std::vector<std::vector<float>> play(const std::vector<double>& frame_dts,
                                     const std::vector<double>& samples) {
  Cape c = make_cape();
  GarmentInstance g(c.bind, c.tris, c.skin, c.settings, pose_at(c, clip_frame(0), clip_bend(0)), "cape");
  std::vector<std::vector<float>> out;
  size_t next = 0;
  double t = 0.0;
  for (double dt : frame_dts) {
    t += dt;
    g.set_pose(pose_at(c, clip_frame(t), clip_bend(t)));
    g.step(dt);
    if (next < samples.size() && std::abs(g.clock() - samples[next]) < 1e-9)
      out.push_back(positions_of(g)), ++next;
  }
  return out;
}

double rms(const std::vector<float>& a, const std::vector<float>& b) {
  double s = 0;
  for (size_t i = 0; i < a.size(); i += 3)
    s += std::pow(a[i] - b[i], 2) + std::pow(a[i + 1] - b[i + 1], 2) + std::pow(a[i + 2] - b[i + 2], 2);
  return std::sqrt(s / (a.size() / 3));
}

}  // namespace

TEST(GarmentInstance, ConstraintsHoldAtEveryStepOfAClip) {
  Cape c = make_cape();
  GarmentInstance g(c.bind, c.tris, c.skin, c.settings, pose_at(c, clip_frame(0)), "cape");
  double worst_over = 0, worst_behind = 0, free_motion = 0;
  for (int f = 1; f <= 180; ++f) {
    const double t = f / 60.0;
    g.set_pose(pose_at(c, clip_frame(t), clip_bend(t)));
    g.step(1.0 / 60.0);
    const Vec3s& x = g.positions();
    for (int i = 0; i < g.num_vertices(); ++i) {
      const double d = (x[i] - g.targets()[i]).norm();
      worst_over = std::max(worst_over, d - c.settings.constraints.max_distance[i]);
      if (c.settings.constraints.max_distance[i] == 0.0) {
        EXPECT_LE(d, 1e-9);
      }
      worst_behind = std::max(worst_behind,
                              g.constraints().backstop_depth(i, x[i], g.targets()[i], g.target_normals()[i]));
      free_motion = std::max(free_motion, d);
    }
    ASSERT_TRUE(std::all_of(x.begin(), x.end(), [](const Vec3& p) { return p.allFinite(); }));
  }
  EXPECT_LE(worst_over, 1e-12);
  EXPECT_LE(worst_behind, 1e-12);
  EXPECT_GT(free_motion, 0.01);  // the hem does move away from the skinned pose
  EXPECT_EQ(g.steps(), 720);     // 3 s of 1/240 s steps
}

TEST(GarmentInstance, ZeroMultiplierIsTheSkinnedMesh) {
  Cape c = make_cape();
  GarmentInstance g(c.bind, c.tris, c.skin, c.settings, pose_at(c, clip_frame(0)), "cape");
  g.set_max_distance_multiplier(0.0);
  for (int f = 1; f <= 30; ++f) {
    g.set_pose(pose_at(c, clip_frame(f / 30.0), clip_bend(f / 30.0)));
    g.step(1.0 / 30.0);
  }
  for (int i = 0; i < g.num_vertices(); ++i) EXPECT_LE((g.positions()[i] - g.skinned()[i]).norm(), 1e-9);
}

TEST(GarmentInstance, FrameRateIndependent) {
  std::vector<double> samples;
  for (int k = 1; k <= 12; ++k) samples.push_back(k / 6.0);  // common times of 30, 60 and 144 Hz
  auto fixed = [](double hz) {
    return std::vector<double>(static_cast<size_t>(std::lround(2.0 * hz)), 1.0 / hz);
  };
  std::vector<double> jitter;
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(1.0 / 200.0, 1.0 / 25.0);
  double t = 0;
  for (double s : samples)
    while (t < s - 1e-12) {
      const double dt = std::min(u(rng), s - t);
      jitter.push_back(dt);
      t += dt;
    }
  const auto a = play(fixed(30), samples), b = play(fixed(60), samples), c = play(fixed(144), samples),
             d = play(jitter, samples);
  ASSERT_EQ(a.size(), samples.size());
  ASSERT_EQ(b.size(), samples.size());
  ASSERT_EQ(c.size(), samples.size());
  ASSERT_EQ(d.size(), samples.size());
  double worst = 0;
  for (size_t k = 0; k < samples.size(); ++k) {
    worst = std::max({worst, rms(a[k], c[k]), rms(b[k], c[k]), rms(d[k], c[k])});
  }
  EXPECT_LT(worst, 1e-3);
  std::printf("frame-rate independence: worst RMS vs 144 Hz over 12 samples = %.3g m\n", worst);
}

TEST(GarmentInstance, TeleportCarriesTheClothRigidly) {
  for (bool detect : {true, false}) {
    Cape c = make_cape();
    if (!detect) c.settings.teleport_distance = HUGE_VAL;
    GarmentInstance g(c.bind, c.tris, c.skin, c.settings, pose_at(c, Iso::Identity()), "cape");
    for (int f = 0; f < 120; ++f) g.step(1.0 / 60.0);  // settle at rest
    std::vector<double> rest(g.num_vertices());
    for (int i = 0; i < g.num_vertices(); ++i) rest[i] = (g.positions()[i] - g.skinned()[i]).norm();
    Iso far = Iso::Identity();
    far.translate(Vec3(10.0, 0.0, 0.0));
    far.rotate(Eigen::AngleAxisd(0.3, Vec3::UnitY()));
    g.set_pose(pose_at(c, far));
    g.step(1.0 / 60.0);
    double worst = 0;
    for (int i = 0; i < g.num_vertices(); ++i) {
      const double d = (g.positions()[i] - g.skinned()[i]).norm();
      worst = std::max(worst, d - 2.0 * rest[i]);
    }
    if (detect) {
      EXPECT_EQ(g.teleports(), 1);
      EXPECT_LE(worst, 1e-6);
    } else {
      EXPECT_EQ(g.teleports(), 0);
      EXPECT_GT(worst, 0.05);  // without the threshold the hem is whipped to its max distance
    }
  }
}

TEST(GarmentInstance, ZeroInertiaIsSimulationInTheCharactersFrame) {
  // A: the character runs, sways and spins about the vertical (gravity's axis), inertia 0. B: the same local
  // motion with the character standing at the origin. A = F(t) B at every frame. On the default solver
  // (fast_xpbd, float rounding in the character's frame) A also stands 10 km from the origin; on xpbd (double
  // in world coordinates, one step of 4 sweeps) it stays near it: 10 km away double keeps 2e-12 m, which
  // the clip's dynamics amplify past the bound.
  for (const char* solver : {"fast_xpbd", "xpbd"}) {
    Iso far = Iso::Identity();
    if (std::string(solver) == "fast_xpbd") far.translate(Vec3(6000.0, 0.0, -8000.0));
    auto frame_a = [&](double t) { return Iso(far * clip_frame(t)); };
    Cape c = make_cape();
    c.settings.solver = solver;
    if (c.settings.solver == "xpbd") c.settings.substeps = 1, c.settings.iterations = 4;
    c.settings.linear_inertia = 0.0;
    c.settings.angular_inertia = 0.0;
    GarmentInstance a(c.bind, c.tris, c.skin, c.settings, pose_at(c, frame_a(0), clip_bend(0)), "cape");
    GarmentInstance b(c.bind, c.tris, c.skin, c.settings, pose_at(c, Iso::Identity(), clip_bend(0)), "cape");
    // The character's frame is the hips bone's (F H in A, H in B), so A = F B.
    double worst = 0;
    for (int f = 1; f <= 120; ++f) {
      const double t = f / 60.0;
      a.set_pose(pose_at(c, frame_a(t), clip_bend(t)));
      b.set_pose(pose_at(c, Iso::Identity(), clip_bend(t)));
      a.step(1.0 / 60.0);
      b.step(1.0 / 60.0);
      const Iso ft = frame_a(t);
      for (int i = 0; i < a.num_vertices(); ++i)
        worst = std::max(worst, (a.positions()[i] - ft * b.positions()[i]).norm());
    }
    // Rounding differences, amplified by the dynamics over 2 s: double's, and float's (the solver rounds in
    // the character's frame, about 1e-7 of the cape's size per step).
    EXPECT_LT(worst, std::string(solver) == "xpbd" ? 1e-7 : 2e-5) << solver;
    std::printf("inertia 0, %s: worst distance from the character-frame run %.3g m\n", solver, worst);
    // With inertia 1 the same motion swings the cape differently.
    Cape w = c;
    w.settings.linear_inertia = w.settings.angular_inertia = 1.0;
    GarmentInstance a1(w.bind, w.tris, w.skin, w.settings, pose_at(w, frame_a(0), clip_bend(0)), "cape");
    double differs = 0;
    for (int f = 1; f <= 120; ++f) {
      const double t = f / 60.0;
      a1.set_pose(pose_at(w, frame_a(t), clip_bend(t)));
      a1.step(1.0 / 60.0);
    }
    for (int i = 0; i < a1.num_vertices(); ++i)
      differs = std::max(differs, (a1.positions()[i] - a.positions()[i]).norm());
    EXPECT_GT(differs, 0.01) << solver;
  }
}

TEST(GarmentInstance, WritesIntoTheCallersBufferWithStride) {
  Cape c = make_cape();
  GarmentInstance g(c.bind, c.tris, c.skin, c.settings, pose_at(c, Iso::Identity()), "cape");
  g.step(0.1);
  std::vector<float> buf(8 * g.num_vertices(), -7.0f);
  g.write_positions(buf.data(), 8);
  g.write_normals(buf.data() + 3, 8);
  for (int i = 0; i < g.num_vertices(); ++i) {
    const float* v = buf.data() + 8 * i;
    const Vec3 n(v[3], v[4], v[5]);
    EXPECT_NEAR(n.norm(), 1.0, 1e-5);
    EXPECT_TRUE(std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2]));
    EXPECT_EQ(v[6], -7.0f);
    EXPECT_EQ(v[7], -7.0f);
  }
  // Between steps the positions are interpolated: a 0.1 s frame on 1/240 s steps leaves clock - time = 0
  // here.
  EXPECT_NEAR(g.time(), 0.1, 1e-9);
}

// The message of the loom::Error that f() throws ("" if it throws none).
template <class F>
std::string error_message(F f) {
  try {
    f();
  } catch (const loom::Error& e) {
    return e.what();
  }
  return {};
}

// The error of a cape garment built with `edit` applied to its settings ("" if it builds).
template <class Edit>
std::string settings_error(Edit edit) {
  Cape k = make_cape();
  edit(k.settings);
  return error_message(
      [&] { GarmentInstance(k.bind, k.tris, k.skin, k.settings, pose_at(k, Iso::Identity()), "cape"); });
}

TEST(GarmentInstance, RejectsBadArgumentsNamingThem) {
  Cape c = make_cape();
  auto message = [](auto f) { return error_message(f); };
  auto with = [](auto edit) { return settings_error(edit); };
  EXPECT_NE(
      with([](GarmentSettings& s) { s.constraints.max_distance[3] = -0.1; }).find("cape: max_distance[3]"),
      std::string::npos);
  EXPECT_NE(with([](GarmentSettings& s) { s.fixed_dt = 0; }).find("fixed_dt"), std::string::npos);
  EXPECT_NE(with([](GarmentSettings& s) { s.linear_inertia = 2; }).find("linear_inertia"), std::string::npos);
  EXPECT_NE(with([](GarmentSettings& s) { s.angular_inertia = NAN; }).find("angular_inertia"),
            std::string::npos);
  EXPECT_NE(with([](GarmentSettings& s) { s.teleport_distance = -1; }).find("teleport_distance"),
            std::string::npos);
  EXPECT_NE(with([](GarmentSettings& s) { s.substeps = 0; }).find("cape: substeps: 0 is not in [1, 1000]"),
            std::string::npos);
  EXPECT_NE(with([](GarmentSettings& s) { s.solver = "nosuch"; }).find("cape: solver.method"),
            std::string::npos);
  EXPECT_NE(with([](GarmentSettings& s) { s.solver = "symplectic_euler"; }).find("cape: solver.iterations"),
            std::string::npos);
  GarmentInstance g(c.bind, c.tris, c.skin, c.settings, pose_at(c, Iso::Identity()), "cape");
  auto bad = pose_at(c, Iso::Identity());
  bad[1].matrix()(0, 3) = NAN;
  EXPECT_NE(message([&] { g.set_pose(bad); }).find("cape: pose[1]: is not finite"), std::string::npos);
  EXPECT_NE(message([&] { g.step(-1.0); }).find("frame_dt"), std::string::npos);
  EXPECT_NE(message([&] { g.set_max_distance_multiplier(-1.0); }).find("max_distance_multiplier"),
            std::string::npos);
}

namespace {

// A cape with sleep on, hanging from a still character until it sleeps (at most 10 s at 60 Hz).
GarmentInstance sleeping_cape(const Cape& c) {
  GarmentInstance g(c.bind, c.tris, c.skin, c.settings, pose_at(c, Iso::Identity()), "cape");
  for (int f = 0; f < 600 && !g.asleep(); ++f) {
    g.set_pose(pose_at(c, Iso::Identity()));
    g.step(1.0 / 60.0);
  }
  return g;
}

Cape sleepy_cape() {
  Cape c = make_cape();
  c.settings.sleep.enabled = true;
  return c;
}

double max_change(const Vec3s& a, const Vec3s& b) {
  double d = 0;
  for (size_t i = 0; i < a.size(); ++i) d = std::max(d, (a[i] - b[i]).norm());
  return d;
}

}  // namespace

TEST(GarmentInstance, StillCharacterFallsAsleepAndStepsStopCosting) {
  const Cape c = sleepy_cape();
  GarmentInstance g = sleeping_cape(c);
  ASSERT_TRUE(g.asleep());
  EXPECT_GT(g.time(), c.settings.sleep.settle_time);
  const long solver = g.solver_steps(), steps = g.steps();
  const Vec3s rest = g.positions();
  for (int f = 0; f < 60; ++f) {  // 1 s on the same pose, and with sub-threshold jitter (1 mm, 0.01 rad)
    Iso j = Iso::Identity();
    j.translate(Vec3(0.001 * (f % 2), 0, 0));
    g.set_pose(pose_at(c, j, 0.01 * (f % 2)));
    g.step(1.0 / 60.0);
  }
  EXPECT_TRUE(g.asleep());
  EXPECT_EQ(g.solver_steps(), solver);  // no solver step while asleep
  EXPECT_EQ(g.steps(), steps + 240);    // the simulated time follows the clock
  EXPECT_EQ(max_change(g.positions(), rest), 0.0);
  // Awake it ran a solver step for every fixed step; the steps left in the frame it fell asleep in are
  // skipped.
  EXPECT_GT(solver, steps - 4);
  EXPECT_LT(solver, steps);
}

TEST(GarmentInstance, PoseChangeWakesASleepingCloth) {
  const Cape c = sleepy_cape();
  GarmentInstance g = sleeping_cape(c);
  ASSERT_TRUE(g.asleep());
  const long solver = g.solver_steps();
  const Vec3s rest = g.positions();
  g.set_pose(pose_at(c, Iso::Identity(), 0.3));  // the neck turns by 0.3 rad
  EXPECT_FALSE(g.asleep());
  for (int f = 0; f < 30; ++f) {
    g.set_pose(pose_at(c, Iso::Identity(), 0.3));
    g.step(1.0 / 60.0);
  }
  EXPECT_EQ(g.solver_steps(), solver + 120);
  EXPECT_GT(max_change(g.positions(), rest), 0.01);  // the cape follows the turned neck
  // A character that walks off (a frame translation) wakes it too.
  GarmentInstance w = sleeping_cape(c);
  ASSERT_TRUE(w.asleep());
  Iso moved = Iso::Identity();
  moved.translate(Vec3(0.02, 0, 0));
  w.set_pose(pose_at(c, moved));
  EXPECT_FALSE(w.asleep());
  // wake() wakes it; at rest it falls asleep again after the settle time.
  GarmentInstance e = sleeping_cape(c);
  e.wake();
  EXPECT_FALSE(e.asleep());
  const long before = e.solver_steps();
  for (int f = 0; f < 120 && !e.asleep(); ++f) e.step(1.0 / 60.0);
  EXPECT_TRUE(e.asleep());
  EXPECT_GE(e.solver_steps() - before, std::lround(c.settings.sleep.settle_time * 240));
}

TEST(GarmentInstance, ASleepingClothWakesWhenTouched) {
  const Cape c = sleepy_cape();
  GarmentInstance g = sleeping_cape(c);
  ASSERT_TRUE(g.asleep());
  const long solver = g.solver_steps();
  // A ball of radius 0.1 m rolls towards the cape (x = 0, z = -0.15) from z = 1 m; the game loop reports its
  // box every frame.
  int woke_at = -1;
  double z_woke = 0;
  for (int f = 0; f < 60; ++f) {
    const double z = 1.0 - f * 0.02;
    const Vec3 centre(0.0, 1.3, z), r(0.1, 0.1, 0.1);
    const bool touched = g.notify_contact(centre - r, centre + r);
    EXPECT_EQ(touched, !g.asleep());
    if (touched && woke_at < 0) woke_at = f, z_woke = z;
    g.set_pose(pose_at(c, Iso::Identity()));
    g.step(1.0 / 60.0);
  }
  ASSERT_GE(woke_at, 0);
  // It woke once the ball's box reached the cloth's (the hanging cape lies near z = -0.15).
  EXPECT_LT(z_woke - 0.1, -0.1);
  EXPECT_GT(z_woke - 0.1, -0.2);
  EXPECT_GT(g.solver_steps(), solver);
}

TEST(GarmentInstance, SleepBookkeepingChangesNoResult) {
  // Sleep on with a zero speed threshold never sleeps: its run is bit-identical to sleep off.
  Cape off = make_cape(), on = make_cape();
  on.settings.sleep.enabled = true;
  on.settings.sleep.speed = 0.0;
  GarmentInstance a(off.bind, off.tris, off.skin, off.settings, pose_at(off, clip_frame(0)), "cape");
  GarmentInstance b(on.bind, on.tris, on.skin, on.settings, pose_at(on, clip_frame(0)), "cape");
  for (int f = 1; f <= 120; ++f) {
    const double t = f / 60.0;
    a.set_pose(pose_at(off, clip_frame(t), clip_bend(t)));
    b.set_pose(pose_at(on, clip_frame(t), clip_bend(t)));
    a.step(1.0 / 60.0);
    b.step(1.0 / 60.0);
    ASSERT_EQ(positions_of(a), positions_of(b));
  }
  EXPECT_FALSE(b.asleep());
}

TEST(GarmentInstance, StrideLodRunsFewerStepsWithoutAPop) {
  // Plays the clip for 4 s at 60 Hz; with `switching`, strides 1, 4, 8, 1, 4, 8, 1 over 40 frames each
  // (set_lod with full_rate_distance 5 m, max_stride 8). Returns the largest move of a rendered vertex
  // between two frames.
  struct Run {
    double worst_jump = 0, worst_over = 0;
    long solver_steps = 0, steps = 0, expected_solver = 0;
  };
  auto play_lod = [](bool switching, double blend_time) {
    Cape c = make_cape();
    c.settings.lod.blend_time = blend_time;
    GarmentInstance g(c.bind, c.tris, c.skin, c.settings, pose_at(c, clip_frame(0)), "cape");
    Run r;
    std::vector<float> prev = positions_of(g);
    long due = 0;
    for (int f = 1; f <= 240; ++f) {
      const double t = f / 60.0;
      if (switching && f % 40 == 0) g.set_lod(std::array<double, 3>{0.0, 20.0, 100.0}[(f / 40) % 3]);
      g.set_pose(pose_at(c, clip_frame(t), clip_bend(t)));
      g.step(1.0 / 60.0);
      // A 1/60 s frame is 4 fixed steps; a step of k fixed steps runs when k of them are due.
      for (due += 4; due >= g.step_stride(); due -= g.step_stride()) ++r.expected_solver;
      const std::vector<float> now = positions_of(g);
      for (size_t i = 0; i < now.size(); i += 3)
        r.worst_jump = std::max<double>(
            r.worst_jump, std::hypot(now[i] - prev[i], now[i + 1] - prev[i + 1], now[i + 2] - prev[i + 2]));
      prev = now;
      for (int i = 0; i < g.num_vertices(); ++i)
        r.worst_over = std::max(r.worst_over, (g.positions()[i] - g.targets()[i]).norm() -
                                                  c.settings.constraints.max_distance[i]);
    }
    r.solver_steps = g.solver_steps();
    r.steps = g.steps();
    return r;
  };
  const Run full = play_lod(false, 0.2), lod = play_lod(true, 0.2), unblended = play_lod(true, 0.0);
  EXPECT_EQ(lod.steps, 960);  // 4 s of 1/240 s steps at any stride
  EXPECT_EQ(lod.solver_steps, lod.expected_solver);
  EXPECT_EQ(full.solver_steps, 960);
  EXPECT_LT(lod.solver_steps, 600);  // two thirds of the frames at a quarter or an eighth of the steps
  EXPECT_LE(lod.worst_over, 1e-12);
  // With the blend no frame moves the rendered cloth much more than the worst frame at full rate (the
  // coarser steps at stride 8 move it a little more); without it the change of the render lag (up to 7 fixed
  // steps) shows as a jump.
  std::printf("stride LOD: worst per-frame move %.4f m (full rate %.4f m, no blend %.4f m)\n", lod.worst_jump,
              full.worst_jump, unblended.worst_jump);
  EXPECT_LE(lod.worst_jump, 1.3 * full.worst_jump);
  EXPECT_GT(unblended.worst_jump, 1.6 * full.worst_jump);
  Cape c = make_cape();
  GarmentInstance g(c.bind, c.tris, c.skin, c.settings, pose_at(c, Iso::Identity()), "cape");
  g.set_lod(100.0, false);
  EXPECT_EQ(g.step_stride(), c.settings.lod.offscreen_stride);
  g.set_lod(100.0);
  EXPECT_EQ(g.step_stride(), c.settings.lod.max_stride);
  g.set_lod(7.0);
  EXPECT_EQ(g.step_stride(), 2);
}

TEST(GarmentInstance, RejectsBadSleepAndLodValuesNamingThem) {
  auto message = [](auto f) { return error_message(f); };
  auto with = [](auto edit) { return settings_error(edit); };
  auto has = [](const std::string& m, const char* s) { return m.find(s) != std::string::npos; };
  EXPECT_TRUE(has(with([](GarmentSettings& s) { s.sleep.speed = -1; }), "cape: sleep.speed"));
  EXPECT_TRUE(has(with([](GarmentSettings& s) { s.sleep.settle_time = NAN; }), "cape: sleep.settle_time"));
  EXPECT_TRUE(
      has(with([](GarmentSettings& s) { s.sleep.wake_distance = -0.1; }), "cape: sleep.wake_distance"));
  EXPECT_TRUE(
      has(with([](GarmentSettings& s) { s.sleep.wake_rotation = NAN; }), "cape: sleep.wake_rotation"));
  EXPECT_TRUE(
      has(with([](GarmentSettings& s) { s.lod.full_rate_distance = 0; }), "cape: lod.full_rate_distance"));
  EXPECT_TRUE(has(with([](GarmentSettings& s) { s.lod.max_stride = 0; }), "cape: lod.max_stride"));
  EXPECT_TRUE(has(with([](GarmentSettings& s) { s.lod.blend_time = -1; }), "cape: lod.blend_time"));
  EXPECT_TRUE(
      has(with([](GarmentSettings& s) { s.lod.offscreen_stride = 65; }), "cape: lod.offscreen_stride"));
  Cape c = make_cape();
  GarmentInstance g(c.bind, c.tris, c.skin, c.settings, pose_at(c, Iso::Identity()), "cape");
  EXPECT_TRUE(has(message([&] { g.set_step_stride(0); }), "cape: step_stride: 0 is not in [1, 64]"));
  EXPECT_TRUE(has(message([&] { g.set_lod(-1.0); }), "cape: distance"));
  EXPECT_TRUE(has(message([&] { g.set_lod(NAN); }), "cape: distance"));
  EXPECT_TRUE(has(message([&] { g.notify_contact(Vec3(NAN, 0, 0), Vec3::Ones()); }), "cape: contact"));
  EXPECT_TRUE(has(message([&] { g.notify_contact(Vec3::Ones(), Vec3::Zero()); }), "cape: contact"));
  // A sleeping cloth still rejects a bad pose.
  Cape s = sleepy_cape();
  GarmentInstance z = sleeping_cape(s);
  ASSERT_TRUE(z.asleep());
  auto bad = pose_at(s, Iso::Identity());
  bad[1].matrix()(0, 3) = NAN;
  EXPECT_TRUE(has(message([&] { z.set_pose(bad); }), "cape: pose[1]: is not finite"));
}
