// SPDX-License-Identifier: Apache-2.0
// qrcode on QR codes made at test time with the qrencode CLI, and on an EAN-13 barcode drawn
// here from the standard's tables, sent by a satellite on guest.camera; and on every picture of
// opencv-doc's sample data, where it must read nothing.
#include "vision_fixture.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>

namespace skr::test {
namespace {

// A white 640x360 frame.
cv::Mat blank() {
  return cv::Mat(360, 640, CV_8UC3, cv::Scalar(255, 255, 255));
}

// The PNG that `qrencode` makes for `text`, pasted into `frame` at `at`; returns where it is.
cv::Rect pasteQr(cv::Mat& frame, const std::filesystem::path& dir, const std::string& text,
                 cv::Point at) {
  const auto png = dir / ("qr" + std::to_string(std::hash<std::string>{}(text)) + ".png");
  const auto txt = dir / "qr.txt";
  std::ofstream(txt, std::ios::binary) << text;
  const std::string cmd = "qrencode -s 5 -m 2 -o '" + png.string() + "' -r '" + txt.string() + "'";
  EXPECT_EQ(std::system(cmd.c_str()), 0) << cmd;
  const cv::Mat qr = cv::imread(png.string());
  EXPECT_FALSE(qr.empty()) << png;
  const cv::Rect where(at, qr.size());
  qr.copyTo(frame(where));
  return where;
}

// An EAN-13 symbol (13 digits, valid check digit) drawn with `module_px` pixels per module.
void drawEan13(cv::Mat& frame, const std::string& digits, cv::Point at, int module_px = 3) {
  static const char* const kL[10] = {"0001101", "0011001", "0010011", "0111101", "0100011",
                                     "0110001", "0101111", "0111011", "0110111", "0001011"};
  static const char* const kParity[10] = {"LLLLLL", "LLGLGG", "LLGGLG", "LLGGGL", "LGLLGG",
                                          "LGGLLG", "LGGGLL", "LGLGLG", "LGLGGL", "LGGLGL"};
  auto r = [](int d) {  // R code: the L code inverted
    std::string s = kL[d];
    for (char& c : s) c = c == '1' ? '0' : '1';
    return s;
  };
  std::string bits = "101";
  const int first = digits[0] - '0';
  for (int i = 1; i <= 6; ++i) {
    const int d = digits[i] - '0';
    // G code: the R code reversed.
    const std::string rd = r(d);
    bits += kParity[first][i - 1] == 'L' ? std::string(kL[d]) : std::string(rd.rbegin(), rd.rend());
  }
  bits += "01010";
  for (int i = 7; i <= 12; ++i) bits += r(digits[i] - '0');
  bits += "101";
  for (std::size_t i = 0; i < bits.size(); ++i) {
    if (bits[i] == '1') {
      cv::rectangle(frame, cv::Rect(at.x + static_cast<int>(i) * module_px, at.y, module_px, 120),
                    cv::Scalar(0, 0, 0), cv::FILLED);
    }
  }
}

inline const char* const kSampleData = "/usr/share/doc/opencv-doc/examples/data";

// The pictures to read nothing in: opencv-doc's sample data (.png and .jpg, decompressed into
// `tmp` when Debian gzipped one), and astronaut.png, the avatar demo's fake camera.
std::vector<std::filesystem::path> samplePictures(const std::filesystem::path& tmp) {
  std::vector<std::filesystem::path> out{kAstronaut};
  for (const auto& e : std::filesystem::directory_iterator(kSampleData)) {
    std::string name = e.path().filename().string();
    const bool gz = name.size() > 3 && name.compare(name.size() - 3, 3, ".gz") == 0;
    if (gz) name.resize(name.size() - 3);
    const std::string ext = std::filesystem::path(name).extension().string();
    if (ext != ".png" && ext != ".jpg") continue;
    if (!gz) {
      out.push_back(e.path());
      continue;
    }
    const auto plain = tmp / name;
    const std::string cmd = "gzip -dc '" + e.path().string() + "' > '" + plain.string() + "'";
    EXPECT_EQ(std::system(cmd.c_str()), 0) << cmd;
    out.push_back(plain);
  }
  std::sort(out.begin() + 1, out.end());
  return out;
}

// `picture` as the avatar demo's camera shows it (tests/web/make_y4m.py --place center): scaled to
// the 640x360 frame's height, centred on grey 96. The page sends it as JPEG (camera.js: 0.7).
cv::Mat cameraFrame(const cv::Mat& picture) {
  cv::Mat frame(360, 640, CV_8UC3, cv::Scalar(96, 96, 96));
  const int w = std::min(640, cvRound(picture.cols * 360.0 / picture.rows));
  cv::Mat sized;
  cv::resize(picture, sized, cv::Size(w, 360), 0, 0, cv::INTER_AREA);
  sized.copyTo(frame(cv::Rect((640 - w) / 2, 0, w, 360)));
  return frame;
}

// "TYPE:text|TYPE:text" of a result's codes.
std::string codesOf(const Json::Value& result) {
  std::string out;
  for (const auto& c : result["codes"]) {
    out += (out.empty() ? "" : "|") + c["type"].asString() + ":" + c["text"].asString();
  }
  return out;
}

class QrCode : public VisionFixture {
 protected:
  void start(const std::string& config = R"({"input":"guest.camera"})") {
    startCamera();
    ASSERT_TRUE(startModule("qr", config, false, "qrcode").empty());
    waitCameraSubscriber();
    results_ = subscribe("qr.codes");
  }
  TestClient results_;
};

TEST_F(QrCode, DecodesTextAndCorners) {
  ASSERT_NO_FATAL_FAILURE(start());
  cv::Mat frame = blank();
  // Quotes and a backslash must survive the JSON.
  const std::string text = R"(skrobot says "hi" \ to the avatar: ok)";
  const cv::Rect where = pasteQr(frame, dir_.path(), text, {200, 60});
  ASSERT_TRUE(publish(jpegFrame(frame, 9, 123)));
  auto r = nextJson(results_);
  ASSERT_TRUE(r);
  EXPECT_EQ((*r)["seq"].asUInt64(), 9u);
  EXPECT_EQ((*r)["capture_ns"].asInt64(), 123);
  ASSERT_EQ((*r)["codes"].size(), 1u) << r->toStyledString();
  const Json::Value& code = (*r)["codes"][0];
  EXPECT_EQ(code["type"].asString(), "QR-Code");
  EXPECT_EQ(code["text"].asString(), text);
  ASSERT_EQ(code["corners"].size(), 4u);
  // The corners are those of the symbol: inside the pasted image (with its 2-module margin),
  // and spanning most of it.
  std::vector<cv::Point> corners;
  for (const auto& p : code["corners"]) corners.emplace_back(p[0].asInt(), p[1].asInt());
  const cv::Rect box = cv::boundingRect(corners);
  // zbar's order for an upright code: top-left, bottom-left, bottom-right, top-right.
  EXPECT_LT(corners[0].y, corners[1].y);
  EXPECT_LT(corners[1].x, corners[2].x);
  EXPECT_GT(corners[2].y, corners[3].y);
  EXPECT_GT(coveredBy(box, where + cv::Size(2, 2)), 0.95) << r->toStyledString();
  EXPECT_GT(box.area(), where.area() / 2) << r->toStyledString();
}

TEST_F(QrCode, AnnouncesOnlyChangesUntilRepeatMs) {
  ASSERT_NO_FATAL_FAILURE(start(R"({"input":"guest.camera","repeat_ms":600000})"));
  cv::Mat a = blank(), b = blank();
  pasteQr(a, dir_.path(), "code A", {100, 100});
  pasteQr(b, dir_.path(), "code B", {300, 100});
  ASSERT_TRUE(publish(jpegFrame(a, 1)));
  auto r = nextJson(results_);
  ASSERT_TRUE(r);
  EXPECT_EQ((*r)["codes"][0]["text"].asString(), "code A");
  // The same code again is not announced: the next message is about B. Each frame is analysed
  // (the counter says so) before the next is sent, so none is skipped for a newer one.
  ASSERT_TRUE(publish(jpegFrame(a, 2)));
  ASSERT_EQ(waitDb("qr", "processed", 2), 2);
  ASSERT_TRUE(publish(jpegFrame(a, 3)));
  ASSERT_EQ(waitDb("qr", "processed", 3), 3);
  ASSERT_TRUE(publish(jpegFrame(b, 4)));
  r = nextJson(results_);
  ASSERT_TRUE(r);
  EXPECT_EQ((*r)["seq"].asUInt64(), 4u);
  EXPECT_EQ((*r)["codes"][0]["text"].asString(), "code B");
  // B and A together is a new set; the codes come sorted.
  cv::Mat both = b.clone();
  pasteQr(both, dir_.path(), "code A", {100, 100});
  ASSERT_TRUE(publish(jpegFrame(both, 5)));
  r = nextJson(results_);
  ASSERT_TRUE(r);
  ASSERT_EQ((*r)["codes"].size(), 2u);
  EXPECT_EQ((*r)["codes"][0]["text"].asString(), "code A");
  EXPECT_EQ((*r)["codes"][1]["text"].asString(), "code B");
  // Codes gone: announced once (an empty list), then silence until a code shows up.
  ASSERT_TRUE(publish(jpegFrame(blank(), 6)));
  r = nextJson(results_);
  ASSERT_TRUE(r);
  EXPECT_EQ((*r)["seq"].asUInt64(), 6u);
  EXPECT_EQ((*r)["codes"].size(), 0u);
  ASSERT_TRUE(publish(jpegFrame(blank(), 7)));
  ASSERT_EQ(waitDb("qr", "processed", 7), 7);
  ASSERT_TRUE(publish(jpegFrame(a, 8)));
  r = nextJson(results_);
  ASSERT_TRUE(r);
  EXPECT_EQ((*r)["seq"].asUInt64(), 8u);
  EXPECT_EQ(dbInt("qr", "skipped"), 0);
}

TEST_F(QrCode, RepeatsAnUnchangedCodeAfterRepeatMs) {
  ASSERT_NO_FATAL_FAILURE(start(R"({"input":"guest.camera","repeat_ms":0})"));
  cv::Mat a = blank();
  pasteQr(a, dir_.path(), "again", {100, 100});
  for (std::uint64_t seq = 1; seq <= 3; ++seq) {
    ASSERT_TRUE(publish(jpegFrame(a, seq)));
    auto r = nextJson(results_);
    ASSERT_TRUE(r);
    EXPECT_EQ((*r)["seq"].asUInt64(), seq);
    EXPECT_EQ((*r)["codes"][0]["text"].asString(), "again");
  }
}

TEST_F(QrCode, DecodesAnEan13Barcode) {
  ASSERT_NO_FATAL_FAILURE(start());
  cv::Mat frame = blank();
  drawEan13(frame, "4006381333931", {150, 100});
  ASSERT_TRUE(publish(jpegFrame(frame, 1)));
  auto r = nextJson(results_);
  ASSERT_TRUE(r);
  ASSERT_EQ((*r)["codes"].size(), 1u) << r->toStyledString();
  EXPECT_EQ((*r)["codes"][0]["type"].asString(), "EAN-13");
  EXPECT_EQ((*r)["codes"][0]["text"].asString(), "4006381333931");
  // A barcode's corners are its bounding box: 95 modules of 3 px from x = 150.
  const Json::Value& c = (*r)["codes"][0]["corners"];
  ASSERT_EQ(c.size(), 4u);
  EXPECT_NEAR(c[0][0].asInt(), 150, 12);           // top-left
  EXPECT_NEAR(c[2][0].asInt(), 150 + 95 * 3, 12);  // bottom-right
  EXPECT_GT(c[2][1].asInt(), c[0][1].asInt());
}

// Every sample picture as it is (grey, lossless) and as the demo's camera frame at three JPEG
// qualities reads nothing with the default types; the generated codes still read exactly as
// made. With every zbar type enabled (as before "types" existed) six frames read an EAN-2 add-on
// (astronaut.png's camera frame at JPEG 75 "34", right09.jpg as it is "55", ...), and with
// DataBar enabled, aero1.jpg's camera frame at JPEG 50 reads as one.
TEST_F(QrCode, ReadsNothingInPicturesWithoutCodes) {
  ASSERT_NO_FATAL_FAILURE(start(R"({"input":"guest.camera","repeat_ms":0})"));
  // Pictures of opencv-doc that do show a code, with what they read: none so far.
  const std::map<std::string, std::string> genuine;
  std::map<std::uint64_t, std::string> sent;  // seq -> what the frame was
  std::map<std::uint64_t, std::string> want;  // seq -> the codes it must read
  std::uint64_t seq = 0;
  // One frame at a time, each analysed before the next (none replaced in the slot).
  auto send = [&](const std::string& frame, const std::string& what, const std::string& codes) {
    ++seq;
    sent[seq] = what;
    if (!codes.empty()) want[seq] = codes;
    ASSERT_TRUE(publish(frame));
    ASSERT_EQ(waitDb("qr", "processed", static_cast<std::int64_t>(seq)),
              static_cast<std::int64_t>(seq))
        << what;
  };
  const auto pictures = samplePictures(dir_.path());
  ASSERT_GT(pictures.size(), 90u) << "opencv-doc's sample data is missing";
  for (const auto& path : pictures) {
    const cv::Mat picture = cv::imread(path.string());
    ASSERT_FALSE(picture.empty()) << path;
    const std::string name = path.filename().string();
    const auto g = genuine.find(name);
    const std::string codes = g == genuine.end() ? "" : g->second;
    cv::Mat grey;
    cv::cvtColor(picture, grey, cv::COLOR_BGR2GRAY);
    ASSERT_NO_FATAL_FAILURE(send(y8Frame(grey, seq + 1), name, codes));
    const cv::Mat camera = cameraFrame(picture);
    for (const int quality : {50, 70, 75}) {
      ASSERT_NO_FATAL_FAILURE(send(jpegFrame(camera, seq + 1, 0, quality),
                                   name + " in a camera frame, JPEG " + std::to_string(quality),
                                   codes));
    }
  }
  const std::uint64_t last_picture = seq;
  // The generated codes, alone and together, lossless and as camera JPEG.
  cv::Mat qr = blank(), ean = blank(), both = blank();
  pasteQr(qr, dir_.path(), "skrobot sees you", {100, 100});
  drawEan13(ean, "4006381333931", {150, 100});
  pasteQr(both, dir_.path(), "code A", {40, 100});
  drawEan13(both, "9780201379624", {300, 100});
  const std::pair<const cv::Mat*, std::string> generated[] = {
      {&qr, "QR-Code:skrobot sees you"},
      {&ean, "EAN-13:4006381333931"},
      {&both, "EAN-13:9780201379624|QR-Code:code A"},
  };
  for (const auto& [image, codes] : generated) {
    cv::Mat grey;
    cv::cvtColor(*image, grey, cv::COLOR_BGR2GRAY);
    ASSERT_NO_FATAL_FAILURE(send(y8Frame(grey, seq + 1), codes, codes));
    ASSERT_NO_FATAL_FAILURE(send(jpegFrame(*image, seq + 1, 0, 70), codes + ", JPEG 70", codes));
  }
  // Only the sets that change are published (an empty one after an empty one is not), and
  // with repeat_ms 0 every non-empty one: so the results name every frame that read something.
  std::map<std::uint64_t, std::string> read;
  for (std::uint64_t got = 0; got < seq;) {
    auto r = nextJson(results_);
    ASSERT_TRUE(r) << "no result after frame " << got;
    got = (*r)["seq"].asUInt64();
    if (!(*r)["codes"].empty()) read[got] = codesOf(*r);
  }
  std::vector<std::string> false_reads;
  for (const auto& [s, codes] : read) {
    const auto w = want.find(s);
    if (w == want.end() || w->second != codes) false_reads.push_back(sent[s] + ": " + codes);
  }
  EXPECT_TRUE(false_reads.empty()) << ::testing::PrintToString(false_reads);
  for (const auto& [s, codes] : want) EXPECT_EQ(read[s], codes) << sent[s];
  EXPECT_GT(seq, last_picture);
  EXPECT_EQ(dbInt("qr", "skipped"), 0);
}

// "all" is zbar with every type, as before "types" existed: the EAN-2 add-on it reads in the
// astronaut's camera frame is the false read that made the default leave it out.
TEST_F(QrCode, AllTypesIncludeTheAddOnsThatMisread) {
  ASSERT_NO_FATAL_FAILURE(start(R"({"input":"guest.camera","types":"all"})"));
  ASSERT_TRUE(publish(jpegFrame(cameraFrame(cv::imread(kAstronaut)), 1, 0, 75)));
  auto r = nextJson(results_);
  ASSERT_TRUE(r);
  EXPECT_EQ(codesOf(*r), "EAN-2:34");
}

TEST_F(QrCode, QrTypesReadQrCodesOnly) {
  ASSERT_NO_FATAL_FAILURE(start(R"({"input":"guest.camera","types":"qr"})"));
  cv::Mat frame = blank();
  pasteQr(frame, dir_.path(), "code A", {40, 100});
  drawEan13(frame, "9780201379624", {300, 100});
  ASSERT_TRUE(publish(jpegFrame(frame, 1)));
  auto r = nextJson(results_);
  ASSERT_TRUE(r);
  EXPECT_EQ(codesOf(*r), "QR-Code:code A");
}

TEST_F(QrCode, MalformedFramesAreCountedAndSkipped) {
  ASSERT_NO_FATAL_FAILURE(start());
  cv::Mat a = blank();
  pasteQr(a, dir_.path(), "still alive", {100, 100});
  checkMalformedSkipped(results_, "qr", a);
}

TEST_F(QrCode, BadConfigFailsInit) {
  startHub();
  std::string why = startFailure("q1", R"({"input":"guest.camera","repeat_ms":-5})", "qrcode");
  EXPECT_NE(why.find("repeat_ms"), std::string::npos) << why;
  why = startFailure("q2", R"({"input":"guest.camera","workers":9})", "qrcode");
  EXPECT_NE(why.find("workers"), std::string::npos) << why;
  why = startFailure("q3", R"({"input":"guest.camera","density":0})", "qrcode");
  EXPECT_NE(why.find("density"), std::string::npos) << why;
  why = startFailure("q4", R"({"input":"guest.camera","types":"ean-2"})", "qrcode");
  EXPECT_NE(why.find("types"), std::string::npos) << why;
}

}  // namespace
}  // namespace skr::test
