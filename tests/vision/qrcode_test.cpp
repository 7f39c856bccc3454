// qrcode on QR codes made at test time with the qrencode CLI, and on an EAN-13 barcode drawn
// here from the standard's tables, sent by a satellite on guest.camera.
#include "vision_fixture.h"

#include <opencv2/imgproc.hpp>

#include <cstdlib>
#include <fstream>
#include <functional>

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
}

}  // namespace
}  // namespace skr::test
