// SPDX-License-Identifier: Apache-2.0
// What the avatar does, decided in the module (the browser only executes): where it looks and
// when it blinks. Pure logic on a caller-supplied clock, so tests drive it without waiting.
//
// Gaze is in the camera image's coordinates: x and y in -1..1 from the image centre (x to the
// image's right, y down). The page turns it into eye rotations.
#pragma once

#include <cstdint>
#include <optional>
#include <random>
#include <string>
#include <vector>

namespace skr::wsui {

struct AvatarOptions {
  double min_motion = 0.004;         // fraction of moving pixels that counts as motion
  std::int64_t face_hold_ms = 1000;  // a face is looked at this long after it was last seen
  std::int64_t motion_hold_ms = 700;
  std::int64_t blink_min_ms = 450;  // interval between blinks: uniform in [min, max]
  std::int64_t blink_max_ms = 4000;
  std::int64_t blink_close_ms = 70;  // eyelids close fast ...
  std::int64_t blink_hold_ms = 40;
  std::int64_t blink_open_ms = 160;  // ... and open slower
  double gaze_min_change = 0.03;     // smaller moves are not sent
  std::int64_t gaze_min_interval_ms = 66;
  std::int64_t greet_after_ms = 3000;  // a face after this long without one makes it smile
};

struct Box {
  double x = 0, y = 0, w = 0, h = 0;
};

struct GazeCommand {
  double x = 0, y = 0;
  std::string source;  // "face", "motion", "idle"
};
struct BlinkCommand {
  std::int64_t close_ms, hold_ms, open_ms;
};
struct ExpressionCommand {
  std::string name;  // "happy", "surprised" (the page knows docs/websocket-ui.md's six)
  double weight;
  std::int64_t duration_ms;
};

class AvatarBehaviour {
 public:
  explicit AvatarBehaviour(AvatarOptions options, std::uint64_t seed = std::random_device{}());

  // A face-detect result: boxes in pixels of a width x height frame.
  void onFaces(const std::vector<Box>& faces, double width, double height, std::int64_t now_ms);
  // A motion result: amount (fraction) and centre, in pixels of the frame.
  void onMotion(double amount, std::optional<std::pair<double, double>> centre, double width,
                double height, std::int64_t now_ms);

  // A QR code or barcode was announced (a new set of codes).
  void onCodes(bool any, std::int64_t now_ms);

  // Commands due at now_ms (call it often, e.g. every fast tick).
  std::optional<GazeCommand> gazeDue(std::int64_t now_ms);
  std::optional<BlinkCommand> blinkDue(std::int64_t now_ms);
  std::optional<ExpressionCommand> expressionDue();

  [[nodiscard]] std::int64_t nextBlinkAt() const noexcept { return next_blink_ms_; }
  [[nodiscard]] const GazeCommand& lastGaze() const noexcept { return sent_; }

 private:
  GazeCommand target(std::int64_t now_ms) const;
  std::int64_t blinkInterval();

  AvatarOptions opt_;
  std::mt19937_64 rng_;
  std::optional<std::pair<double, double>> face_;  // normalised centre of the largest face
  std::int64_t face_at_ = 0;
  bool seen_face_ = false;
  std::optional<ExpressionCommand> expression_;
  std::optional<std::pair<double, double>> motion_;
  std::int64_t motion_at_ = 0;
  GazeCommand sent_{0, 0, "idle"};
  std::int64_t sent_at_ = -1;
  std::int64_t next_blink_ms_ = -1;
};

}  // namespace skr::wsui
