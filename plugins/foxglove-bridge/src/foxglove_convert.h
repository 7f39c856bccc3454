// SPDX-License-Identifier: Apache-2.0
// What foxglove-bridge turns hub messages into (docs/foxglove.md), and the JSON schemas it
// advertises with them (images: skrobot/foxglove/images.h). Pure functions; any thread.
#pragma once

#include <skrobot/foxglove/images.h>

#include <json/value.h>

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace skr::foxglove {

// How a hub channel is shown.
enum class Shape {
  json,         // a JSON channel as it is
  image,        // a media frame holding a JPEG: foxglove.CompressedImage
  raw_image,    // a media frame of raw pixels (docs/channels.md): foxglove.RawImage
  annotations,  // face or motion detections (JSON): foxglove.ImageAnnotations
  joints,       // {"angles": [...]} with the channel's "names": the angles by name, to plot
  typed,        // a typed channel (docs/channels.md) as it is, with its own encoding and schema
};

// The schema name and JSON schema text advertised for a shape (json: a permissive object
// schema, named after the mime type).
[[nodiscard]] std::string schemaName(Shape shape, const std::string& mime);
[[nodiscard]] std::string schemaText(Shape shape);

// face-detect's {"capture_ns", "faces": [{"x","y","w","h","score"}]} or motion's
// {"capture_ns", "regions": [{"x","y","w","h"}], "center"} as foxglove.ImageAnnotations JSON
// (boxes as closed line loops, scores as texts); nullopt when it is neither.
[[nodiscard]] std::optional<Converted> imageAnnotations(std::string_view message);
// nao-bridge's {"angles": [...]} with `names` (the channel's "names" property) as
// {"angles": [...], "positions": {"HeadYaw": ..., ...}}; nullopt when it is not that.
[[nodiscard]] std::optional<Converted> jointPositions(std::string_view message,
                                                      const std::vector<std::string>& names);

}  // namespace skr::foxglove
