#include "core/json_file.h"

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <unistd.h>

#include "core/error.h"
#include "core/test_dir.h"

namespace relit {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

testing::AssertionResult Contains(const std::string& text, const std::string& part) {
  if (text.find(part) != std::string::npos) return testing::AssertionSuccess();
  return testing::AssertionFailure() << "'" << part << "' not found in: " << text;
}

using test_support::ReadText;
using test_support::WriteText;

class JsonFileTest : public test_support::TempDirTest {
 protected:
  JsonFileTest() : TempDirTest("relit_json_") {}

  std::string Path(const std::string& name) const { return (root_ / name).string(); }
  // The message of the relit::Error thrown by ReadJsonFile.
  static std::string ReadError(const std::string& path, const std::string& kind, int version) {
    try {
      ReadJsonFile(path, kind, version);
    } catch (const Error& e) {
      return e.what();
    }
    ADD_FAILURE() << "expected relit::Error for " << path;
    return "";
  }
  // The message of reading `path` as relit.cameras/2, checked to name the
  // file and to hold every one of `parts`.
  static std::string CamerasError(const std::string& path, const std::vector<std::string>& parts) {
    const std::string message = ReadError(path, "cameras", 2);
    EXPECT_TRUE(Contains(message, path));
    for (const std::string& part : parts) EXPECT_TRUE(Contains(message, part));
    return message;
  }
};

TEST_F(JsonFileTest, SchemaString) { EXPECT_EQ(SchemaString("cameras", 2), "relit.cameras/2"); }

TEST_F(JsonFileTest, WriteThenReadRoundTripsWithSchemaFirst) {
  const std::string path = Path("sub/dir/cameras.json");
  WriteJsonFile(path, "cameras", 2, json{{"alpha", 1}, {"beta", {1, 2, 3}}, {"schema", "bogus"}});
  const std::string text = ReadText(path);
  EXPECT_EQ(text.rfind("{\n  \"schema\": \"relit.cameras/2\",\n", 0), 0u) << text;
  EXPECT_EQ(text.back(), '\n');
  const json document = ReadJsonFile(path, "cameras", 2);
  EXPECT_EQ(document["schema"], "relit.cameras/2");
  EXPECT_EQ(document["alpha"], 1);
  EXPECT_EQ(document["beta"], json({1, 2, 3}));
}

TEST_F(JsonFileTest, MissingFileNamesFileAndSchema) {
  const std::string path = Path("nope.json");
  CamerasError(path, {"does not exist", "relit.cameras/2"});
}

TEST_F(JsonFileTest, ParseErrorHasLineAndColumn) {
  const std::string path = Path("broken.json");
  WriteText(path, "{\n  \"schema\": \"relit.cameras/2\",\n  \"a\": [1, 2,\n}\n");
  const std::string message = CamerasError(path, {"invalid JSON", "line 4", "column"});
  EXPECT_FALSE(Contains(message, "[json.exception"));
}

// Values a JSON library accepts or throws on in its own words: relit names
// the file and says what to do (docs/refusals.md).
TEST_F(JsonFileTest, HostileValuesNameTheFile) {
  const std::string path = Path("huge.json");
  WriteText(path, "{\"schema\": \"relit.cameras/2\", \"fx\": 1e400}\n");
  CamerasError(path, {"fit a double"});
  json j = ToJson(Intrinsics::FromFov(640, 480, 1.1));
  j["width"] = 100000;
  j["height"] = 100000;
  try {
    IntrinsicsFromJson(j, "cameras.json: devices.view");
    ADD_FAILURE() << "a 100000 x 100000 camera was accepted";
  } catch (const Error& e) {
    EXPECT_TRUE(Contains(e.what(), "cameras.json: devices.view")) << e.what();
    EXPECT_TRUE(Contains(e.what(), "larger than relit handles")) << e.what();
  }
}

TEST_F(JsonFileTest, MissingSchema) {
  const std::string path = Path("plain.json");
  WriteText(path, "{\"a\": 1}");
  CamerasError(path, {"no \"schema\"", "relit.cameras/2"});
}

TEST_F(JsonFileTest, NotAnObject) {
  const std::string path = Path("array.json");
  WriteText(path, "[1, 2]");
  EXPECT_TRUE(Contains(ReadError(path, "cameras", 2), "found an array"));
}

TEST_F(JsonFileTest, OtherKind) {
  const std::string path = Path("poses.json");
  WriteJsonFile(path, "poses", 2, json::object());
  CamerasError(path, {"relit.poses/2", "expected relit.cameras/2"});
}

TEST_F(JsonFileTest, NewerAndOlderVersion) {
  const std::string path = Path("cameras.json");
  WriteJsonFile(path, "cameras", 3, json::object());
  CamerasError(path, {"newer relit (relit.cameras/3)", "this build reads relit.cameras/2", "rerun the stage"});

  WriteJsonFile(path, "cameras", 1, json::object());
  CamerasError(path, {"older relit (relit.cameras/1)"});
}

TEST_F(JsonFileTest, MalformedSchema) {
  const std::string path = Path("odd.json");
  WriteText(path, "{\"schema\": \"cameras-v2\"}");
  EXPECT_TRUE(Contains(ReadError(path, "cameras", 2), "\"cameras-v2\""));
  WriteText(path, "{\"schema\": 2}");
  EXPECT_TRUE(Contains(ReadError(path, "cameras", 2), "must be a string"));
}

TEST(JsonConvert, Vector3RoundTripAndErrors) {
  const Eigen::Vector3d v(0.1, -2.5, 1e-17);
  EXPECT_EQ(Vector3FromJson(ToJson(v)), v);
  EXPECT_THROW(Vector3FromJson(json({1, 2})), Error);
  EXPECT_THROW(Vector3FromJson(json({1, "2", 3})), Error);
  EXPECT_THROW(Vector3FromJson(json{{"x", 1}}), Error);
}

TEST(JsonConvert, Rigid3RoundTripIsExact) {
  const Rigid3 transform(
      Eigen::Quaterniond(Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, -2, 0.5).normalized())),
      Eigen::Vector3d(0.123456789012345, -1.5, 3e-9));
  const json j = ToJson(transform);
  ASSERT_TRUE(j.contains("rotation_wxyz"));
  EXPECT_EQ(j["rotation_wxyz"][0].get<double>(), transform.rotation.w());
  // Through text as well, since that is how it is stored.
  const Rigid3 back = Rigid3FromJson(json::parse(j.dump()));
  EXPECT_EQ(back.translation, transform.translation);
  EXPECT_LT(RotationAngle(back.rotation, transform.rotation), 1e-15);
}

TEST(JsonConvert, Rigid3Errors) {
  json j = ToJson(Rigid3());
  j.erase("translation_m");
  try {
    Rigid3FromJson(j, "poses.json: frames[2]");
    FAIL();
  } catch (const Error& e) {
    EXPECT_TRUE(Contains(e.what(), "poses.json: frames[2]"));
    EXPECT_TRUE(Contains(e.what(), "translation_m"));
  }
  j = ToJson(Rigid3());
  j["rotation_wxyz"] = {0, 0, 0, 0};
  EXPECT_THROW(Rigid3FromJson(j), Error);
}

TEST(JsonConvert, IntrinsicsRoundTrip) {
  Intrinsics k = Intrinsics::FromFov(640, 480, 1.1);
  k.cx += 3.25;
  k.distortion = {0.12, -0.25, 0.001, -0.0015, 0.1};
  const json j = json::parse(ToJson(k).dump());
  EXPECT_EQ(j["distortion"]["p2"].get<double>(), -0.0015);
  const Intrinsics back = IntrinsicsFromJson(j);
  EXPECT_EQ(back.width, 640);
  EXPECT_EQ(back.height, 480);
  EXPECT_EQ(back.fx, k.fx);
  EXPECT_EQ(back.fy, k.fy);
  EXPECT_EQ(back.cx, k.cx);
  EXPECT_EQ(back.cy, k.cy);
  EXPECT_EQ(back.distortion.k1, k.distortion.k1);
  EXPECT_EQ(back.distortion.k2, k.distortion.k2);
  EXPECT_EQ(back.distortion.p1, k.distortion.p1);
  EXPECT_EQ(back.distortion.p2, k.distortion.p2);
  EXPECT_EQ(back.distortion.k3, k.distortion.k3);
}

TEST(JsonConvert, IntrinsicsErrorsNameTheField) {
  const json good = ToJson(Intrinsics::FromFov(640, 480, 1.1));
  auto error_for = [](const json& j) -> std::string {
    try {
      IntrinsicsFromJson(j, "cam.json");
    } catch (const Error& e) {
      return e.what();
    }
    return "(no error)";
  };
  json j = good;
  j.erase("fy");
  EXPECT_TRUE(Contains(error_for(j), "missing field 'fy'"));
  j = good;
  j["width"] = 640.5;
  EXPECT_TRUE(Contains(error_for(j), "'width': expected an integer"));
  j = good;
  j["cx"] = "320";
  EXPECT_TRUE(Contains(error_for(j), "'cx': expected a number"));
  j = good;
  j["distortion"].erase("k3");
  EXPECT_TRUE(Contains(error_for(j), "cam.json.distortion: missing field 'k3'"));
  j = good;
  j["fx"] = -5;
  EXPECT_TRUE(Contains(error_for(j), "focal lengths must be positive"));
}

}  // namespace
}  // namespace relit
