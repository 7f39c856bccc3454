// SPDX-License-Identifier: Apache-2.0
// ROS 2 definitions and CDR without generated code (plugin-api/ros2): definitions parsed with
// their line numbers in errors, schema text as MCAP's ros2msg, and CDR bytes equal to those of
// the npm reference @foxglove/rosmsg2-serialization (the vectors below are its output for the
// same definitions and values), both ways, and bad samples refused naming the field.
#include <skrobot/ros2/cdr.h>
#include <skrobot/ros2/definitions.h>
#include <skrobot/support/json.hpp>

#include <gtest/gtest.h>

#include <filesystem>
#include <string>

namespace ros2 = skr::ros2;

namespace {

std::string unhex(std::string_view hex) {
  std::string out;
  for (std::size_t i = 0; i + 1 < hex.size(); i += 2) {
    out.push_back(static_cast<char>(std::stoi(std::string(hex.substr(i, 2)), nullptr, 16)));
  }
  return out;
}

Json::Value json(std::string_view text) {
  auto v = skr::support::parseJson(text);
  EXPECT_TRUE(v) << text;
  return v ? *v : Json::Value();
}

constexpr const char* kSample =
    "uint8 a\nfloat64 b\nstring name\nint16[] xs\nbool[2] flags\ngeometry_msgs/Point p\n"
    "string<=5 tag\nuint8 EMPTY=0\n"
    "================================================================================\n"
    "MSG: geometry_msgs/Point\nfloat64 x\nfloat64 y\nfloat64 z\n";
// @foxglove/rosmsg2-serialization 3.1.0's MessageWriter for kSample and the value below.
constexpr const char* kSampleCdr =
    "000100000700000000000000000000000000f83f0300000068690000030000000100feff0300010000000000"
    "000000000000f03f00000000000000400000000000000840030000006f6b00";
constexpr const char* kSampleJson =
    R"({"a":7,"b":1.5,"name":"hi","xs":[1,-2,3],"flags":[true,false],"p":{"x":1,"y":2,"z":3},)"
    R"("tag":"ok"})";

}  // namespace

TEST(Ros2Definitions, ParsesFieldsArraysBoundsConstantsAndDefaults) {
  auto def =
      ros2::parseMessage("lab/msg/Thing",
                         "# a comment\nint32 X=-5  # a constant\nstring<=8 name \"bob\"\n"
                         "float64[3] v [1.0, 2, 3]\nPoint[<=4] pts\nbuiltin_interfaces/Time t\n");
  ASSERT_TRUE(def) << def.error().message;
  ASSERT_EQ(def->constants.size(), 1u);
  EXPECT_EQ(def->constants[0].name, "X");
  EXPECT_EQ(def->constants[0].value.asInt64(), -5);
  ASSERT_EQ(def->fields.size(), 4u);
  EXPECT_EQ(def->fields[0].type.string_bound, 8u);
  EXPECT_EQ(def->fields[0].default_value->asString(), "bob");
  EXPECT_EQ(def->fields[1].type.array, ros2::FieldType::Array::fixed);
  EXPECT_EQ(def->fields[1].default_value->size(), 3u);
  EXPECT_EQ(def->fields[2].type.message, "lab/msg/Point");  // the same package
  EXPECT_EQ(def->fields[2].type.array, ros2::FieldType::Array::bounded);
  EXPECT_EQ(def->fields[3].type.message, "builtin_interfaces/msg/Time");
  EXPECT_EQ(ros2::ddsTypeName("sensor_msgs/msg/Image"), "sensor_msgs::msg::dds_::Image_");
  EXPECT_EQ(ros2::ddsTypeName("std_srvs/srv/Trigger_Request"),
            "std_srvs::srv::dds_::Trigger_Request_");
}

TEST(Ros2Definitions, BadLinesAreRefusedWithTheirLine) {
  const std::pair<const char*, const char*> bad[] = {
      {"int32 a\nfloat-99 b\n", "lab/msg/T:2: \"float-99\" is not a type"},
      {"int32 a\nint32 a\n", "lab/msg/T:2: a is defined twice"},
      {"uint8 x 300\n", "lab/msg/T:1: the default of x is not a uint8"},
      {"int32[0] x\n", "lab/msg/T:1: a fixed array needs a size"},
      {"int32\n", "lab/msg/T:1: a field needs a type and a name"},
      {"Point P=3\n", "lab/msg/T:1: a constant must be of a primitive type"},
      {"flaot32 x\n", "lab/msg/T:1: \"flaot32\" is not a type (a message's name starts with"},
      {"time stamp\n", "lab/msg/T:1: \"time\" is not a type"},
  };
  for (const auto& [text, why] : bad) {
    auto def = ros2::parseMessage("lab/msg/T", text);
    ASSERT_FALSE(def) << text;
    EXPECT_NE(def.error().message.find(why), std::string::npos) << def.error().message;
  }
  auto srv = ros2::parseService("std_srvs/srv/SetBool",
                                "bool data\n---\nbool success\nstring<=x message\n");
  ASSERT_FALSE(srv);
  EXPECT_NE(srv.error().message.find("std_srvs/srv/SetBool_Response:4:"), std::string::npos)
      << srv.error().message;
}

TEST(Ros2Definitions, ASchemaRegistersItsTypesAndIsWrittenBackTheSame) {
  ros2::Registry r;
  ASSERT_TRUE(r.addSchema("lab/msg/Sample", kSample));
  EXPECT_EQ(r.size(), 2u);
  EXPECT_TRUE(r.resolve("lab/msg/Sample"));
  EXPECT_EQ(r.schemaText("lab/Sample"), kSample);
  ros2::Registry partial;
  ASSERT_TRUE(partial.add(*ros2::parseMessage("lab/msg/Pose", "geometry_msgs/Point p\n")));
  auto missing = partial.resolve("lab/msg/Pose");
  ASSERT_FALSE(missing);
  EXPECT_EQ(missing.error().message,
            "no definition of geometry_msgs/msg/Point, used by lab/msg/Pose.p");
  // A type that uses itself, at any depth, is refused: its samples would have no end.
  ros2::Registry cycle;
  ASSERT_TRUE(cycle.add(*ros2::parseMessage("lab/msg/A", "B b\n")));
  ASSERT_TRUE(cycle.add(*ros2::parseMessage("lab/msg/B", "A[] a\n")));
  auto loop = cycle.resolve("lab/msg/A");
  ASSERT_FALSE(loop);
  EXPECT_EQ(loop.error().message, "lab/msg/A uses itself (lab/msg/B.a)");
  // Another definition of a known type is a conflict; the same one is not.
  EXPECT_TRUE(
      r.add(*ros2::parseMessage("geometry_msgs/msg/Point", "float64 x\nfloat64 y\nfloat64 z\n")));
  EXPECT_FALSE(r.add(*ros2::parseMessage("geometry_msgs/msg/Point", "float32 x\n")));
}

TEST(Ros2Cdr, MatchesTheReferenceBothWays) {
  ros2::Registry r;
  ASSERT_TRUE(r.addSchema("lab/msg/Sample", kSample));
  auto cdr = ros2::jsonToCdr(r, "lab/msg/Sample", json(kSampleJson));
  ASSERT_TRUE(cdr) << cdr.error().message;
  EXPECT_EQ(*cdr, unhex(kSampleCdr));
  auto back = ros2::cdrToJson(r, "lab/msg/Sample", unhex(kSampleCdr));
  ASSERT_TRUE(back) << back.error().message;
  EXPECT_EQ((*back)["a"].asUInt(), 7u);
  EXPECT_EQ((*back)["b"].asDouble(), 1.5);
  EXPECT_EQ((*back)["name"].asString(), "hi");
  EXPECT_EQ((*back)["xs"][1].asInt(), -2);
  EXPECT_EQ((*back)["flags"][0].asBool(), true);
  EXPECT_EQ((*back)["p"]["z"].asDouble(), 3.0);
  EXPECT_EQ((*back)["tag"].asString(), "ok");
  EXPECT_EQ((*back).size(), 7u);
  EXPECT_EQ(*ros2::jsonToCdr(r, "lab/msg/Sample", *back), unhex(kSampleCdr));
  // A message without fields is one byte; left-out fields are their defaults.
  ASSERT_TRUE(r.add(*ros2::parseMessage("std_srvs/srv/Trigger_Request", "")));
  EXPECT_EQ(*ros2::jsonToCdr(r, "std_srvs/srv/Trigger_Request", json("{}")), unhex("0001000000"));
  auto zero =
      ros2::cdrToJson(r, "lab/msg/Sample", *ros2::jsonToCdr(r, "lab/msg/Sample", json("{}")));
  ASSERT_TRUE(zero);
  EXPECT_EQ((*zero)["name"].asString(), "");
  EXPECT_EQ((*zero)["flags"].size(), 2u);
  EXPECT_EQ((*zero)["p"]["z"].asDouble(), 0.0);
}

TEST(Ros2Cdr, Float32ValuesReadAsTheirShortestDecimalAndGoBackTheSame) {
  ros2::Registry r;
  ASSERT_TRUE(r.add(*ros2::parseMessage("lab/msg/F", "float32[] v\n")));
  const float values[] = {0.1f, 1.0f / 3.0f, 16777217.0f, -2.5e-38f, 3.4028235e38f};
  Json::Value in(Json::objectValue);
  in["v"] = Json::Value(Json::arrayValue);
  for (float f : values) in["v"].append(static_cast<double>(f));
  auto sample = ros2::jsonToCdr(r, "lab/msg/F", in);
  ASSERT_TRUE(sample);
  auto read = ros2::cdrToJson(r, "lab/msg/F", *sample);
  ASSERT_TRUE(read);
  EXPECT_EQ((*read)["v"][0].asDouble(), 0.1);  // not 0.10000000149011612
  EXPECT_EQ(skr::support::writeJson((*read)["v"][0]), "0.1");
  EXPECT_EQ(*ros2::jsonToCdr(r, "lab/msg/F", *read), *sample);  // the same floats again
}

TEST(Ros2Cdr, BadSamplesAndValuesAreRefusedNamingTheField) {
  ros2::Registry r;
  ASSERT_TRUE(r.addSchema("lab/msg/Sample", kSample));
  const std::string good = unhex(kSampleCdr);
  auto cut = ros2::cdrToJson(r, "lab/msg/Sample", good.substr(0, 30));
  ASSERT_FALSE(cut);
  EXPECT_NE(cut.error().message.find("lab/msg/Sample.xs"), std::string::npos)
      << cut.error().message;
  std::string huge = good;
  huge[31] = '\x7f';  // the count of xs (bytes 28-31): 0x7f000003 elements
  auto big = ros2::cdrToJson(r, "lab/msg/Sample", huge);
  ASSERT_FALSE(big);
  EXPECT_NE(big.error().message.find("more than the sample holds"), std::string::npos)
      << big.error().message;
  EXPECT_FALSE(ros2::cdrToJson(r, "lab/msg/Sample", "\x01\x02"));
  // validate() reads as cdrToJson does, without the JSON; padding after the last field is at
  // most 3 bytes (Fast DDS pads to 4), more is another type's sample.
  EXPECT_TRUE(ros2::validate(r, "lab/msg/Sample", good));
  EXPECT_TRUE(ros2::validate(r, "lab/msg/Sample", good + std::string(3, '\0')));
  auto longer = ros2::validate(r, "lab/msg/Sample", good + std::string(4, '\0'));
  ASSERT_FALSE(longer);
  EXPECT_EQ(longer.error().message, "lab/msg/Sample: 4 bytes after the last field (another type?)");
  auto in_array = ros2::validate(r, "lab/msg/Sample", huge);
  ASSERT_FALSE(in_array);
  EXPECT_EQ(in_array.error().message, big.error().message);
  // An error inside an array element names the element.
  ASSERT_TRUE(r.addSchema(
      "lab/msg/Outer",
      "lab/Inner[] inner\n"
      "================================================================================\n"
      "MSG: lab/Inner\nbool[] flags\n"));
  auto bad_bool = ros2::cdrToJson(r, "lab/msg/Outer",
                                  unhex("00010000"
                                        "02000000"
                                        "01000000"
                                        "01"
                                        "000000"
                                        "02000000"
                                        "0102"));
  ASSERT_FALSE(bad_bool);
  EXPECT_EQ(bad_bool.error().message, "lab/msg/Outer.inner[1].flags[1]: a bool of 2 at byte 22");
  const std::pair<const char*, const char*> bad[] = {
      {R"({"a":300})", "lab/msg/Sample.a: out of range"},
      {R"({"flags":[true]})", "lab/msg/Sample.flags: 1 elements where it takes 2"},
      {R"({"tag":"toolong"})", "lab/msg/Sample.tag: a string of 7 bytes, over its bound 5"},
      {R"({"p":{"w":1}})", "lab/msg/Sample.p.w: no such field in geometry_msgs/msg/Point"},
      {R"({"xs":[1,"x"]})", "lab/msg/Sample.xs[1]: not an integer"},
  };
  for (const auto& [value, why] : bad) {
    auto cdr = ros2::jsonToCdr(r, "lab/msg/Sample", json(value));
    ASSERT_FALSE(cdr) << value;
    EXPECT_EQ(cdr.error().message, why);
  }
}

TEST(Ros2Definitions, TheShippedInterfacesLoadAndEachResolves) {
  // What a program in bin/ or a module in modules/ finds: the build tree's copy.
  const auto folder = ros2::shippedFolder(std::filesystem::path(SKROBOT_BINARY_DIR) / "bin");
  EXPECT_EQ(folder, std::filesystem::path(SKROBOT_ROS2_MSGS).lexically_normal());
  EXPECT_EQ(ros2::shippedFolder(std::filesystem::path(SKROBOT_BINARY_DIR) / "modules"), folder);
  ros2::Registry r;
  auto loaded = r.addFolder(SKROBOT_ROS2_MSGS);
  ASSERT_TRUE(loaded) << loaded.error().message;
  EXPECT_GE(r.size(), 100u);
  for (const auto& name : r.names()) {
    auto resolved = r.resolve(name);
    EXPECT_TRUE(resolved) << resolved.error().message;
  }
  // A service's halves, and a type of the same package named without its package.
  ASSERT_NE(r.find("std_srvs/srv/SetBool_Request"), nullptr);
  ASSERT_NE(r.find("nav_msgs/srv/GetMap_Response"), nullptr);
  EXPECT_EQ(r.find("nav_msgs/srv/GetMap_Response")->fields[0].type.message,
            "nav_msgs/msg/OccupancyGrid");
  // A Twist from JSON with only what is set; a Quaternion left out is its default (w = 1).
  auto twist = ros2::jsonToCdr(r, "geometry_msgs/msg/Twist", json(R"({"linear":{"x":0.5}})"));
  ASSERT_TRUE(twist);
  EXPECT_EQ(twist->size(), 4u + 48u);
  auto pose = ros2::cdrToJson(r, "geometry_msgs/msg/Pose",
                              *ros2::jsonToCdr(r, "geometry_msgs/msg/Pose", json("{}")));
  ASSERT_TRUE(pose);
  EXPECT_EQ((*pose)["orientation"]["w"].asDouble(), 1.0);
}
