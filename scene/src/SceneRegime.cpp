// The divergence report (SceneRegime.h).
#include "loom/scene/SceneRegime.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <vector>

#include "loom/cloth/Solver.h"
#include "loom/collision/ColliderBroadPhase.h"
#include "loom/collision/ColliderDistance.h"
#include "loom/collision/ColliderGeometry.h"
#ifdef LOOM_HAVE_CHARACTERS
#include "loom/characters/Character.h"
#endif

namespace loom::scene {

namespace {

std::string fig(double v) {  // 3 significant digits
  char s[32];
  std::snprintf(s, sizeof s, "%.3g", v);
  return s;
}

bool explicit_method(const std::string& m) {
  return m == "explicit_euler" || m == "symplectic_euler" || m == "verlet";
}

double min_rest_edge(const cloth::ClothMesh& mesh) {
  double l = INFINITY;
  const cloth::Vec3s& x = mesh.rest_positions();
  for (const auto& e : mesh.edges()) l = std::min(l, (x[e.i] - x[e.j]).norm());
  return l;
}

// The fastest point at `reach` (m) from the origin of a moving pose (m/s): its origin's speed plus its turn
// rate times reach, sampled at `samples` even steps over the scene (a turn is resolved up to pi per step).
double surface_speed(const std::function<collision::Transform(double)>& motion, double reach, double duration,
                     int samples) {
  const double dt = duration / samples;
  double v = 0.0;
  for (double t = 0.0; t < duration; t += dt) {
    const collision::Transform a = motion(t), b = motion(t + dt);
    const double turn = Eigen::AngleAxisd(b.linear() * a.linear().transpose()).angle();
    v = std::max(v, ((b.translation() - a.translation()).norm() + turn * reach) / dt);
  }
  return v;
}

// Where a cloth's rest mesh starts inside collider `c` (at pose c.curr) or its thickness: "vertex 12,
// 0.03 m in" or "its edge between vertices 3 and 4, ..."; empty when no point is inside. Vertices with
// held[v] != 0, and the edges that end at them, are left out (held may be empty).
std::string start_inside(const collision::Collider& c, const cloth::ClothMesh& mesh,
                         const collision::Aabb& cloth_box, const std::vector<char>& held) {
  const collision::Aabb box = collision::swept_collider_box(c, c.thickness);
  if (!box.overlaps(cloth_box)) return "";
  const cloth::Vec3s& x = mesh.rest_positions();
  auto in_box = [&box](const cloth::Vec3& p) {
    return (p.array() >= box.lo.array()).all() && (p.array() <= box.hi.array()).all();
  };
  auto depth = [&](const cloth::Vec3& p) {
    return collision::signed_distance(c, c.curr, p, nullptr) - c.thickness;
  };
  auto is_held = [&held](int v) { return !held.empty() && held[v] != 0; };
  double deepest = HUGE_VAL;
  int vertex = -1;
  std::vector<double> dv(x.size(), std::nan(""));  // m, each vertex's depth once computed
  for (int v = 0; v < static_cast<int>(x.size()); ++v) {
    if (is_held(v) || !in_box(x[v])) continue;
    const double d = dv[v] = depth(x[v]);
    if (d < deepest) deepest = d, vertex = v;
  }
  // A collider thinner than the cloth's edges can pass between its vertices: each edge within the
  // collider's box that may reach inside it is sampled at kEdgeSamples interior points. The signed
  // distance is 1-Lipschitz, so no point of an edge of length l is inside when d_i + d_j > l.
  constexpr int kEdgeSamples = 8;
  cloth::Edge edge{-1, -1};
  if (!(vertex >= 0 && deepest < 0.0))
    for (const cloth::Edge& e : mesh.edges()) {
      if (is_held(e.i) || is_held(e.j)) continue;
      collision::Aabb eb;
      eb.grow(x[e.i]);
      eb.grow(x[e.j]);
      if (!box.overlaps(eb)) continue;
      for (const int v : {e.i, e.j})
        if (std::isnan(dv[v])) dv[v] = depth(x[v]);
      if (dv[e.i] + dv[e.j] > (x[e.j] - x[e.i]).norm()) continue;
      for (int q = 1; q <= kEdgeSamples; ++q) {
        const cloth::Vec3 p = x[e.i] + (x[e.j] - x[e.i]) * (q / (kEdgeSamples + 1.0));
        if (!in_box(p)) continue;
        const double d = depth(p);
        if (d < deepest) deepest = d, edge = e, vertex = -1;
      }
    }
  if (!((vertex >= 0 || edge.i >= 0) && deepest < 0.0)) return "";
  return (vertex >= 0
              ? "vertex " + std::to_string(vertex)
              : "its edge between vertices " + std::to_string(edge.i) + " and " + std::to_string(edge.j)) +
         ", " + fig(-deepest) + " m in";
}

// A collider's reach: the farthest point of its local box (a plane: 0, its origin's speed only).
double collider_reach(const collision::Collider& c) {
  if (c.shape.type == collision::ShapeType::plane) return 0.0;
  cloth::Vec3 lo, hi;
  collision::local_bounds(c.shape, c.geometry.get(), lo, hi);
  return (0.5 * (lo + hi)).norm() + 0.5 * (hi - lo).norm();
}

#ifdef LOOM_HAVE_CHARACTERS
struct ClipSpeed {
  double speed = 0.0;  // m/s, the fastest joint's speed after the clip's scale and settings.speed
  std::string joint;   // its name
  int frame = 0;       // 1-based clip frame (key) where it moves that fast
  double time = 0.0;   // s, simulated time of the sample
};

// The 1-based clip frame (key) that ends the key interval holding simulated time t, by the joint's own keys
// (the root's for a joint without keys of its own).
int clip_frame(const characters::Motion& m, int joint, double t) {
  double tau = m.clip_time(t);
  const double d = m.duration();
  tau = m.settings().loop && d > 0.0 ? tau - std::floor(tau / d) * d : std::clamp(tau, 0.0, d);
  const characters::JointTrack* track = &m.track(joint);
  if (track->position_times.empty() && track->rotation_times.empty()) track = &m.track(m.root());
  const std::vector<double>& times =
      track->position_times.empty() ? track->rotation_times : track->position_times;
  const auto after = std::upper_bound(times.begin(), times.end(), tau) - times.begin();  // 0-based
  return static_cast<int>(std::min<std::ptrdiff_t>(after, std::max<std::ptrdiff_t>(1, times.size()) - 1)) + 1;
}

// The clip's fastest joint over the scene's [0, duration], as the character stage poses it (speed, start,
// looping, root motion applied): joint positions sampled at half the clip's shortest key spacing (in
// simulated seconds), so every sampled interval lies within one key interval of a jump at least once;
// at most 1e6 joint samples in all. A joint's speed carries its bone's capsule, whose surface follows it.
ClipSpeed clip_speed(const characters::Motion& m, double duration) {
  ClipSpeed out;
  if (!(duration > 0.0) || m.num_joints() == 0) return out;
  double spacing = HUGE_VAL;  // clip s
  for (int k = 0; k < m.num_joints(); ++k) {
    const characters::JointTrack& t = m.track(k);
    for (const std::vector<double>* times : {&t.position_times, &t.rotation_times})
      for (size_t i = 1; i < times->size(); ++i)
        if ((*times)[i] > (*times)[i - 1]) spacing = std::min(spacing, (*times)[i] - (*times)[i - 1]);
  }
  const double budget = 1e6 / m.num_joints();
  double samples = std::isfinite(spacing) ? 2.0 * duration * m.settings().speed / spacing : 1000.0;
  samples = std::clamp(samples, 1000.0, std::max(1000.0, budget));
  const int n = static_cast<int>(std::ceil(samples));
  const double dt = duration / n;
  std::vector<characters::Transform> a, b;
  std::vector<double> v(m.num_joints());
  m.pose(0.0, a);
  for (int s = 0; s < n; ++s) {
    m.pose((s + 1) * dt, b);
    for (int k = 0; k < m.num_joints(); ++k) v[k] = (b[k].translation() - a[k].translation()).norm() / dt;
    const double top = *std::max_element(v.begin(), v.end());
    if (top > out.speed) {
      // Named by the joint nearest the root that moves nearly as fast: the one whose keys carry the
      // motion (a root jump moves every joint below it).
      int k = 0;
      while (v[k] < 0.9 * top) ++k;
      out = {top, m.joints()[k].name, clip_frame(m, k, (s + 0.5) * dt), s * dt};
    }
    a.swap(b);
  }
  return out;
}
#endif

}  // namespace

std::vector<RegimeOutlier> regime_outliers(const Scene& scene) {
  const cloth::SimulationSetup& s = scene.setup;
  std::vector<RegimeOutlier> out;
  // step_bound: more steps per frame bring the value back into the regime.
  auto add = [&](const std::string& text, bool step_bound = false) { out.push_back({text, step_bound}); };
  const int substeps = s.substeps > 0 ? s.substeps : cloth::default_substeps(s.solver.method, s.frame_dt);
  const double h = s.frame_dt / std::max(1, substeps);  // s, one solver step
  const double g = s.gravity.norm();
  if (g > kRegimeAcceleration)
    add("gravity (|g| = " + fig(g) + " m/s^2, " + fig(g / 9.81) + " g; validated up to " +
        fig(kRegimeAcceleration) + ")");
  double cloth_mass = 0.0;
  for (size_t i = 0; i < s.cloths.size(); ++i) {
    const cloth::ClothSetup& c = s.cloths[i];
    const std::string at = scene.cloth_field(static_cast<int>(i));
    const double rho = c.material.areal_density;  // kg/m^2
    cloth_mass += rho * c.mesh->total_area();
    const double wave = std::sqrt(std::max(c.material.stretch_weft, c.material.stretch_warp) / rho);
    if (wave > kRegimeWaveSpeed)
      add(at + ".material stretch with its areal density (stretch waves at " + fig(wave) +
          " m/s; validated up to " + fig(kRegimeWaveSpeed) + ")");
    if (explicit_method(s.solver.method)) {
      const double courant = wave * h / min_rest_edge(*c.mesh);
      if (courant > kRegimeCourant)
        add("solver.substeps for " + at + " (a stretch wave crosses " + fig(courant) +
                " edges per step of the explicit " + s.solver.method + "; stable below " +
                fig(kRegimeCourant) + ")",
            true);
    }
    const double l_min = min_rest_edge(*c.mesh);
    // Stiffness-proportional damping (Material.h: c = damping k) relaxes an edge's stretch at the rate
    // damping omega^2, omega = wave / l_min: an explicit step must not exceed it; any solver past 1 s.
    const double damping_steps = c.material.damping * (wave / l_min) * (wave / l_min) * h;
    if (c.material.damping > kRegimeDamping ||
        (explicit_method(s.solver.method) && damping_steps > kRegimeDampingSteps))
      add(at + ".material.damping (" + fig(c.material.damping) + " s, relaxing an edge " +
              fig(damping_steps) + " times per step; validated up to " + fig(kRegimeDamping) + " s and " +
              fig(kRegimeDampingSteps) + " per step)",
          !(c.material.damping > kRegimeDamping));
    // A pin whose first target lies far from its vertex moves the vertex there in the first step.
    cloth::Vec3 lo = c.mesh->rest_positions()[0], hi = lo;
    for (const cloth::Vec3& x : c.mesh->rest_positions()) {
      lo = lo.cwiseMin(x);
      hi = hi.cwiseMax(x);
    }
    const double reach = kRegimePinReach * std::max((hi - lo).norm(), l_min);
    for (size_t k = 0; k < c.pins.size(); ++k) {
      const cloth::PinSpec& p = c.pins[k];
      if (p.vertex < 0 || p.vertex >= c.mesh->num_vertices()) continue;
      const cloth::Vec3 start = c.mesh->rest_positions()[p.vertex];
      cloth::Vec3 target = p.anchor.value_or(start);
      if (!p.offsets.empty()) target += p.offsets.front();
      const double d = (target - start).norm();
      const std::string pin =
          k < c.pin_fields.size() ? c.pin_fields[k] : at + ".pins[" + std::to_string(k) + "]";
      if (d > reach)
        add(pin + " (its first target lies " + fig(d) + " m from its vertex; validated up to " + fig(reach) +
            " m, a quarter of the cloth's size)");
      // A path moves its vertex linearly between keys: its speed is the fastest key interval's, as for a
      // kinematic collider, over the keys that start within the scene's duration.
      double v = 0.0;
      for (size_t q = 1; q < p.times.size() && q < p.offsets.size() && p.times[q - 1] < scene.duration; ++q)
        if (p.times[q] > p.times[q - 1])
          v = std::max(v, (p.offsets[q] - p.offsets[q - 1]).norm() / (p.times[q] - p.times[q - 1]));
      if (v > kRegimeSpeed)
        add(pin + ".path (moves its vertex at up to " + fig(v) + " m/s; validated up to " +
            fig(kRegimeSpeed) + ")");
    }
    // PressureTerm.h: |f| = |dp| A on a face, dp = p_in - p_out the net pressure, so a = |dp| / rho. At the
    // rest volume dp is `overpressure` for both models (an ideal gas holds ambient + overpressure inside
    // against ambient outside): the ambient pressure itself pushes on both sides and moves nothing.
    if (c.pressure) {
      const double dp = c.pressure->overpressure, p = std::abs(dp);
      if (p / rho > kRegimeWindAcceleration)
        add(at + ".pressure (a net " + fig(dp) + " Pa, inside minus outside at the rest volume, " +
            (dp > 0.0 ? "pushes the cloth out" : "pulls the cloth in") + " at " + fig(p / rho) +
            " m/s^2; validated up to " + fig(kRegimeWindAcceleration) + ")");
    }
    if (c.initial_velocity.norm() > kRegimeSpeed)
      add(at + ".velocity (" + fig(c.initial_velocity.norm()) + " m/s; validated up to " + fig(kRegimeSpeed) +
          ")");
    if (s.drag) {  // AirDragTerm.h: f = -c A (v - w), so a = c |w| / rho and a relaxation rate c / rho
      const double coef = std::max(s.drag->isotropic, s.drag->normal);
      const double a = coef * s.drag->wind.norm() * (1.0 + std::abs(s.drag->gust_amplitude)) / rho;
      if (a > kRegimeWindAcceleration)
        add("effects.drag.wind with " + at + "'s areal density (the wind pushes at " + fig(a) +
            " m/s^2; validated up to " + fig(kRegimeWindAcceleration) + ")");
      if (coef / rho * h > kRegimeDampingSteps)
        add(std::string("effects.drag.") + (s.drag->isotropic >= s.drag->normal ? "isotropic" : "normal") +
                " with " + at + "'s areal density (the drag relaxes the velocity " + fig(coef / rho * h) +
                " times per step; validated up to " + fig(kRegimeDampingSteps) + ")",
            true);
    }
    if (s.wind) {  // AeroTerm.h: |f| <= 1/2 rho_air max(C_D, C_L) |w|^2 A
      const double w = s.wind->max_speed();
      const double a = 0.5 * s.wind->density * std::max(s.wind->drag, s.wind->lift) * w * w / rho;
      if (a > kRegimeWindAcceleration)
        add("effects.wind with " + at + "'s areal density (the wind pushes at " + fig(a) +
            " m/s^2; validated up to " + fig(kRegimeWindAcceleration) + ")");
    }
  }
  for (size_t k = 0; k < scene.bodies.size(); ++k) {
    const collision::RigidBodySpec& b = scene.bodies[k];
    const std::string at = "bodies[" + std::to_string(k) + "]";
    if (b.velocity.norm() > kRegimeSpeed)
      add(at + ".velocity (" + fig(b.velocity.norm()) + " m/s; validated up to " + fig(kRegimeSpeed) + ")");
    if (b.motion) {  // a kinematic body's origin speed
      const double v = surface_speed(b.motion, 0.0, scene.duration, 100000);
      if (v > kRegimeSpeed)
        add(at + ".motion (moves at up to " + fig(v) + " m/s; validated up to " + fig(kRegimeSpeed) + ")");
    }
    double carried = 0.0;  // kg, the cloths that hang from this body
    for (const collision::BodyAttachment& a : b.attachments)
      if (a.cloth >= 0 && a.cloth < static_cast<int>(s.cloths.size()))
        carried = std::max(carried,
                           s.cloths[a.cloth].material.areal_density * s.cloths[a.cloth].mesh->total_area());
    if (b.mass > 0.0 && !b.motion && carried > 0.0 && b.mass < 1e-2 * carried)
      add(at + ".mass (" + fig(b.mass) + " kg carries a cloth of " + fig(carried) +
          " kg; validated down to a hundredth of it)");
    if (cloth_mass > 0.0 && b.mass > 1e3 * cloth_mass)
      add(at + ".mass (" + fig(b.mass / cloth_mass) + " times the cloths' mass; validated up to 1000)");
  }
  int moving = 0;
  for (const collision::Collider& c : scene.colliders) moving += c.motion ? 1 : 0;
  // 1e6 pose samples over all moving colliders, at least 1000 each.
  const int samples = moving ? std::max(1000, 1000000 / moving) : 0;
  std::vector<collision::Aabb> cloth_box(s.cloths.size());
  for (size_t i = 0; i < s.cloths.size(); ++i)
    for (const cloth::Vec3& x : s.cloths[i].mesh->rest_positions()) cloth_box[i].grow(x);
  for (size_t k = 0; k < scene.colliders.size(); ++k) {
    const collision::Collider& c = scene.colliders[k];
    const std::string at = "colliders[" + std::to_string(k) + "]";
    if (c.motion) {
      const double v = surface_speed(c.motion, collider_reach(c), scene.duration, samples);
      if (v > kRegimeSpeed)
        add(at + ".motion (its surface moves at up to " + fig(v) + " m/s; validated up to " +
            fig(kRegimeSpeed) + ")");
    }
    // A cloth that starts inside the collider or its thickness is pushed out at once.
    collision::Collider at_start = c;
    at_start.prev = at_start.curr = c.motion ? c.motion(0.0) : c.curr;
    for (size_t i = 0; i < s.cloths.size(); ++i) {
      const std::string where = start_inside(at_start, *s.cloths[i].mesh, cloth_box[i], {});
      if (!where.empty())
        out.push_back({scene.cloth_field(static_cast<int>(i)) + " starts inside " + at + " '" + c.name +
                           "' or its thickness (" + where + ")",
                       false, true});
    }
  }
  // The same for the bodies, at their pose at t = 0; a body's attached vertices (and the edges that end at
  // them) are where the body holds the cloth, not a start inside it.
  for (size_t k = 0; k < scene.bodies.size(); ++k) {
    const collision::RigidBodySpec& b = scene.bodies[k];
    collision::Collider at_start;
    at_start.shape = b.shape;
    at_start.prev = at_start.curr = b.motion ? b.motion(0.0) : b.pose;
    for (size_t i = 0; i < s.cloths.size(); ++i) {
      std::vector<char> held;  // empty unless the body holds vertices of this cloth
      for (const collision::BodyAttachment& a : b.attachments)
        if (a.cloth == static_cast<int>(i) && a.vertex >= 0 && a.vertex < s.cloths[i].mesh->num_vertices()) {
          if (held.empty()) held.assign(s.cloths[i].mesh->num_vertices(), 0);
          held[a.vertex] = 1;
        }
      const std::string where = start_inside(at_start, *s.cloths[i].mesh, cloth_box[i], held);
      if (!where.empty())
        out.push_back({scene.cloth_field(static_cast<int>(i)) + " starts inside bodies[" + std::to_string(k) +
                           "] '" + b.name + "' (" + where + ")",
                       false, true});
    }
  }
#ifdef LOOM_HAVE_CHARACTERS
  if (scene.character && scene.character->motion.settings().speed > kRegimeClipSpeed)
    add("character.speed (" + fig(scene.character->motion.settings().speed) +
        " clip seconds per second; validated up to " + fig(kRegimeClipSpeed) + ")");
  if (scene.character) {
    const ClipSpeed v = clip_speed(scene.character->motion, scene.duration);
    if (v.speed > kRegimeSpeed)
      add("character.bvh (" + scene.character->motion.source() + ": joint '" + v.joint + "' moves at " +
          fig(v.speed) + " m/s near clip frame " + std::to_string(v.frame) + ", t = " + fig(v.time) +
          " s; validated up to " + fig(kRegimeSpeed) + ")");
  }
#endif
  return out;
}

std::string divergence_suspects(const Scene& scene) {
  std::vector<std::string> out;
  for (const RegimeOutlier& o : regime_outliers(scene)) out.push_back(o.text);
  const cloth::SimulationSetup& s = scene.setup;
  const int substeps = s.substeps > 0 ? s.substeps : cloth::default_substeps(s.solver.method, s.frame_dt);
  if (out.empty() && s.solver.method == "weil")  // one geometric shape: no steps to add
    return "; no scene value is outside the validated regime, and the weil drape has no substeps: its "
           "catenaries between the pins' anchors (cloths[].pins[k].anchor) reach this shape only by "
           "stretching the cloth; move the anchors or use the static solver";
  if (out.empty())
    return "; no scene value is outside the validated regime: more solver.substeps (now " +
           std::to_string(substeps) + " per frame)" +
           (scene.quality.name == "reference"
                ? std::string(" or a larger guard.max_halvings")
                : std::string(", a larger guard.max_halvings, or \"quality\": \"reference\"")) +
           " may carry the frame";
  std::string text = "; the scene's values outside the validated regime: ";
  for (size_t k = 0; k < out.size(); ++k) text += (k ? "; " : "") + out[k];
  return text;
}

}  // namespace loom::scene
