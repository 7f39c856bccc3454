// SPDX-License-Identifier: Apache-2.0
// What the detectors' results are (docs/vision.md, "Results"), as typed channels declare it
// (docs/channels.md, "Typed channels"): JSON, with a JSON Schema each. tests/web/
// channel_types.test.mjs checks the messages the modules publish against them.
#pragma once

#include <skrobot/channel_type.hpp>

namespace skr::vision {

// The fields every result has: the frame it came from.
#define SKR_VISION_FRAME_FIELDS                                              \
  R"("seq":{"type":"integer","minimum":0},"capture_ns":{"type":"integer"},)" \
  R"("width":{"type":"integer","minimum":0},"height":{"type":"integer","minimum":0},)"
#define SKR_VISION_BOX                                                                    \
  R"({"type":"object","required":["x","y","w","h"],"properties":{"x":{"type":"number"},)" \
  R"("y":{"type":"number"},"w":{"type":"number","minimum":0},"h":{"type":"number","minimum":0}}})"

inline constexpr const char* kFacesSchema =
    R"({"$schema":"http://json-schema.org/draft-07/schema#","title":"skrobot.vision.Faces",)"
    R"("description":"The faces found in one frame of the source channel, docs/vision.md",)"
    R"("type":"object","required":["seq","capture_ns","width","height","faces"],"properties":{)" SKR_VISION_FRAME_FIELDS
    R"("faces":{"type":"array","items":{"allOf":[)" SKR_VISION_BOX
    R"(,{"type":"object","required":["score"],"properties":{"score":{"type":"number"}}}]}}}})";

inline constexpr const char* kMotionSchema =
    R"({"$schema":"http://json-schema.org/draft-07/schema#","title":"skrobot.vision.Motion",)"
    R"("description":"What moved in one frame of the source channel, docs/vision.md",)"
    R"("type":"object","required":["seq","capture_ns","width","height","amount","center",)"
    R"("regions"],"properties":{)" SKR_VISION_FRAME_FIELDS
    R"("amount":{"type":"number","minimum":0,"maximum":1},)"
    R"("center":{"oneOf":[{"type":"null"},{"type":"object","required":["x","y"],)"
    R"("properties":{"x":{"type":"number"},"y":{"type":"number"}}}]},)"
    R"("regions":{"type":"array","items":)" SKR_VISION_BOX R"(}}})";

inline constexpr const char* kCodesSchema =
    R"({"$schema":"http://json-schema.org/draft-07/schema#","title":"skrobot.vision.Codes",)"
    R"("description":"The QR codes and barcodes in view, docs/vision.md",)"
    R"("type":"object","required":["seq","capture_ns","width","height","codes"],)"
    R"("properties":{)" SKR_VISION_FRAME_FIELDS
    R"("codes":{"type":"array","items":{"type":"object","required":["type","text","corners"],)"
    R"("properties":{"type":{"type":"string"},"text":{"type":"string"},)"
    R"("corners":{"type":"array","minItems":4,"maxItems":4,"items":{"type":"array",)"
    R"("minItems":2,"maxItems":2,"items":{"type":"number"}}}}}}}})";

#undef SKR_VISION_BOX
#undef SKR_VISION_FRAME_FIELDS

inline channel_type::ChannelType facesType() {
  return {"json", "skrobot.vision.Faces", "jsonschema", kFacesSchema};
}
inline channel_type::ChannelType motionType() {
  return {"json", "skrobot.vision.Motion", "jsonschema", kMotionSchema};
}
inline channel_type::ChannelType codesType() {
  return {"json", "skrobot.vision.Codes", "jsonschema", kCodesSchema};
}

}  // namespace skr::vision
