// SPDX-License-Identifier: Apache-2.0
#include "avatar_behaviour.h"

#include <algorithm>
#include <cmath>

namespace skr::wsui {
namespace {

double norm(double v, double size) {
  return size > 0 ? std::clamp(v / size * 2 - 1, -1.0, 1.0) : 0;
}

}  // namespace

AvatarBehaviour::AvatarBehaviour(AvatarOptions options, std::uint64_t seed)
    : opt_(options), rng_(seed) {}

void AvatarBehaviour::onFaces(const std::vector<Box>& faces, double width, double height,
                              std::int64_t now_ms) {
  const Box* largest = nullptr;
  for (const Box& b : faces) {
    if (b.w <= 0 || b.h <= 0) continue;
    if (largest == nullptr || b.w * b.h > largest->w * largest->h) largest = &b;
  }
  if (largest == nullptr) return;  // no face now: the last one holds for face_hold_ms
  if (!seen_face_ || now_ms - face_at_ > opt_.greet_after_ms) {
    expression_ = ExpressionCommand{"happy", 1.0, 2500};  // someone (new) to greet
  }
  seen_face_ = true;
  face_ = std::make_pair(norm(largest->x + largest->w / 2, width),
                         norm(largest->y + largest->h / 2, height));
  face_at_ = now_ms;
}

void AvatarBehaviour::onMotion(double amount, std::optional<std::pair<double, double>> centre,
                               double width, double height, std::int64_t now_ms) {
  if (amount < opt_.min_motion || !centre) return;
  motion_ = std::make_pair(norm(centre->first, width), norm(centre->second, height));
  motion_at_ = now_ms;
}

GazeCommand AvatarBehaviour::target(std::int64_t now_ms) const {
  if (face_ && now_ms - face_at_ <= opt_.face_hold_ms) return {face_->first, face_->second, "face"};
  if (motion_ && now_ms - motion_at_ <= opt_.motion_hold_ms) {
    return {motion_->first, motion_->second, "motion"};
  }
  return {0, 0, "idle"};
}

std::optional<GazeCommand> AvatarBehaviour::gazeDue(std::int64_t now_ms) {
  if (sent_at_ >= 0 && now_ms - sent_at_ < opt_.gaze_min_interval_ms) return std::nullopt;
  const GazeCommand t = target(now_ms);
  const double moved = std::hypot(t.x - sent_.x, t.y - sent_.y);
  if (sent_at_ >= 0 && t.source == sent_.source && moved < opt_.gaze_min_change) {
    return std::nullopt;
  }
  sent_ = t;
  sent_at_ = now_ms;
  return t;
}

void AvatarBehaviour::onCodes(bool any, std::int64_t /*now_ms*/) {
  if (any) expression_ = ExpressionCommand{"surprised", 1.0, 1800};
}

std::optional<ExpressionCommand> AvatarBehaviour::expressionDue() {
  auto e = std::move(expression_);
  expression_.reset();
  return e;
}

std::int64_t AvatarBehaviour::blinkInterval() {
  std::uniform_int_distribution<std::int64_t> d(opt_.blink_min_ms, opt_.blink_max_ms);
  return d(rng_);
}

std::optional<BlinkCommand> AvatarBehaviour::blinkDue(std::int64_t now_ms) {
  if (next_blink_ms_ < 0) next_blink_ms_ = now_ms + blinkInterval();
  if (now_ms < next_blink_ms_) return std::nullopt;
  // Start to start; never before this blink has ended.
  const std::int64_t length = opt_.blink_close_ms + opt_.blink_hold_ms + opt_.blink_open_ms;
  next_blink_ms_ = now_ms + std::max(blinkInterval(), length);
  return BlinkCommand{opt_.blink_close_ms, opt_.blink_hold_ms, opt_.blink_open_ms};
}

}  // namespace skr::wsui
