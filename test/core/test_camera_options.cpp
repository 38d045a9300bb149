// The `cameras` scene key: read by the one scene parser, validated by validateSceneOptions with messages
// that name the camera's field, its value and the range.
#include "cloth_sim/core/options.h"
#include "cloth_sim/io/scene_file.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace cloth_sim::core {
namespace {

SceneOptions withCamera(const CameraOptions& camera) {
  SceneOptions options;
  options.cameras.push_back(camera);
  return options;
}

CameraOptions namedCamera() {
  CameraOptions camera;
  camera.name = "front";
  camera.frame = "front_optical";
  return camera;
}

/// The problem naming `field`, or "" with a test failure if there is none.
std::string problemAbout(const SceneOptions& options, const std::string& field) {
  for (const std::string& problem : validateSceneOptions(options)) {
    if (problem.compare(0, field.size(), field) == 0) return problem;
  }
  ADD_FAILURE() << "no problem names " << field;
  return "";
}

TEST(CameraOptions, ADefaultCameraWithANameAndAFrameIsValid) {
  EXPECT_TRUE(validateSceneOptions(withCamera(namedCamera())).empty());
}

TEST(CameraOptions, BadIntrinsicsAreRefusedByName) {
  CameraOptions camera = namedCamera();
  camera.fx_px = 0.0;
  camera.fy_px = -525.0;
  SceneOptions options = withCamera(camera);
  EXPECT_EQ(problemAbout(options, "cameras[0].fx"), "cameras[0].fx = 0: must be in (0, 1e+06]");
  EXPECT_EQ(problemAbout(options, "cameras[0].fy"), "cameras[0].fy = -525: must be in (0, 1e+06]");
  // A value just past a limit is printed with the digits that tell it from the limit.
  camera.fx_px = 1000001.0;
  camera.fy_px = 1e6 * (1.0 + 1e-15);
  options = withCamera(camera);
  EXPECT_EQ(problemAbout(options, "cameras[0].fx"), "cameras[0].fx = 1000001: must be in (0, 1e+06]");
  EXPECT_EQ(problemAbout(options, "cameras[0].fy"), "cameras[0].fy = 1000000.0000000012: must be in (0, 1e+06]");

  camera = namedCamera();
  camera.width = 0;
  camera.height = 0;
  options = withCamera(camera);
  EXPECT_EQ(problemAbout(options, "cameras[0].width"), "cameras[0].width = 0: must be in [1, 4096]");
  EXPECT_EQ(problemAbout(options, "cameras[0].height"), "cameras[0].height = 0: must be in [1, 4096]");

  camera = namedCamera();
  camera.width = 8192;  // over the stated limit of 4096 x 4096
  EXPECT_EQ(problemAbout(withCamera(camera), "cameras[0].width"), "cameras[0].width = 8192: must be in [1, 4096]");
}

TEST(CameraOptions, BadRatesAndRangesAreRefusedByName) {
  CameraOptions camera = namedCamera();
  camera.rate_hz = 0.0;
  EXPECT_EQ(problemAbout(withCamera(camera), "cameras[0].rate"), "cameras[0].rate = 0: must be in (0, 1000]");
  camera.rate_hz = 5000.0;
  EXPECT_EQ(problemAbout(withCamera(camera), "cameras[0].rate"), "cameras[0].rate = 5000: must be in (0, 1000]");
  camera = namedCamera();
  camera.min_range_m = 3.0;
  camera.max_range_m = 2.0;
  EXPECT_EQ(problemAbout(withCamera(camera), "cameras[0].min_range"),
            "cameras[0].min_range = 3 m: must be below max_range = 2 m");
}

TEST(CameraOptions, NamesMustBeTopicNamesAndUnique) {
  CameraOptions camera = namedCamera();
  SceneOptions options;
  options.cameras = {camera, camera};
  EXPECT_EQ(problemAbout(options, "cameras[1].name"), "cameras[1].name = 'front': another camera has this name");
  camera.name = "front camera";
  EXPECT_NE(problemAbout(withCamera(camera), "cameras[0].name").find("must be a letter"), std::string::npos);
  camera = namedCamera();
  camera.frame = "";
  EXPECT_NE(problemAbout(withCamera(camera), "cameras[0].frame").find("non-empty tf frame"), std::string::npos);
  // An audit's: names and frames of 10,001 characters were taken (and written to state files, which refuse
  // strings over 4096 characters); the limit is every scene string's.
  camera = namedCamera();
  camera.name = "c" + std::string(OptionLimits::kMaxTextChars, 'a');
  EXPECT_NE(problemAbout(withCamera(camera), "cameras[0].name").find("at most 4096 characters"), std::string::npos);
  camera.name.pop_back();
  EXPECT_TRUE(validateSceneOptions(withCamera(camera)).empty()) << "4096 characters are allowed";
  camera = namedCamera();
  camera.frame = "f" + std::string(OptionLimits::kMaxTextChars, 'a');
  EXPECT_NE(problemAbout(withCamera(camera), "cameras[0].frame").find("at most 4096 characters"), std::string::npos);
}

bool readScene(const std::string& text, SceneOptions* options, std::vector<std::string>* errors) {
  return applySceneYaml(YAML::Load(text), "test", options, errors);
}

// One scene entry points a camera: unspecified fields take the defaults, cx and cy the image's centre.
TEST(CameraOptions, OneSceneEntryDeclaresACamera) {
  SceneOptions options;
  std::vector<std::string> errors;
  ASSERT_TRUE(readScene("cameras: [{name: side, frame: side_optical, width: 320, height: 240, noise: kinect, seed: 3}]",
                        &options, &errors))
      << errors.front();
  ASSERT_EQ(options.cameras.size(), 1u);
  const CameraOptions& camera = options.cameras[0];
  EXPECT_EQ(camera.name, "side");
  EXPECT_EQ(camera.frame, "side_optical");
  EXPECT_EQ(camera.cx_px, 159.5);
  EXPECT_EQ(camera.cy_px, 119.5);
  EXPECT_EQ(camera.fx_px, 525.0);
  EXPECT_EQ(camera.noise, DepthNoise::kKinect);
  EXPECT_EQ(camera.seed, 3u);
  EXPECT_TRUE(validateSceneOptions(options).empty());
}

TEST(CameraOptions, UnknownNoiseAndKeysAreRefusedByName) {
  SceneOptions options;
  std::vector<std::string> errors;
  EXPECT_FALSE(readScene("cameras: [{name: a, frame: f, noise: laser}]", &options, &errors));
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_NE(errors[0].find("cameras"), std::string::npos) << errors[0];
  EXPECT_NE(errors[0].find("none or kinect"), std::string::npos) << errors[0];
  errors.clear();
  EXPECT_FALSE(readScene("cameras: [{name: a, frame: f, focal: 500}]", &options, &errors));
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_NE(errors[0].find("'focal'"), std::string::npos) << errors[0];
}

// A seed past an int's range is refused with the range it must lie in, not as "not an integer".
TEST(CameraOptions, ASeedOutOfRangeIsRefusedWithItsRange) {
  SceneOptions options;
  std::vector<std::string> errors;
  for (const char* seed : {"2147483648", "-1"}) {
    errors.clear();
    EXPECT_FALSE(readScene(std::string("cameras: [{name: a, frame: f, seed: ") + seed + "}]", &options, &errors));
    ASSERT_EQ(errors.size(), 1u) << seed;
    EXPECT_NE(errors[0].find(std::string("maps whose seed is an integer within [0, 2147483647] ([0].seed = '") +
                             seed + "')"),
              std::string::npos)
        << errors[0];
  }
}

// Any other integer field past an int's range says so, and its own range comes from validation.
TEST(CameraOptions, AnIntegerPastAnIntsRangeIsRefusedAsSuch) {
  SceneOptions options;
  std::vector<std::string> errors;
  EXPECT_FALSE(readScene("cameras: [{name: a, frame: f, width: 3000000000}]", &options, &errors));
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_NE(errors[0].find("width is an integer no larger in size than 2147483647"), std::string::npos) << errors[0];
}

}  // namespace
}  // namespace cloth_sim::core
