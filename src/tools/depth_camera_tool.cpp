// depth_camera_tool: the depth renderer on its own, without ROS. Settles a scene, then
//   - times one camera image (median and minimum of --repeat renders, depth only and depth + colour), and
//   - with --out DIR, writes what the camera sees (depth.f32, rgb.u8, mask.u8, camera.json) for
//     scripts/camera_picture.py, which draws the depth image and its point cloud (doc/images/camera_drape.png).
//
//   depth_camera_tool [--scene drape] [--rows 64] [--cols 64] [--frames 300] [--repeat 50]
//                     [--width 640] [--height 480] [--eye x,y,z] [--target x,y,z] [--out DIR]
// The default camera stands 2 m from the drape scene's cloth, to its front right, level with its middle.
// Image up is world +z, except for a view along z (a top view), where it is world +y. A bad option (eye equal
// to target, --out not a writable folder) exits 2 before the scene is settled; --help prints the usage, exit 0.
#include "cloth_sim/core/depth_render.h"
#include "cloth_sim/core/simulation.h"
#include "cloth_sim/io/scene_file.h"
#include "cloth_sim/io/texture.h"
#include "bench_common.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <functional>
#include <optional>
#include <iostream>
#include <map>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include <sys/stat.h>
#include <unistd.h>

namespace {

using cloth_sim::bench::jsonQuoted;
using cloth_sim::bench::kExitOk;
using cloth_sim::bench::kExitRunFailed;
using cloth_sim::bench::kExitUsage;
using cloth_sim::bench::parseDouble;
using cloth_sim::bench::parseInt;
namespace core = cloth_sim::core;

/// The most --repeat: renders of 1 to 7 ms each, twice over (depth, then depth and colour), so 10,000 already
/// take minutes; a larger count only looks like a hang.
constexpr int kMaxRepeat = 10000;
/// The most --frames before the render: a million frames are 5.5 hours of a 50 Hz scene.
constexpr int kMaxSettleFrames = 1000000;
/// Eye and target closer than this, m, give no view direction.
constexpr double kMinViewDistance_m = 1e-6;
/// |sin| of the angle between the view and world z below which z cannot be the image's up (their cross product
/// vanishes and the look-at has no right axis): such a view takes world y as up instead.
constexpr double kMinUpSine = 1e-6;
constexpr const char* kUsage =
    "usage: depth_camera_tool [--scene drape] [--rows N] [--cols N] [--frames 300] [--repeat 50]\n"
    "                         [--width 640] [--height 480] [--eye x,y,z] [--target x,y,z] [--out DIR]\n";

struct ToolOptions {
  std::string scene = "drape";
  std::optional<int> rows;  // none: the scene's
  std::optional<int> cols;
  int frames = 300;  // 6 s at 50 Hz: the drape scene's corners reach their hooks at 4 s
  int repeat = 50;
  core::CameraOptions camera;
  Eigen::Vector3d eye_m{1.0, -1.75, 1.2};
  Eigen::Vector3d target_m{0.0, 0.0, 1.0};
  std::string out_dir;
};

bool parseVector(const std::string& text, Eigen::Vector3d* vector) {
  std::stringstream in(text);
  std::string part;
  for (int k = 0; k < 3; ++k) {
    if (!std::getline(in, part, ',')) return false;
    const auto value = parseDouble(part);
    if (!value) return false;
    (*vector)[k] = *value;
  }
  return !std::getline(in, part, ',');
}

/// Whether `path` is a folder this process may write into: checked before the scene is settled, so a typo
/// does not cost the whole run.
bool isWritableFolder(const std::string& path) {
  struct stat info {};
  return ::stat(path.c_str(), &info) == 0 && S_ISDIR(info.st_mode) && ::access(path.c_str(), W_OK | X_OK) == 0;
}

/// Image up for a camera looking along `forward`: world z, unless the view runs along z, where z has no
/// component across the view; then world y, so a top view looks down with +y up in the image.
Eigen::Vector3d upAxisFor(const Eigen::Vector3d& forward) {
  const Eigen::Vector3d z = Eigen::Vector3d::UnitZ();
  return forward.normalized().cross(z).norm() < kMinUpSine ? Eigen::Vector3d::UnitY() : z;
}

/// False with *error set; *help when --help asked for the usage (then nothing else is read).
bool parseArguments(int argc, char** argv, ToolOptions* options, bool* help, std::string* error) {
  options->camera.name = "tool";
  options->camera.frame = "tool_optical";
  *help = false;
  // Every option that takes a value, with what reads it: "" when the value reads, else why not.
  const auto integer = [](int* target) {
    return [target](const std::string& value) -> std::string {
      const auto parsed = parseInt(value);
      if (!parsed) return "not a valid value";
      *target = *parsed;
      return "";
    };
  };
  // A grid side the scene's limits allow; 0 or less was once ignored silently (the scene's own size ran).
  const auto side = [](std::optional<int>* target) {
    return [target](const std::string& value) -> std::string {
      const auto parsed = parseInt(value);
      if (!parsed || *parsed < core::OptionLimits::kMinGridSide || *parsed > core::OptionLimits::kMaxGridSide) {
        return "takes a whole number in [" + std::to_string(core::OptionLimits::kMinGridSide) + ", " +
               std::to_string(core::OptionLimits::kMaxGridSide) + "]";
      }
      *target = *parsed;
      return "";
    };
  };
  const auto vector = [](Eigen::Vector3d* target) {
    return [target](const std::string& value) -> std::string {
      return parseVector(value, target) ? "" : "not a valid value";
    };
  };
  const auto text = [](std::string* target) {
    return [target](const std::string& value) -> std::string {
      *target = value;
      return "";
    };
  };
  const std::map<std::string, std::function<std::string(const std::string&)>> setters = {
      {"--scene", text(&options->scene)},           {"--rows", side(&options->rows)},
      {"--cols", side(&options->cols)},             {"--frames", integer(&options->frames)},
      {"--repeat", integer(&options->repeat)},      {"--width", integer(&options->camera.width)},
      {"--height", integer(&options->camera.height)}, {"--eye", vector(&options->eye_m)},
      {"--target", vector(&options->target_m)},     {"--out", text(&options->out_dir)}};
  std::map<std::string, std::string> typed;  // each option's value as typed, for the messages below
  for (int i = 1; i < argc; ++i) {
    const std::string flag = argv[i];
    if (flag == "--help" || flag == "-h") {
      *help = true;
      return true;
    }
    const auto setter = setters.find(flag);
    if (setter == setters.end()) {
      *error = "unknown option " + flag;
      return false;
    }
    if (i + 1 >= argc) {
      *error = flag + " needs a value";
      return false;
    }
    const std::string value = argv[++i];
    const std::string problem = setter->second(value);
    if (!problem.empty()) {
      *error = flag + " " + value + ": " + problem;
      return false;
    }
    typed[flag] = value;
  }
  // Named as the user typed them (the scene's validation would name cameras[0].width).
  for (const auto& [flag, pixels] : {std::pair{"--width", options->camera.width}, std::pair{"--height", options->camera.height}}) {
    if (pixels < 1 || pixels > core::CameraLimits::kMaxImageSide) {
      *error = std::string(flag) + " " + std::to_string(pixels) + ": takes a whole number of pixels in [1, " +
               std::to_string(core::CameraLimits::kMaxImageSide) + "]";
      return false;
    }
  }
  // The default intrinsics are VGA's; another size keeps the field of view and the centre.
  const double scale = options->camera.width / 640.0;
  options->camera.fx_px = options->camera.fy_px = 525.0 * scale;
  options->camera.cx_px = 0.5 * (options->camera.width - 1);
  options->camera.cy_px = 0.5 * (options->camera.height - 1);
  if (options->repeat < 1 || options->repeat > kMaxRepeat) {
    *error = "--repeat " + std::to_string(options->repeat) + ": takes a whole number in [1, " +
             std::to_string(kMaxRepeat) + "]";
    return false;
  }
  if (options->frames < 0 || options->frames > kMaxSettleFrames) {
    *error = "--frames " + std::to_string(options->frames) + ": takes a whole number in [0, " +
             std::to_string(kMaxSettleFrames) + "]";
    return false;
  }
  // Within the scene's coordinate limit: from 1e160 m away the view direction's length overflows, and the
  // look-at rotation came out zero or NaN (an empty picture, and "nan" in camera.json, exit 0).
  for (const auto& [flag, point] : {std::pair{"--eye", &options->eye_m}, std::pair{"--target", &options->target_m}}) {
    if (point->cwiseAbs().maxCoeff() > core::OptionLimits::kMaxCoordinate_m) {
      std::ostringstream out;
      out << flag << " " << typed[flag] << ": each coordinate within +-" << core::OptionLimits::kMaxCoordinate_m
          << " m (the scene's limit)";
      *error = out.str();
      return false;
    }
  }
  if ((options->target_m - options->eye_m).norm() < kMinViewDistance_m) {
    *error = "--eye and --target are the same point: the camera has no direction to look in";
    return false;
  }
  if (!options->out_dir.empty() && !isWritableFolder(options->out_dir)) {
    *error = "--out " + options->out_dir + ": not a folder this user can write into";
    return false;
  }
  return true;
}

double medianOf(std::vector<double> values) {
  std::sort(values.begin(), values.end());
  return values[values.size() / 2];
}

template <typename T>
bool writeRaw(const std::string& path, const std::vector<T>& values) {
  std::ofstream out(path, std::ios::binary);
  out.write(reinterpret_cast<const char*>(values.data()), static_cast<std::streamsize>(values.size() * sizeof(T)));
  return static_cast<bool>(out);
}

}  // namespace

int main(int argc, char** argv) {
  ToolOptions options;
  std::string error;
  bool help = false;
  if (!parseArguments(argc, argv, &options, &help, &error)) {
    std::cerr << "depth_camera_tool: " << error << "\n" << kUsage;
    return kExitUsage;
  }
  if (help) {
    std::cout << kUsage;
    return kExitOk;
  }
  core::SceneOptions scene;
  std::vector<std::string> errors;
  if (!core::loadSceneFile(core::resolveScenePath(options.scene, CLOTH_SIM_SCENES_DIR), &scene, &errors)) {
    std::cerr << "depth_camera_tool: " << errors.front() << "\n";
    return kExitUsage;
  }
  if (options.rows) scene.rows = *options.rows;
  if (options.cols) scene.cols = *options.cols;
  scene.cameras = {options.camera};
  const std::vector<std::string> problems = core::validateSceneOptions(scene);
  if (!problems.empty()) {
    std::cerr << "depth_camera_tool: " << problems.front() << "\n";
    return kExitUsage;
  }
  core::Simulation simulation(scene);
  Eigen::Matrix3Xf colors;
  if (!core::sceneVertexColors(scene.texture, simulation.grid().uv, &colors, &error)) {
    std::cerr << "depth_camera_tool: " << error << "\n";
    return kExitUsage;
  }
  simulation.setVertexColors(colors);
  for (int f = 0; f < options.frames; ++f) simulation.advanceFrame();

  const core::PinholeCamera camera = core::PinholeCamera::from(options.camera);
  const Eigen::Isometry3d pose =
      core::opticalLookAt(options.eye_m, options.target_m, upAxisFor(options.target_m - options.eye_m));
  core::RenderScene view;
  view.positions_m = &simulation.state().positions_m;
  view.triangles = &simulation.grid().triangles;
  view.colors = &simulation.vertexColors();
  view.colliders = &simulation.options().colliders;
  view.time_s = simulation.state().time_s;
  view.collider_inset_m = core::colliderInset_m(simulation.options().contact);
  core::DepthRenderer renderer;
  core::DepthFrame frame;
  const auto time = [&](bool with_color) {
    std::vector<double> costs_ms;
    for (int r = 0; r < options.repeat; ++r) {
      const auto start = std::chrono::steady_clock::now();
      renderer.render(camera, pose, view, with_color, &frame);
      costs_ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count());
    }
    // The median, and the minimum: on a shared machine the fastest render is the best estimate of the
    // cost on a core of its own.
    return std::make_pair(medianOf(costs_ms), *std::min_element(costs_ms.begin(), costs_ms.end()));
  };
  const auto [depth_ms, depth_min_ms] = time(false);
  const auto [color_ms, color_min_ms] = time(true);
  const long seen = std::count_if(frame.mask.begin(), frame.mask.end(), [](std::uint8_t m) { return m != 0; });
  std::printf("{\"scene\": %s, \"rows\": %d, \"cols\": %d, \"triangles\": %zu, \"width\": %d, \"height\": %d, "
              "\"cloth_pixels\": %ld, \"repeat\": %d, \"depth_ms\": %.3f, \"depth_min_ms\": %.3f, "
              "\"depth_and_color_ms\": %.3f, \"depth_and_color_min_ms\": %.3f}\n",
              jsonQuoted(scene.name).c_str(), scene.rows, scene.cols, simulation.grid().triangles.size() / 3,
              camera.width, camera.height, seen, options.repeat, depth_ms, depth_min_ms, color_ms, color_min_ms);

  if (!options.out_dir.empty()) {
    std::ofstream meta(options.out_dir + "/camera.json");
    meta << "{\"width\": " << camera.width << ", \"height\": " << camera.height << ", \"fx\": " << camera.fx_px
         << ", \"fy\": " << camera.fy_px << ", \"cx\": " << camera.cx_px << ", \"cy\": " << camera.cy_px
         << ", \"scene\": " << jsonQuoted(scene.name) << ", \"rows\": " << scene.rows << ", \"cols\": " << scene.cols
         << ", \"time_s\": " << simulation.state().time_s << ", \"world_from_optical\": [";
    for (int r = 0; r < 3; ++r) {
      meta << (r > 0 ? ", " : "") << "[" << pose.matrix()(r, 0) << ", " << pose.matrix()(r, 1) << ", "
           << pose.matrix()(r, 2) << ", " << pose.matrix()(r, 3) << "]";
    }
    meta << "]}\n";
    if (!meta || !writeRaw(options.out_dir + "/depth.f32", frame.depth_m) ||
        !writeRaw(options.out_dir + "/rgb.u8", frame.rgb) || !writeRaw(options.out_dir + "/mask.u8", frame.mask)) {
      std::cerr << "depth_camera_tool: cannot write into " << options.out_dir << "\n";
      return kExitRunFailed;
    }
  }
  return kExitOk;
}
