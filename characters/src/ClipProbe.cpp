#include "loom/characters/ClipProbe.h"

#include <algorithm>
#include <cmath>

#include "loom/collision/Distance.h"
#include "loom/collision/MultiClothCensus.h"

namespace loom::characters {

ClipProbe::ClipProbe(std::shared_ptr<const Character> character, int census_every)
    : character_(std::move(character)), census_every_(census_every) {}

void ClipProbe::run(cloth::StageContext& ctx) {
  const Character& c = *character_;
  if (attached_.size() != ctx.cloths.size()) {
    attached_.assign(ctx.cloths.size(), {});
    for (size_t k = 0; k < ctx.cloths.size(); ++k) attached_[k].assign(ctx.cloths[k]->state().size(), 0);
    for (const Attachment& a : c.attachments) attached_[a.cloth][a.vertex] = 1;
  }
  c.motion.pose(ctx.t + ctx.h, pose_);
  for (size_t k = 0; k < ctx.cloths.size(); ++k) {
    const cloth::ClothState& s = ctx.cloths[k]->state();
    f_.finite = f_.finite && s.is_finite();
    for (int i = 0; i < s.size(); ++i) {
      const double speed = s.v[i].norm();
      if (speed > f_.max_speed) f_.max_speed = speed, f_.max_speed_time = ctx.t + ctx.h;
      double depth = 0.0;
      int bone = -1;
      for (size_t bk = 0; bk < c.rig.bones().size(); ++bk) {
        const Bone& b = c.rig.bones()[bk];
        const double d = b.radius - collision::point_segment_distance(s.x[i], pose_[b.joint].translation(),
                                                                      pose_[b.child].translation());
        if (d > depth) depth = d, bone = static_cast<int>(bk);
      }
      double& worst = attached_[k][i] ? f_.max_attached_depth : f_.max_depth;
      double& when = attached_[k][i] ? f_.max_attached_depth_time : f_.max_depth_time;
      int& which = attached_[k][i] ? f_.max_attached_depth_bone : f_.max_depth_bone;
      if (depth > worst) worst = depth, when = ctx.t + ctx.h, which = bone;
    }
  }
  for (const Attachment& a : c.attachments)
    f_.max_track =
        std::max(f_.max_track, (ctx.cloths[a.cloth]->state().x[a.vertex] - c.target(a, pose_)).norm());
  if (census_every_ > 0 && f_.steps % census_every_ == 0) {
    std::vector<collision::CensusInput> in;
    for (const auto& cl : ctx.cloths) in.push_back({&cl->mesh(), &cl->state().x});
    f_.max_intersections =
        std::max(f_.max_intersections, collision::count_all_intersections(in, ctx.threads));
    ++f_.census_steps;
  }
  ++f_.steps;
}

void ClipProbe::save_state(cloth::StateWriter& out) const {
  out.tag("character_probe");
  out.doubles({static_cast<double>(f_.steps), f_.finite ? 1.0 : 0.0, f_.max_speed, f_.max_depth,
               f_.max_attached_depth, f_.max_track, static_cast<double>(f_.max_intersections),
               static_cast<double>(f_.census_steps), f_.max_speed_time, f_.max_depth_time,
               f_.max_attached_depth_time, static_cast<double>(f_.max_depth_bone),
               static_cast<double>(f_.max_attached_depth_bone)});
}

void ClipProbe::load_state(cloth::StateReader& in) {
  in.tag("character_probe");
  const std::vector<double> d = in.doubles();
  if (d.size() != 13) return;
  f_.steps = static_cast<long>(d[0]);
  f_.finite = d[1] != 0.0;
  f_.max_speed = d[2];
  f_.max_depth = d[3];
  f_.max_attached_depth = d[4];
  f_.max_track = d[5];
  f_.max_intersections = static_cast<long>(d[6]);
  f_.census_steps = static_cast<long>(d[7]);
  f_.max_speed_time = d[8];
  f_.max_depth_time = d[9];
  f_.max_attached_depth_time = d[10];
  f_.max_depth_bone = static_cast<int>(d[11]);
  f_.max_attached_depth_bone = static_cast<int>(d[12]);
}

}  // namespace loom::characters
