#include "loom/characters/GarmentInstance.h"

#include <algorithm>
#include <cmath>

#include "loom/cloth/Error.h"
#include "loom/cloth/GravityTerm.h"
#include "loom/cloth/Model.h"

namespace loom::characters {

namespace {

using cloth::Vec3;
using cloth::Vec3s;
using Iso = Eigen::Isometry3d;

void check_range(double value, double lo, double hi, bool inf_ok, const std::string& source,
                 const char* field, const char* what) {
  const bool ok = value >= lo && value <= hi && (inf_ok || std::isfinite(value));
  if (!ok) throw Error(source, field, std::to_string(value) + " " + what);
}

// The rigid part of an affine map: its rotation by polar decomposition, its translation.
Iso rigid_part(const Affine& a) {
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(a.linear(), Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d r = svd.matrixU() * svd.matrixV().transpose();
  if (r.determinant() < 0.0) {
    Eigen::Matrix3d u = svd.matrixU();
    u.col(2) *= -1.0;
    r = u * svd.matrixV().transpose();
  }
  Iso out = Iso::Identity();
  out.linear() = r;
  out.translation() = a.translation();
  return out;
}

}  // namespace

GarmentInstance::GarmentInstance(const Vec3s& bind_positions, const std::vector<cloth::Tri>& triangles,
                                 Skin skin, GarmentSettings settings, const std::vector<Affine>& pose,
                                 const std::string& source)
    : source_(source),
      settings_(std::move(settings)),
      skin_(std::move(skin)),
      bind_(bind_positions),
      tris_(triangles),
      constraints_(settings_.constraints, static_cast<int>(bind_positions.size()), source) {
  check_range(settings_.fixed_dt, 1e-6, 1.0, false, source, "fixed_dt", "must be in [1e-6, 1] s");
  if (settings_.iterations < 1)
    throw Error(source, "iterations", std::to_string(settings_.iterations) + " must be >= 1");
  if (settings_.substeps < 1 || settings_.substeps > 1000)
    throw Error(source, "substeps", std::to_string(settings_.substeps) + " is not in [1, 1000]");
  check_range(settings_.linear_inertia, 0.0, 1.0, false, source, "linear_inertia", "must be in [0, 1]");
  check_range(settings_.angular_inertia, 0.0, 1.0, false, source, "angular_inertia", "must be in [0, 1]");
  check_range(settings_.teleport_distance, 1e-9, HUGE_VAL, true, source, "teleport_distance", "must be > 0");
  check_range(settings_.teleport_rotation, 1e-9, HUGE_VAL, true, source, "teleport_rotation", "must be > 0");
  if (settings_.max_steps_per_frame < 1)
    throw Error(source, "max_steps_per_frame",
                std::to_string(settings_.max_steps_per_frame) + " must be >= 1");
  if (!settings_.gravity.allFinite()) throw Error(source, "gravity", "must be finite");
  const GarmentSleepSettings& sl = settings_.sleep;
  check_range(sl.speed, 0.0, HUGE_VAL, false, source, "sleep.speed", "must be finite and >= 0 m/s");
  check_range(sl.settle_time, 0.0, HUGE_VAL, false, source, "sleep.settle_time", "must be finite and >= 0 s");
  check_range(sl.wake_distance, 0.0, HUGE_VAL, true, source, "sleep.wake_distance", "must be >= 0 m");
  check_range(sl.wake_rotation, 0.0, HUGE_VAL, true, source, "sleep.wake_rotation", "must be >= 0 rad");
  const GarmentLodSettings& lod = settings_.lod;
  check_range(lod.blend_time, 0.0, HUGE_VAL, false, source, "lod.blend_time", "must be finite and >= 0 s");
  check_range(lod.full_rate_distance, 1e-9, HUGE_VAL, false, source, "lod.full_rate_distance",
              "must be finite and > 0 m");
  for (auto [value, field] :
       {std::pair{lod.max_stride, "lod.max_stride"}, std::pair{lod.offscreen_stride, "lod.offscreen_stride"}})
    if (value < 1 || value > kMaxStride)
      throw Error(source, field,
                  std::to_string(value) + " is not in [1, " + std::to_string(kMaxStride) + "]");
  if (skin_.num_vertices() != static_cast<int>(bind_.size()))
    throw Error(source, "skin",
                "skins " + std::to_string(skin_.num_vertices()) + " vertices, the mesh has " +
                    std::to_string(bind_.size()));
  settings_.material.validate(source, "material");
  auto mesh = cloth::ClothMesh::from_triangles(bind_, tris_, {}, source);
  cloth_ = std::make_unique<cloth::Cloth>("garment", mesh, settings_.material);
  if (settings_.gravity.squaredNorm() > 0.0)
    cloth_->add_term(std::make_unique<cloth::GravityTerm>(cloth_->state().mass, settings_.gravity));
  cloth::add_model_terms(*cloth_, settings_.model, source, "model");
  if (settings_.wind)
    cloth_->add_term(
        std::make_unique<cloth::AirDragTerm>(*settings_.wind, mesh->triangles(), mesh->vertex_areas()));
  cloth::SolverSettings solver;
  solver.method = settings_.solver;
  solver.params["iterations"] = settings_.iterations;
  solver_ = cloth::make_solver(solver, source);
  solver_->check(*cloth_);
  mass_ = cloth_->state().mass;

  skin_.skinning_matrices(pose, matrices_, source_);
  skin_.apply(matrices_, bind_, skinned_curr_);
  frame_curr_ = rigid_part(pose[0]);
  bones_ = pose;
  local_curr_.resize(bind_.size());
  for (size_t i = 0; i < bind_.size(); ++i) local_curr_[i] = frame_curr_.inverse() * skinned_curr_[i];
  reset();
}

void GarmentInstance::set_pose(const std::vector<Affine>& bones) {
  if (bones.empty()) throw Error(source_, "pose", "no bone transforms");
  // Asleep, a pose within the wake thresholds changes nothing (and costs no polar decomposition).
  if (asleep_ && !pose_moved(bones, sleep_frame_)) return;
  set_pose(bones, rigid_part(bones[0]));
}

void GarmentInstance::set_pose(const std::vector<Affine>& bones, const Iso& frame) {
  if (!frame.matrix().allFinite()) throw Error(source_, "frame", "is not finite");
  if (asleep_) {
    if (!pose_moved(bones, frame)) return;
    wake();
  }
  skin_.skinning_matrices(bones, matrices_, source_);
  bones_ = bones;
  skin_.apply(matrices_, bind_, skinned_curr_);
  frame_curr_ = frame;
  const Iso to_local = frame_curr_.inverse();
  for (size_t i = 0; i < local_curr_.size(); ++i) local_curr_[i] = to_local * skinned_curr_[i];
  // Frame change since the pose at clock(): a teleport carries the cloth rigidly by it.
  const Iso delta = frame_curr_ * frame_prev_.inverse();
  const double moved = (frame_curr_.translation() - frame_prev_.translation()).norm();
  const double turned = Eigen::AngleAxisd(delta.linear()).angle();
  if (teleport_requested_ || moved > settings_.teleport_distance || turned > settings_.teleport_rotation) {
    carry(frame_prev_, frame_curr_, 1.0, 1.0);
    for (Vec3& p : render_prev_) p = delta * p;
    frame_sim_ = delta * frame_sim_;
    frame_prev2_ = delta * frame_prev2_;
    frame_prev_ = frame_curr_;
    ++teleports_;
    blend_start_ = -1.0;  // the blend offset is in the world before the teleport
    teleport_requested_ = false;
  }
}

void GarmentInstance::step(double frame_dt) {
  if (!(frame_dt >= 0.0) || !std::isfinite(frame_dt))
    throw Error(source_, "frame_dt", std::to_string(frame_dt) + " must be finite and >= 0");
  const int stride = stride_;
  const double h = stride * settings_.fixed_dt;
  clock_ += frame_dt;
  if (asleep_) {  // no solver step: the simulated time follows the clock in whole fixed steps
    ticks_ = std::max(ticks_, static_cast<long>(std::floor(clock_ / settings_.fixed_dt + 1e-9)));
    if (frame_dt > 0.0) clock_prev2_ = clock_prev_;
    clock_prev_ = clock_;
    return;
  }
  long due = static_cast<long>(std::floor((clock_ - time()) / h + 1e-9));
  if (due > settings_.max_steps_per_frame) {
    due = settings_.max_steps_per_frame;
    clock_ = time() + due * h;  // the clock slips: the excess frame time is not simulated
  }
  const double span = clock_ - clock_prev_;
  // Three poses (T_{k-2}, T_{k-1}, T_k) give a quadratic in time (Lagrange weights w0, w1, w2) when both
  // intervals are long enough; otherwise the path is linear between the last two.
  const bool quadratic = span > 1e-6 && clock_prev_ - clock_prev2_ > 1e-6;
  // A stride change moves the render lag: keep the rendered positions of the frame before (blend_offset_).
  const int stride_before = last_stride_;
  Vec3s before;  // allocated only at a stride change
  if (stride != stride_before) render_positions(before);
  for (long k = 0; k < due; ++k) {
    if (asleep_) {  // fell asleep during this frame: the simulated time follows the clock
      ticks_ += stride;
      continue;
    }
    const double t_end = static_cast<double>(ticks_ + stride) * settings_.fixed_dt;
    const double s = span > 0.0 ? std::clamp((t_end - clock_prev_) / span, 0.0, 1.0) : 1.0;
    double w0 = 0.0, w1 = 1.0 - s, w2 = s;
    if (quadratic) {
      const double t = std::min(t_end, clock_), a = clock_prev2_, b = clock_prev_, c = clock_;
      w0 = (t - b) * (t - c) / ((a - b) * (a - c));
      w1 = (t - a) * (t - c) / ((b - a) * (b - c));
      w2 = (t - a) * (t - b) / ((c - a) * (c - b));
    }
    // Rotation: R_{k-1} exp(w0 r0 + w2 r2), r_j = log(R_{k-1}ᵀ R_j) (rotation vectors relative to the middle
    // pose).
    const Eigen::AngleAxisd r0(frame_prev_.linear().transpose() * frame_prev2_.linear());
    const Eigen::AngleAxisd r2(frame_prev_.linear().transpose() * frame_curr_.linear());
    const Vec3 rv = w0 * r0.angle() * r0.axis() + w2 * r2.angle() * r2.axis();
    Iso frame = Iso::Identity();
    frame.linear() = frame_prev_.linear() *
                     (rv.norm() > 0.0 ? Eigen::AngleAxisd(rv.norm(), rv / rv.norm()).toRotationMatrix()
                                      : Eigen::Matrix3d::Identity());
    frame.translation() =
        w0 * frame_prev2_.translation() + w1 * frame_prev_.translation() + w2 * frame_curr_.translation();
    const int n = num_vertices();
    for (int i = 0; i < n; ++i)
      target_[i] = frame * (w0 * local_prev2_[i] + w1 * local_prev_[i] + w2 * local_curr_[i]);
    render_prev_ = cloth_->state().x;
    if (settings_.linear_inertia < 1.0 || settings_.angular_inertia < 1.0)
      carry(frame_sim_, frame, 1.0 - settings_.linear_inertia, 1.0 - settings_.angular_inertia);
    const Iso frame_before = frame_sim_;
    frame_sim_ = frame;
    fixed_step(stride);
    if (settings_.sleep.enabled) settle(frame_before, frame, h);
  }
  if (last_stride_ != stride_before) {
    blend_start_ = -1.0;
    render_positions(scratch_);
    blend_offset_.resize(scratch_.size());
    for (size_t i = 0; i < scratch_.size(); ++i) blend_offset_[i] = before[i] - scratch_[i];
    blend_start_ = clock_;
  }
  if (span > 0.0) {
    local_prev2_ = local_prev_;
    frame_prev2_ = frame_prev_;
    clock_prev2_ = clock_prev_;
  }
  local_prev_ = local_curr_;
  frame_prev_ = frame_curr_;
  clock_prev_ = clock_;
}

void GarmentInstance::fixed_step(int stride) {
  const double h = stride * settings_.fixed_dt;
  cloth::ClothState& st = cloth_->state();
  vertex_normals(tris_, target_, target_normal_);
  const int n = num_vertices();
  for (int i = 0; i < n; ++i) {
    if (constraints_.settings().effective_max_distance(i) == 0.0) {
      st.inv_mass[i] = 0.0;
      st.v[i] = (target_[i] - st.x[i]) / h;
    } else {
      st.inv_mass[i] = 1.0 / mass_[i];
    }
  }
  // Float rounding in the character's frame (Solver::set_frame): the same local motion rounds the same way
  // wherever the character stands and whichever way it faces.
  solver_->set_frame(frame_sim_);
  // The solver's substeps leave x_prev at the start of the last one; the state after the fixed step keeps
  // x_prev at the start of [t, t + h] (the contact stage's swept test and friction span the whole step).
  if (settings_.substeps > 1) step_start_ = st.x;
  const double hs = h / settings_.substeps;
  for (int k = 0; k < settings_.substeps; ++k) solver_->step(*cloth_, time() + k * hs, hs, 1);
  if (settings_.substeps > 1) st.x_prev.swap(step_start_);
  constraints_.apply(target_, target_normal_, h, st.x, st.v);
  if (contact_) run_contacts(h);
  ticks_ += stride;
  last_stride_ = stride;
  ++solver_steps_;
}

void GarmentInstance::run_contacts(double h) {
  contact_cloths_.resize(1);
  contact_cloths_[0] = std::move(cloth_);
  cloth::StageContext ctx{contact_cloths_, time(), h, 1};
  contact_->run(ctx);
  cloth_ = std::move(contact_cloths_[0]);
}

void GarmentInstance::set_colliders(collision::ColliderSetPtr colliders,
                                    const collision::RealtimeContactSettings& contact) {
  check_range(contact.thickness, 0.0, HUGE_VAL, false, source_, "contact.thickness",
              "must be finite and >= 0 m");
  if (contact.passes < 1)
    throw Error(source_, "contact.passes", std::to_string(contact.passes) + " must be >= 1");
  colliders_ = std::move(colliders);
  contact_.reset();
  if (colliders_) contact_ = std::make_unique<collision::RealtimeBodyContactStage>(colliders_, contact);
}

void GarmentInstance::settle(const Iso& from, const Iso& to, double h) {
  // Speed relative to the character's frame: the change of F⁻¹ x over the step.
  const Iso to_inv = to.inverse(), from_inv = from.inverse();
  const Vec3s& x = cloth_->state().x;
  const double limit = settings_.sleep.speed * h;
  bool at_rest = true;
  for (size_t i = 0; i < x.size() && at_rest; ++i)
    at_rest = (to_inv * x[i] - from_inv * render_prev_[i]).norm() < limit;
  rest_time_ = at_rest ? rest_time_ + h : 0.0;
  if (at_rest && rest_time_ >= settings_.sleep.settle_time) fall_asleep();
}

void GarmentInstance::fall_asleep() {
  cloth::ClothState& st = cloth_->state();
  std::fill(st.v.begin(), st.v.end(), Vec3::Zero());
  st.x_prev = st.x;
  render_prev_ = st.x;
  sleep_bones_ = bones_;
  sleep_frame_ = frame_curr_;
  // The pose history restarts at the sleeping pose (local_curr_ and frame_curr_ stay there while asleep).
  local_prev2_ = local_prev_ = local_curr_;
  frame_prev2_ = frame_prev_ = frame_curr_;
  box_lo_ = box_hi_ = st.x[0];
  for (const Vec3& p : st.x) {
    box_lo_ = box_lo_.cwiseMin(p);
    box_hi_ = box_hi_.cwiseMax(p);
  }
  asleep_ = true;
}

bool GarmentInstance::pose_moved(const std::vector<Affine>& bones, const Iso& frame) const {
  if (bones.size() != sleep_bones_.size()) return true;  // set_pose reports the wrong count
  // A rotation by θ changes the linear part by 2√2 sin(θ/2) in the Frobenius norm.
  const double turn = std::min(settings_.sleep.wake_rotation, M_PI);
  const double limit = 2.0 * std::sqrt(2.0) * std::sin(0.5 * turn);
  const double dist = settings_.sleep.wake_distance;
  auto moved = [&](const Eigen::Matrix4d& a, const Eigen::Matrix4d& b) {
    if (!a.allFinite()) return true;  // set_pose reports it
    return (a.block<3, 1>(0, 3) - b.block<3, 1>(0, 3)).norm() > dist ||
           (a.block<3, 3>(0, 0) - b.block<3, 3>(0, 0)).norm() > limit;
  };
  if (moved(frame.matrix(), sleep_frame_.matrix())) return true;
  for (size_t b = 0; b < bones.size(); ++b)
    if (moved(bones[b].matrix(), sleep_bones_[b].matrix())) return true;
  return false;
}

void GarmentInstance::wake() {
  asleep_ = false;
  rest_time_ = 0.0;
}

bool GarmentInstance::notify_contact(const Vec3& lo, const Vec3& hi) {
  if (!lo.allFinite() || !hi.allFinite()) throw Error(source_, "contact", "box is not finite");
  if ((lo.array() > hi.array()).any()) throw Error(source_, "contact", "box has lo > hi");
  Vec3 a = box_lo_, b = box_hi_;
  if (!asleep_) {
    const Vec3s& x = cloth_->state().x;
    a = b = x[0];
    for (const Vec3& p : x) {
      a = a.cwiseMin(p);
      b = b.cwiseMax(p);
    }
  }
  const bool overlaps = (lo.array() <= b.array()).all() && (a.array() <= hi.array()).all();
  if (overlaps) wake();
  return overlaps;
}

void GarmentInstance::set_step_stride(int k) {
  if (k < 1 || k > kMaxStride)
    throw Error(source_, "step_stride",
                std::to_string(k) + " is not in [1, " + std::to_string(kMaxStride) + "]");
  stride_ = k;
}

void GarmentInstance::set_lod(double distance, bool visible) {
  if (!(distance >= 0.0) || !std::isfinite(distance))
    throw Error(source_, "distance", std::to_string(distance) + " must be finite and >= 0 m");
  const GarmentLodSettings& lod = settings_.lod;
  if (!visible) return set_step_stride(lod.offscreen_stride);
  const double k = std::ceil(distance / lod.full_rate_distance);
  set_step_stride(static_cast<int>(std::clamp(k, 1.0, static_cast<double>(lod.max_stride))));
}

void GarmentInstance::carry(const Iso& from, const Iso& to, double linear, double angular) {
  const Vec3 oa = from.translation();
  const Vec3 shift = linear * (to.translation() - from.translation());
  const Eigen::AngleAxisd turn(to.linear() * from.linear().transpose());
  const Eigen::Matrix3d r = Eigen::AngleAxisd(angular * turn.angle(), turn.axis()).toRotationMatrix();
  cloth::ClothState& st = cloth_->state();
  for (int i = 0; i < st.size(); ++i) {
    st.x[i] = oa + shift + r * (st.x[i] - oa);
    st.x_prev[i] = oa + shift + r * (st.x_prev[i] - oa);
    st.v[i] = r * st.v[i];
  }
}

void GarmentInstance::reset() {
  cloth::ClothState& st = cloth_->state();
  st.x = skinned_curr_;
  st.x_prev = st.x;
  std::fill(st.v.begin(), st.v.end(), Vec3::Zero());
  render_prev_ = st.x;
  local_prev_ = local_prev2_ = local_curr_;
  target_ = skinned_curr_;
  vertex_normals(tris_, target_, target_normal_);
  frame_prev_ = frame_prev2_ = frame_curr_;
  frame_sim_ = frame_curr_;
  clock_prev2_ = clock_prev_ = clock_ = time();
  solver_->reset();
  wake();
  blend_start_ = -1.0;
}

void GarmentInstance::set_state(const Vec3s& x, const Vec3s& v) {
  if (x.size() != bind_.size() || v.size() != bind_.size())
    throw Error(source_, "state", "needs " + std::to_string(bind_.size()) + " positions and velocities");
  for (size_t i = 0; i < x.size(); ++i)
    if (!x[i].allFinite() || !v[i].allFinite())
      throw Error(source_, "state", "vertex " + std::to_string(i) + " is not finite");
  cloth::ClothState& st = cloth_->state();
  st.x = x;
  st.x_prev = x;
  st.v = v;
  render_prev_ = x;
  blend_start_ = -1.0;
}

void GarmentInstance::set_max_distance_multiplier(double s) {
  constraints_.set_max_distance_multiplier(s, source_);
}

void GarmentInstance::render_positions(Vec3s& out) const {
  const double a = std::clamp((clock_ - time()) / (last_stride_ * settings_.fixed_dt), 0.0, 1.0);
  const Vec3s& x = cloth_->state().x;
  out.resize(x.size());
  for (size_t i = 0; i < x.size(); ++i) out[i] = render_prev_[i] + a * (x[i] - render_prev_[i]);
  const double blend = settings_.lod.blend_time;
  const double b = blend_start_ < 0.0 ? 0.0
                   : blend > 0.0      ? 1.0 - (clock_ - blend_start_) / blend
                                      : (clock_ == blend_start_ ? 1.0 : 0.0);
  if (b > 0.0)
    for (size_t i = 0; i < x.size(); ++i) out[i] += b * blend_offset_[i];
}

void GarmentInstance::write_positions(float* dst, size_t stride) const {
  const double a = std::clamp((clock_ - time()) / (last_stride_ * settings_.fixed_dt), 0.0, 1.0);
  const Vec3s& x = cloth_->state().x;
  const bool blending = blend_start_ >= 0.0 && clock_ - blend_start_ <= settings_.lod.blend_time;
  if (blending) render_positions(scratch_);
  for (int i = 0; i < num_vertices(); ++i) {
    const Vec3 p = blending ? scratch_[i] : Vec3(render_prev_[i] + a * (x[i] - render_prev_[i]));
    float* d = dst + static_cast<size_t>(i) * stride;
    d[0] = static_cast<float>(p.x());
    d[1] = static_cast<float>(p.y());
    d[2] = static_cast<float>(p.z());
  }
}

void GarmentInstance::write_normals(float* dst, size_t stride) const {
  render_positions(scratch_);
  vertex_normals(tris_, scratch_, scratch_normals_);
  for (int i = 0; i < num_vertices(); ++i) {
    float* d = dst + static_cast<size_t>(i) * stride;
    d[0] = static_cast<float>(scratch_normals_[i].x());
    d[1] = static_cast<float>(scratch_normals_[i].y());
    d[2] = static_cast<float>(scratch_normals_[i].z());
  }
}

void GarmentInstance::vertex_normals(const std::vector<cloth::Tri>& tris, const Vec3s& x, Vec3s& n) {
  n.assign(x.size(), Vec3::Zero());
  for (const cloth::Tri& t : tris) {
    const Vec3 a = (x[t[1]] - x[t[0]]).cross(x[t[2]] - x[t[0]]);  // twice the area times the unit normal
    for (int v : t) n[v] += a;
  }
  for (Vec3& v : n) {
    const double len = v.norm();
    v = len > 0.0 ? Vec3(v / len) : Vec3::Zero();
  }
}

}  // namespace loom::characters
