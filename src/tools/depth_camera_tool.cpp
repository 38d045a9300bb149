// depth_camera_tool: the depth renderer on its own, without ROS. Settles a scene, then
//   - times one camera image (median and minimum of --repeat renders, depth only and depth + colour), and
//   - with --out DIR, writes what the camera sees (depth.f32, rgb.u8, mask.u8, camera.json) for
//     scripts/camera_picture.py, which draws the depth image and its point cloud (doc/images/camera_drape.png).
//
//   depth_camera_tool [--scene drape] [--rows 64] [--cols 64] [--frames 150] [--repeat 50]
//                     [--width 640] [--height 480] [--eye x,y,z] [--target x,y,z] [--out DIR]
// The default camera stands 2 m from the drape scene's cloth, to its front right, level with its middle.
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
#include <iostream>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

namespace {

using cloth_sim::bench::parseDouble;
using cloth_sim::bench::parseInt;
namespace core = cloth_sim::core;

struct ToolOptions {
  std::string scene = "drape";
  int rows = 0;  // 0: the scene's
  int cols = 0;
  int frames = 150;  // 3 s at 50 Hz: the drape scene's corners reach their hooks after 1 s
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

bool parseArguments(int argc, char** argv, ToolOptions* options, std::string* error) {
  options->camera.name = "tool";
  options->camera.frame = "tool_optical";
  for (int i = 1; i < argc; ++i) {
    const std::string flag = argv[i];
    if (i + 1 >= argc) {
      *error = flag + " needs a value";
      return false;
    }
    const std::string value = argv[++i];
    bool ok = true;
    const auto integer = [&](int* target) {
      const auto parsed = parseInt(value);
      ok = parsed.has_value();
      if (ok) *target = *parsed;
    };
    if (flag == "--scene") {
      options->scene = value;
    } else if (flag == "--rows") {
      integer(&options->rows);
    } else if (flag == "--cols") {
      integer(&options->cols);
    } else if (flag == "--frames") {
      integer(&options->frames);
    } else if (flag == "--repeat") {
      integer(&options->repeat);
    } else if (flag == "--width") {
      integer(&options->camera.width);
    } else if (flag == "--height") {
      integer(&options->camera.height);
    } else if (flag == "--eye") {
      ok = parseVector(value, &options->eye_m);
    } else if (flag == "--target") {
      ok = parseVector(value, &options->target_m);
    } else if (flag == "--out") {
      options->out_dir = value;
    } else {
      *error = "unknown option " + flag;
      return false;
    }
    if (!ok) {
      *error = flag + " " + value + ": not a valid value";
      return false;
    }
  }
  // The default intrinsics are VGA's; another size keeps the field of view and the centre.
  const double scale = options->camera.width / 640.0;
  options->camera.fx_px = options->camera.fy_px = 525.0 * scale;
  options->camera.cx_px = 0.5 * (options->camera.width - 1);
  options->camera.cy_px = 0.5 * (options->camera.height - 1);
  if (options->repeat < 1 || options->frames < 0) {
    *error = "--repeat must be >= 1 and --frames >= 0";
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
  if (!parseArguments(argc, argv, &options, &error)) {
    std::cerr << "depth_camera_tool: " << error << "\n";
    return 2;
  }
  core::SceneOptions scene;
  std::vector<std::string> errors;
  if (!core::loadSceneFile(core::resolveScenePath(options.scene, CLOTH_SIM_SCENES_DIR), &scene, &errors)) {
    std::cerr << "depth_camera_tool: " << errors.front() << "\n";
    return 2;
  }
  if (options.rows > 0) scene.rows = options.rows;
  if (options.cols > 0) scene.cols = options.cols;
  scene.cameras = {options.camera};
  const std::vector<std::string> problems = core::validateSceneOptions(scene);
  if (!problems.empty()) {
    std::cerr << "depth_camera_tool: " << problems.front() << "\n";
    return 2;
  }
  core::Simulation simulation(scene);
  Eigen::Matrix3Xf colors;
  if (!core::sceneVertexColors(scene.texture, simulation.grid().uv, &colors, &error)) {
    std::cerr << "depth_camera_tool: " << error << "\n";
    return 2;
  }
  simulation.setVertexColors(colors);
  for (int f = 0; f < options.frames; ++f) simulation.advanceFrame();

  const core::PinholeCamera camera = core::PinholeCamera::from(options.camera);
  const Eigen::Isometry3d pose = core::opticalLookAt(options.eye_m, options.target_m, Eigen::Vector3d::UnitZ());
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
  std::printf("{\"scene\": \"%s\", \"rows\": %d, \"cols\": %d, \"triangles\": %zu, \"width\": %d, \"height\": %d, "
              "\"cloth_pixels\": %ld, \"repeat\": %d, \"depth_ms\": %.3f, \"depth_min_ms\": %.3f, "
              "\"depth_and_color_ms\": %.3f, \"depth_and_color_min_ms\": %.3f}\n",
              scene.name.c_str(), scene.rows, scene.cols, simulation.grid().triangles.size() / 3, camera.width,
              camera.height, seen, options.repeat, depth_ms, depth_min_ms, color_ms, color_min_ms);

  if (!options.out_dir.empty()) {
    std::ofstream meta(options.out_dir + "/camera.json");
    meta << "{\"width\": " << camera.width << ", \"height\": " << camera.height << ", \"fx\": " << camera.fx_px
         << ", \"fy\": " << camera.fy_px << ", \"cx\": " << camera.cx_px << ", \"cy\": " << camera.cy_px
         << ", \"scene\": \"" << scene.name << "\", \"rows\": " << scene.rows << ", \"cols\": " << scene.cols
         << ", \"time_s\": " << simulation.state().time_s << ", \"world_from_optical\": [";
    for (int r = 0; r < 3; ++r) {
      meta << (r > 0 ? ", " : "") << "[" << pose.matrix()(r, 0) << ", " << pose.matrix()(r, 1) << ", "
           << pose.matrix()(r, 2) << ", " << pose.matrix()(r, 3) << "]";
    }
    meta << "]}\n";
    if (!meta || !writeRaw(options.out_dir + "/depth.f32", frame.depth_m) ||
        !writeRaw(options.out_dir + "/rgb.u8", frame.rgb) || !writeRaw(options.out_dir + "/mask.u8", frame.mask)) {
      std::cerr << "depth_camera_tool: cannot write into " << options.out_dir << "\n";
      return 1;
    }
  }
  return 0;
}
