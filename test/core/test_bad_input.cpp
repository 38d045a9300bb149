// Bad input that reaches the core through scene files and parameters (doc/RELIABILITY.md, "Bad input"):
// each one is refused with a reason that names what is wrong, quotes at most a short excerpt of the
// file, and never reads more of a file than the limit.
#include "cloth_sim/core/constants.h"
#include "cloth_sim/core/simulation.h"
#include "cloth_sim/io/scene_file.h"

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

namespace cloth_sim::core {
namespace {

namespace fs = std::filesystem;

/// A fresh folder under the test's temporary directory.
std::string scratchDir(const std::string& name) {
  const fs::path dir = fs::path(::testing::TempDir()) / ("cloth_sim_bad_input_" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir.string();
}

std::string writeFile(const std::string& dir, const std::string& name, const std::string& text) {
  const std::string path = dir + "/" + name;
  std::ofstream(path, std::ios::binary) << text;
  return path;
}

/// Loads `path` expecting a refusal; returns all errors joined.
std::string refusal(const std::string& path) {
  SceneOptions options;
  std::vector<std::string> errors;
  EXPECT_FALSE(loadSceneFile(path, &options, &errors)) << path;
  std::string joined;
  for (const std::string& e : errors) joined += e + "\n";
  EXPECT_FALSE(joined.empty()) << "refused without a reason: " << path;
  return joined;
}

std::string refusalOf(const std::string& yaml) {
  return refusal(writeFile(scratchDir("yaml"), "scene.yaml", yaml));
}

bool mentions(const std::string& text, const std::string& needle) { return text.find(needle) != std::string::npos; }

/// The scene `yaml` is refused with a message that mentions `needle`.
void expectRefusalMentions(const std::string& yaml, const std::string& needle) {
  const std::string message = refusalOf(yaml);
  EXPECT_TRUE(mentions(message, needle)) << yaml << "\n" << message;
}

/// The first problem validation finds with `options`, or "" when it accepts them.
std::string problemsWith(const SceneOptions& options) {
  const std::vector<std::string> problems = validateSceneOptions(options);
  std::string joined;
  for (const std::string& p : problems) joined += p + "\n";
  return joined;
}

// ---- scene files: paths, kinds of file, sizes ----------------------------------------------------

TEST(BadSceneFile, AnEmptyNameIsRefused) {
  EXPECT_TRUE(mentions(refusal(resolveScenePath("", "/nonexistent")), "empty"));
}

TEST(BadSceneFile, ADirectoryIsRefusedEvenWithAYamlName) {
  const std::string dir = scratchDir("directory") + "/looks_like.yaml";
  fs::create_directories(dir);
  EXPECT_TRUE(mentions(refusal(dir), "is a directory"));
}

TEST(BadSceneFile, AFifoOrADeviceIsRefusedWithoutBeingOpened) {
  // Opening a FIFO with no writer blocks forever: refusing it proves the kind was checked first.
  const std::string dir = scratchDir("special");
  const std::string fifo = dir + "/pipe.yaml";
  ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
  EXPECT_TRUE(mentions(refusal(fifo), "not a regular file"));
  const std::string device = dir + "/zero.yaml";
  fs::create_symlink("/dev/zero", device);
  EXPECT_TRUE(mentions(refusal(device), "not a regular file"));
}

TEST(BadSceneFile, AFileThatIsNotNamedLikeASceneFileIsRefusedBeforeItIsOpened) {
  // /etc/passwd and ../../etc/hostname are what a peer tried; neither is opened.
  EXPECT_TRUE(mentions(refusal("/etc/passwd"), "not a scene file"));
  EXPECT_TRUE(mentions(refusal(resolveScenePath("../../etc/hostname", "/nonexistent")), "not a scene file"));
  EXPECT_EQ(resolveScenePath("hanging", "/scenes"), "/scenes/hanging.yaml") << "built-in names still resolve";
}

TEST(BadSceneFile, AFileOverTheSizeLimitIsRefusedAndTheMessageStaysShort) {
  // A valid scene padded with a comment to one byte over the limit: only its size is wrong.
  const std::string scene = "rows: 5\ncols: 5\n# ";
  std::string text = scene + std::string(kMaxSceneFileBytes + 1 - scene.size() - 1, 'x') + "\n";
  ASSERT_EQ(text.size(), kMaxSceneFileBytes + 1);
  const std::string dir = scratchDir("big");
  const std::string message = refusal(writeFile(dir, "big.yaml", text));
  EXPECT_TRUE(mentions(message, "larger than the limit of " + std::to_string(kMaxSceneFileBytes) + " bytes"))
      << message;
  EXPECT_LT(message.size(), 300u) << message;
  // Control: at the limit exactly, the same scene loads.
  text.erase(text.size() - 2, 1);
  ASSERT_EQ(text.size(), kMaxSceneFileBytes);
  SceneOptions options;
  std::vector<std::string> errors;
  EXPECT_TRUE(loadSceneFile(writeFile(dir, "limit.yaml", text), &options, &errors))
      << (errors.empty() ? "" : errors.front());
  EXPECT_EQ(options.rows, 5);
}

// ---- scene files: content --------------------------------------------------------------------------

TEST(BadSceneFile, AnEmptyOrBlankFileIsRefused) {
  EXPECT_TRUE(mentions(refusalOf(""), "empty"));
  EXPECT_TRUE(mentions(refusalOf("  \n\n"), "empty"));
}

TEST(BadSceneFile, MalformedYamlNamesTheLineAndQuotesNoContent) {
  const std::string message = refusalOf("rows: 5\ncols: [1, 2\nsecret_token_1234: 1\n");
  EXPECT_TRUE(mentions(message, "not valid YAML at line")) << message;
  EXPECT_FALSE(mentions(message, "secret_token_1234")) << message;
}

TEST(BadSceneFile, ASecondYamlDocumentIsRefusedNotDroppedUnread) {
  // An audit's: only the first document was read, so `cols` after a `---` was lost (a 10 x 20 cloth ran)
  // and a malformed second document loaded without a word.
  EXPECT_TRUE(mentions(refusalOf("rows: 10\n---\ncols: 10\n"), "2 YAML documents (separated by ---)"));
  EXPECT_TRUE(mentions(refusalOf("rows: 10\ncols: 10\n---\nmass: [oops\n"), "not valid YAML at line 5"));
  // A document marker before or after the one document is still one scene.
  SceneOptions options;
  std::vector<std::string> errors;
  const std::string dir = scratchDir("documents");
  EXPECT_TRUE(loadSceneFile(writeFile(dir, "marked.yaml", "---\nrows: 7\ncols: 6\n---\n"), &options, &errors))
      << (errors.empty() ? "" : errors.front());
  EXPECT_EQ(options.rows, 7);
  EXPECT_EQ(options.cols, 6);
}

TEST(BadSceneFile, AFileThatIsNotASceneIsQuotedOnlyAsAShortCutExcerpt) {
  // /etc/passwd renamed .yaml: one long plain scalar. Before, the whole of it came back in the message.
  const std::string passwd =
      "root:x:0:0:root:/root:/bin/bash\ndaemon:x:1:1:daemon:/usr/sbin:/usr/sbin/nologin\n"
      "secret:x:1000:1000:the_part_that_must_not_leak:/home/secret:/bin/bash\n";
  const std::string message = refusalOf(passwd);
  EXPECT_TRUE(mentions(message, "expected a map of scene keys")) << message;
  EXPECT_TRUE(mentions(message, "root:x:0:0")) << "a short excerpt helps to recognise the file: " << message;
  EXPECT_TRUE(mentions(message, "...'")) << "the excerpt is marked as cut: " << message;
  EXPECT_FALSE(mentions(message, "the_part_that_must_not_leak")) << message;
  EXPECT_LT(message.size(), 200u) << message;
}

TEST(BadSceneFile, LongUnknownKeysAndValuesAreCut) {
  const std::string secret = "the_part_that_must_not_leak";
  const std::string padding(60, 'k');
  for (const std::string& yaml :
       {padding + secret + ": 1\n", "rows: " + padding + secret + "\n", "pins: [" + padding + secret + "]\n",
        "spheres:\n  - {" + padding + secret + ": 1}\n", "integrator: " + padding + secret + "\n"}) {
    const std::string message = refusalOf(yaml);
    EXPECT_FALSE(mentions(message, secret)) << message;
    EXPECT_TRUE(mentions(message, "kkkk")) << "still quotes the start: " << message;
  }
}

TEST(BadSceneFile, ADuplicateKeyIsRefusedByName) {
  // yaml-cpp keeps both entries; before, the last one silently won.
  const std::string message = refusalOf("rows: 5\ncols: 5\nrows: 7\n");
  EXPECT_TRUE(mentions(message, "duplicate key 'rows'")) << message;
  EXPECT_TRUE(mentions(refusalOf("spheres:\n  - {center: [0, 0, 0], radius: 0.1, radius: 0.2}\n"), "'radius' twice"));
}

TEST(BadSceneFile, WrongTypesAreRefusedByName) {
  EXPECT_TRUE(mentions(refusalOf("rows: [5]\n"), "rows"));
  EXPECT_TRUE(mentions(refusalOf("mass: heavy\n"), "a number"));
  EXPECT_TRUE(mentions(refusalOf("gravity: 9.81\n"), "3 numbers"));
  EXPECT_TRUE(mentions(refusalOf("spheres: {center: [0, 0, 0]}\n"), "a list of maps"));
}

TEST(BadSceneFile, AWrongTypeInsideAListOrAMaterialNamesTheEntryAndTheField) {
  // Before: "cameras = a list of 1: expected an integer", naming neither the camera nor the field.
  const std::string camera = refusalOf("cameras:\n  - {name: front, frame: f, width: 640.5}\n");
  EXPECT_TRUE(mentions(camera, "maps whose width is an integer")) << camera;
  EXPECT_TRUE(mentions(camera, "[0].width = '640.5'")) << camera;
  const std::string second = refusalOf("spheres:\n  - {center: [0, 0, 0], radius: 0.1}\n  - {center: [0, 0, 1], radius: big}\n");
  EXPECT_TRUE(mentions(second, "[1].radius = 'big'")) << second;
  // A field's own refusal (not a type: an unknown name) is worded the same way, with the entry added.
  const std::string noise = refusalOf("cameras:\n  - {name: front, frame: f, noise: loud}\n");
  EXPECT_TRUE(mentions(noise, "maps whose noise is none or kinect ([0].noise = 'loud')")) << noise;
  const std::string damping = refusalOf("material: {preset: denim, damping: abc}\n");
  EXPECT_TRUE(mentions(damping, "a map whose damping is a number (damping = 'abc')")) << damping;
  const std::string substeps = refusalOf("substeps: automatic\n");
  EXPECT_TRUE(mentions(substeps, "'auto' or an integer in [1, ")) << substeps;
}

TEST(BadSceneFile, ANumberNoDoubleHoldsIsNamedAsSuchAndWhichComponent) {
  // An audit's: 1e400 read as "expected a number", and in a vector without saying which of the three.
  expectRefusalMentions("mass: 1e400\n", "expected a number a double holds");
  expectRefusalMentions("gravity: [0, 0, -1e400]\n", "its [2] = '-1e400' is not a number a double holds");
  expectRefusalMentions("gravity: [0, zero, -9.81]\n", "its [1] = 'zero' is not a number)");
}

TEST(BadSceneFile, EachOutlineMistakeIsNamed) {
  // An audit's: each of these answered only the forms expected.
  const std::vector<std::pair<std::string, std::string>> cases{
      {"{circle: {center: [0.5, 0.5], radius: 0.5, extra: 1}}", "the key 'extra' is not one of them"},
      {"{circle: {center: [0.5, 0.5]}}", "the circle has no radius"},
      {"{circle: {center: [0.5, 0.5], radius: 0.5}, polygon: [[0, 0], [1, 0], [0, 1]]}", "not both"},
      {"{circle: {center: [0.5, 0.5, 0], radius: 0.5}}", "the circle's center is a list of 3, not [u, v]"},
      {"{circle: {center: [0.5, 0.5], radius: wide}}", "the circle's radius is 'wide', not a number"},
      {"{polygon: [[0, 0], [1, 0], [0, 1, 2]]}", "corner [2] is a list of 3, not [u, v]"},
      {"{square: 1}", "the key 'square' is not one of them"},
      {"round", "got 'round'"},
      {"{}", "an empty map: give circle or polygon"},
  };
  for (const auto& [outline, named] : cases) expectRefusalMentions("rows: 10\ncols: 10\noutline: " + outline + "\n", named);
  expectRefusalMentions("rows: 10\ncols: 10\noutline: {circle: {center: [0.5, 0.5], radius: 0.5, radius: 0.4}}\n",
                        "'radius' twice");
}

TEST(BadSceneFile, AFrameColliderWithoutItsShapeOrWithAFieldOutOfRangeIsRefused) {
  // An audit's: {frame: link1, size: [...]} ran as a 5 cm sphere (no shape: a sphere), and a box's
  // radius -1 was taken because a box does not use it.
  expectRefusalMentions("frame_colliders: [{frame: link1, size: [0.3, 0.3, 0.3]}]\n",
                        "[0] has size but no shape, so it would be a sphere: give shape: box");
  expectRefusalMentions("frame_colliders: [{frame: link1, length: 0.3}]\n", "give shape: capsule");
  SceneOptions options;
  FrameCollider link;
  link.frame = "link";
  link.shape = ShapeKind::kBox;
  link.radius_m = -1.0;
  options.colliders.frames = {link};
  EXPECT_TRUE(mentions(problemsWith(options), "frame_colliders[0].radius = -1")) << problemsWith(options);
  link.radius_m = 0.05;
  link.shape = ShapeKind::kSphere;
  link.size_m.setZero();
  options.colliders.frames = {link};
  EXPECT_TRUE(mentions(problemsWith(options), "frame_colliders[0].size[0] = 0")) << problemsWith(options);
  // A shape named beside every field (as a state file writes them) still loads.
  SceneOptions loaded;
  std::vector<std::string> errors;
  EXPECT_TRUE(loadSceneFile(writeFile(scratchDir("link"), "link.yaml",
                                      "frame_colliders: [{frame: l, shape: sphere, radius: 0.1, length: 0.2, "
                                      "size: [0.1, 0.1, 0.1]}]\n"),
                            &loaded, &errors))
      << (errors.empty() ? "" : errors.front());
}

TEST(BadSceneFile, AParameterOfTheWrongTypeSaysWhichTypeItCameAs) {
  // A parameter 10.0 reaches the reader as !!float "10": quoted alone it read as an integer.
  const std::string rows = refusalOf("rows: !!float 10\n");
  EXPECT_TRUE(mentions(rows, "rows = '10' (a floating-point number): expected an integer")) << rows;
  EXPECT_TRUE(mentions(refusalOf("rows: !!str 40\n"), "'40' (a string)"));
  EXPECT_TRUE(mentions(refusalOf("rows: forty\n"), "rows = 'forty': expected")) << "an untagged scene file's value stays as written";
}

TEST(BadSceneFile, AnExplicitTagThatDoesNotFitTheKeyIsRefused) {
  // Parameters reach the reader tagged with their XmlRpc type: `_name:=42` arrives as !!int 42.
  EXPECT_TRUE(mentions(refusalOf("name: !!int 42\n"), "name"));
  EXPECT_TRUE(mentions(refusalOf("rows: !!str 5\n"), "an integer"));
  EXPECT_TRUE(mentions(refusalOf("rows: !!float 5\n"), "an integer"));
  EXPECT_TRUE(mentions(refusalOf("wind_enabled: !!int 1\n"), "true or false"));
  EXPECT_TRUE(mentions(refusalOf("mass: !!str 0.5\n"), "a number"));
  // What fits is taken: an integer for a number, an integer particle index for a pin.
  SceneOptions options;
  std::vector<std::string> errors;
  const std::string path = writeFile(scratchDir("tags"), "fits.yaml",
                                     "name: !!str tagged\nmass: !!int 1\nrows: !!int 6\npins: [!!int 0, top_right]\n");
  ASSERT_TRUE(loadSceneFile(path, &options, &errors)) << (errors.empty() ? "" : errors.front());
  EXPECT_EQ(options.mass_kg, 1.0);
  EXPECT_EQ(options.pins.front(), "0");
}

TEST(BadSceneFile, AQuotedNumberOrBoolIsAStringAndRefusedWhereANumberOrBoolIsExpected) {
  // YAML's core schema makes a quoted scalar a string, as rosparam load does: "true" switched
  // self-collision on, and '12' made 12 rows.
  expectRefusalMentions("self_collision: \"true\"\n", "'true' (a string): expected true or false");
  expectRefusalMentions("mass: '0.5'\n", "'0.5' (a string): expected a number");
  expectRefusalMentions("rows: '12'\n", "'12' (a string): expected an integer");
  expectRefusalMentions("gravity: [0, 0, \"-9.81\"]\n", "its [2] = '-9.81' (a string) is not a number");
  // Where a string is expected, quoted or not is the same.
  SceneOptions options;
  std::vector<std::string> errors;
  const std::string path = writeFile(scratchDir("quoted"), "strings.yaml",
                                     "name: \"123\"\nmaterial: 'denim'\nsubsteps: \"auto\"\npins: [\"top_left\", '5']\n");
  ASSERT_TRUE(loadSceneFile(path, &options, &errors)) << (errors.empty() ? "" : errors.front());
  EXPECT_EQ(options.name, "123");
  EXPECT_EQ(options.pins.back(), "5");
}

TEST(BadSceneFile, AMissingTextureOrOneThatIsNotARegularFileIsRefused) {
  const std::string dir = scratchDir("texture");
  EXPECT_TRUE(mentions(refusal(writeFile(dir, "missing.yaml", "texture: no_such.png\n")), "no_such.png"));
  fs::create_directories(dir + "/folder.png");
  EXPECT_TRUE(mentions(refusal(writeFile(dir, "folder.yaml", "texture: folder.png\n")), "not a regular file"));
  ASSERT_EQ(mkfifo((dir + "/pipe.png").c_str(), 0600), 0);
  EXPECT_TRUE(mentions(refusal(writeFile(dir, "pipe.yaml", "texture: pipe.png\n")), "not a regular file"));
}

TEST(BadSceneFile, A512By512SceneLoadsAndBuildsAnd513IsRefused) {
  const std::string dir = scratchDir("large");
  SceneOptions options;
  std::vector<std::string> errors;
  ASSERT_TRUE(loadSceneFile(writeFile(dir, "large.yaml", "rows: 512\ncols: 512\n"), &options, &errors))
      << (errors.empty() ? "" : errors.front());
  const Simulation simulation(options);
  EXPECT_EQ(simulation.state().particleCount(), 512 * 512);
  EXPECT_TRUE(simulation.state().positions_m.allFinite());
  EXPECT_TRUE(mentions(refusalOf("rows: 513\ncols: 512\n"), "rows = 513"));
}

// ---- ranges the physics and the node can honour ----------------------------------------------------

TEST(BadOptions, ANearlyUnitNormalIsRefusedNamingItsLengthAndTheTolerance) {
  // An audit's: [0, 0.7071, 0.7071] (0.99999 long) was refused as "must be a unit vector", which gave no
  // hint that four digits are too few.
  SceneOptions options;
  options.colliders.planes.push_back(PlaneCollider{Eigen::Vector3d(0.0, 0.7071, 0.7071), 0.0});
  options.origin_m = Eigen::Vector3d(0.0, 0.0, 2.0);  // above the plane, whatever its tilt
  const std::string problems = problemsWith(options);
  EXPECT_TRUE(mentions(problems, "planes[0].normal")) << problems;
  EXPECT_TRUE(mentions(problems, "its length is 0.99999")) << problems;
  EXPECT_TRUE(mentions(problems, "1 within 1e-06")) << problems;
  options.colliders.planes.front().normal = Eigen::Vector3d(0.0, 0.70710678, 0.70710678);
  EXPECT_FALSE(mentions(problemsWith(options), "planes[0].normal")) << problemsWith(options);
}

TEST(BadOptions, APinMotionPeriodOf1eMinus300IsRefusedByItsPeakSpeed) {
  // The curtain's rail (0.15 m) at a period of 1e-300 s moved its pins at 9e298 m/s: the kinetic energy
  // on ~state was inf.
  SceneOptions options;
  options.pin_motion_amplitude_m = Eigen::Vector3d(0.15, 0.0, 0.0);
  options.pin_motion_period_s = 1e-300;
  const std::string problems = problemsWith(options);
  EXPECT_TRUE(mentions(problems, "pin_motion_period")) << problems;
  EXPECT_TRUE(mentions(problems, "at most 100 m/s")) << problems;
  // The shortest period the limit allows runs with finite energies.
  options.pin_motion_period_s = 0.15 * kTwoPi / OptionLimits::kMaxPinSpeed_m_per_s * 1.001;
  ASSERT_EQ(problemsWith(options), "");
  Simulation simulation(options);
  for (int frame = 0; frame < 10; ++frame) simulation.advanceFrame();
  EXPECT_TRUE(std::isfinite(simulation.energies().kinetic_J));
  EXPECT_TRUE(std::isfinite(simulation.energies().potential_J));
  // A fixed pin has no speed whatever its period.
  options.pin_motion_amplitude_m.setZero();
  options.pin_motion_period_s = 1e-300;
  EXPECT_EQ(problemsWith(options), "");
}

TEST(BadOptions, PinsTravellingToTheirHooksTooFastAreRefused) {
  SceneOptions options;
  options.pin_positions_m = {Eigen::Vector3d(-0.3, 0.0, 1.5), Eigen::Vector3d(0.3, 0.0, 1.5)};
  options.pin_travel_time_s = 1e-300;
  EXPECT_TRUE(mentions(problemsWith(options), "pin_travel_time")) << problemsWith(options);
  options.pin_travel_time_s = 1.0;  // the drape's was
  EXPECT_EQ(problemsWith(options), "");
}

TEST(BadOptions, ASphereSwingingFasterThanTheColliderSpeedLimitIsRefused) {
  SceneOptions options;
  SphereCollider sphere;
  sphere.oscillation_amplitude_m = Eigen::Vector3d(0.0, 0.75, 0.0);
  sphere.oscillation_period_s = 1e-9;
  options.colliders.spheres.push_back(sphere);
  EXPECT_TRUE(mentions(problemsWith(options), "spheres[0]")) << problemsWith(options);
  options.colliders.spheres[0].oscillation_period_s = 6.0;  // the ball's
  EXPECT_EQ(problemsWith(options), "");
}

TEST(BadOptions, AFrameRateTheNodeCannotTimeIsRefused) {
  // 1e-10 Hz aborted the node (a 1e10 s ros::Duration); the node times, publishes and diagnoses per frame.
  SceneOptions options;
  for (const double rate_hz : {1e-10, 0.5, 0.0, -1.0, 1001.0, std::nan("")}) {
    options.frame_rate_hz = rate_hz;
    const std::string problems = problemsWith(options);
    EXPECT_TRUE(mentions(problems, "frame_rate")) << rate_hz << ": " << problems;
    EXPECT_TRUE(mentions(problems, "[1, 1000]")) << problems;
  }
  options.frame_rate_hz = OptionLimits::kMinFrameRateHz;
  EXPECT_EQ(problemsWith(options), "");
}

TEST(BadOptions, AWindOver100MetresPerSecondInMagnitudeIsRefused) {
  // Each component within 100 m/s is not enough: (100, 100, 100) is 173 m/s.
  SceneOptions options;
  options.wind.velocity_m_per_s = Eigen::Vector3d(100.0, 100.0, 100.0);
  EXPECT_TRUE(mentions(problemsWith(options), "magnitude")) << problemsWith(options);
  options.wind.velocity_m_per_s = Eigen::Vector3d(0.0, 100.0, 0.0);
  EXPECT_EQ(problemsWith(options), "");
}

TEST(BadOptions, AGridOutsideItsLimitsIsRefusedAloneAtOnceWithoutResolvingPinsMaterialOrOutline) {
  // Validation resolved the pins before it knew the sides were in range: 100000 x 100000 with
  // bottom_right formed rows x cols in an int (signed overflow), 2 x 2e9 with top_edge allocated 2e9
  // indices (bad_alloc out of validation: std::terminate at the node's start-up, an exception out of
  // ~load_state), and a material with an outline allocated a rows x cols mask for its area.
  struct Grid {
    int rows;
    int cols;
    std::vector<std::string> pins;
  };
  SceneOptions options;
  options.has_material = true;
  ASSERT_TRUE(findMaterialPreset("cotton", &options.material));
  options.outline.shape = OutlineOptions::Shape::kCircle;
  options.outline.center_m = Eigen::Vector2d(0.5, 0.5);
  options.outline.radius_m = 0.5;
  // Well under the time one pass over a 1e10-particle grid (or one allocation of it) takes.
  constexpr double kQuickly_s = 1.0;
  for (const Grid& grid : {Grid{100000, 100000, {"bottom_right"}}, Grid{2, 2000000000, {"top_edge"}},
                           Grid{2000000000, 2, {"left_edge", "nonsense"}}, Grid{1, 5, {"nonsense"}}}) {
    options.rows = grid.rows;
    options.cols = grid.cols;
    options.pins = grid.pins;
    const auto start = std::chrono::steady_clock::now();
    std::vector<std::string> problems;
    ASSERT_NO_THROW(problems = validateSceneOptions(options)) << grid.rows << " x " << grid.cols;
    EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), kQuickly_s);
    // Only the sides: nothing that depends on the grid (pins, outline, the material's mass) is looked at.
    std::vector<std::string> expected;
    if (grid.rows > OptionLimits::kMaxGridSide || grid.rows < OptionLimits::kMinGridSide) {
      expected.push_back("rows = " + std::to_string(grid.rows) + ": must be in [2, 512]");
    }
    if (grid.cols > OptionLimits::kMaxGridSide || grid.cols < OptionLimits::kMinGridSide) {
      expected.push_back("cols = " + std::to_string(grid.cols) + ": must be in [2, 512]");
    }
    EXPECT_EQ(problems, expected) << grid.rows << " x " << grid.cols;
  }
  // What resolves pins on its own refuses such a grid too, and forms its indices in 64 bits.
  std::string error;
  EXPECT_TRUE(resolvePins({"bottom_right"}, 100000, 100000, &error).empty());
  EXPECT_TRUE(mentions(error, "100000 x 100000 grid")) << error;
  error.clear();
  EXPECT_EQ(resolvePins({"bottom_right"}, 512, 512, &error), std::vector<int>{512 * 512 - 1});
  EXPECT_EQ(error, "");
  // A retune or a restore derives a material's constants before it compares grids: nothing is derived
  // (nor allocated) for a grid outside the limits, and it is refused by its sides.
  options.rows = options.cols = 100000;
  EXPECT_EQ(resolveMaterial(options).mass_kg, options.mass_kg);
  SceneOptions disc = options;
  disc.rows = disc.cols = 11;
  disc.pins = {"60"};  // the centre
  ASSERT_EQ(problemsWith(disc), "");
  Simulation simulation(disc);
  options.pins = disc.pins;
  ASSERT_FALSE(simulation.retune(options, &error));
  EXPECT_TRUE(mentions(error, "rows, cols")) << error;
}

TEST(BadOptions, ANegativeSubstepsCountSaysThatZeroMeansAuto) {
  SceneOptions options;
  options.substeps = -1;
  EXPECT_EQ(validateSceneOptions(options), std::vector<std::string>{"substeps = -1: must be 0 (auto) or in [1, 10000]"});
  options.substeps = SceneOptions::kAutoSubsteps;
  EXPECT_EQ(problemsWith(options), "");
}

TEST(BadOptions, ARetuneThatWouldChangeTheGridNamesWhatChanged) {
  // It named "rows, cols, size, pose, pins and mass" whatever changed, and an outline is none of those.
  SceneOptions options;
  Simulation simulation(options);
  SceneOptions tuned = options;
  tuned.outline.shape = OutlineOptions::Shape::kCircle;
  tuned.outline.center_m = Eigen::Vector2d(0.5, 0.5);
  tuned.outline.radius_m = 0.75;  // keeps the top corners, where the pins are
  ASSERT_EQ(problemsWith(tuned), "");
  std::string error;
  EXPECT_FALSE(simulation.retune(tuned, &error));
  EXPECT_EQ(error, "outline cannot change while running: load a scene instead");
  tuned = options;
  tuned.pin_travel_time_s = 1.0;
  EXPECT_FALSE(simulation.retune(tuned, &error));
  EXPECT_EQ(error, "pin_positions, pin_travel_time cannot change while running: load a scene instead");
}

TEST(BadOptions, NonFiniteValuesAreRefusedByName) {
  SceneOptions options;
  options.mass_kg = std::nan("");
  options.springs[0].stiffness_N_per_m = INFINITY;
  options.gravity_m_per_s2.x() = -INFINITY;
  const std::string problems = problemsWith(options);
  for (const char* field : {"mass", "structural_stiffness", "gravity"}) {
    EXPECT_TRUE(mentions(problems, field)) << problems;
  }
}

}  // namespace
}  // namespace cloth_sim::core
