#include "mode_validate.h"

#include "bench_common.h"

#include "cloth_sim/core/constants.h"
#include "cloth_sim/core/material.h"
#include "cloth_sim/core/simulation.h"
#include "cloth_sim/core/textile_tests.h"

#include <chrono>
#include <cmath>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

namespace cloth_sim::bench {

namespace {

namespace core = cloth_sim::core;
using Clock = std::chrono::steady_clock;

constexpr const char* kValidateFlag = "--validate";
constexpr const char* kUsage = R"(usage: cloth_bench --validate TEST [options]
Runs one textile test of doc/VALIDATION.md and prints one JSON line on stdout (make validate runs them all).

  TEST                   cantilever (ASTM D1388 strip against the heavy elastica), drape (the `drape` scene:
                         1 m square hung by two corners 0.6 m apart), hanging (a sheet hung by its top edge:
                         top strain against rho g H / E) or cusick (BS 5058: a 30 cm disc on an 18 cm
                         support: drape coefficient and folds)
  --material NAME        a preset (cotton, denim, wool, polyester, silk; default cotton)
  --bend-model MODEL     springs or curvature (default curvature)
  --compression-model M  drape: linear or buckling (default linear)
  --cols N               cantilever: particles along the strip's free length (default 21)
  --side N               drape, hanging, cusick: particles per side (default 20)
  --seconds S            drape, cusick: simulated time (default 8)
  --set KEY=VALUE        drape: a key of the `drape` scene, after the options above (repeatable), e.g.
                         --set pin_travel_time=3.5 to lower the corners to the hooks over 3.5 s
  --positions            drape, cusick: also print the final particle positions (and cusick its triangles)
  --scenes-dir DIR       where built-in scenes live (default: the build's config/scenes)
  --help                 this text
)";

/// Frames the cantilever may take to settle (it takes under 20 with the curvature term, a few hundred
/// with bend springs).
constexpr int kCantileverMaxFrames = 3000;
/// The hanging sheet: one-second implicit steps bring its stretch to rest in a few frames.
constexpr int kHangingFrames = 30;
constexpr double kDefaultDrapeSeconds = 8.0;
constexpr double kRadToDeg = 180.0 / core::kPi;

struct ValidateOptions {
  std::string test;
  std::string material = "cotton";
  core::BendModel bend_model = core::BendModel::kCurvature;
  core::CompressionModel compression_model = core::CompressionModel::kLinear;
  int cols = 21;
  int side = 20;
  double seconds = kDefaultDrapeSeconds;
  bool positions = false;
  bool help = false;
  std::string scenes_dir;
  /// --set KEY=VALUE: drape scene keys overlaid after the named options (the others build their scenes in code).
  std::vector<SceneOverride> settings;
};

double msSince(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

std::string number(double value) {
  if (!std::isfinite(value)) return "null";
  std::ostringstream out;
  out.precision(9);
  out << value;
  return out.str();
}

int cantilever(const ValidateOptions& options, const core::MaterialOptions& material) {
  const double weight_N_per_m2 = material.areal_density_kg_per_m2 * 9.81;
  const double overhang_m =
      core::overhangForChordAngle(material.bending_rigidity_N_m, weight_N_per_m2, core::kCantileverInclineAngle_rad);
  const core::ElasticaSolution exact =
      core::solveHeavyCantilever(material.bending_rigidity_N_m, weight_N_per_m2, overhang_m);
  const core::SceneOptions scene = core::cantileverScene(material, options.bend_model, overhang_m, options.cols);
  std::ostringstream out;
  out << "{\"test\": \"cantilever\", \"material\": \"" << material.preset << "\", \"bend_model\": \""
      << core::bendModelName(options.bend_model) << "\", \"cols\": " << options.cols << ", \"rows\": " << scene.rows
      << ", \"overhang_m\": " << number(overhang_m) << ", \"exact_drop_m\": " << number(exact.tip_drop_m)
      << ", \"exact_reach_m\": " << number(exact.tip_reach_m);
  const std::vector<std::string> problems = core::validateSceneOptions(scene);
  if (!problems.empty()) {  // bend springs too stiff in tension at this spacing: part of the result
    out << ", \"refused\": \"" << problems.front() << "\"}";
    std::cout << out.str() << std::endl;
    return kExitOk;
  }
  const Clock::time_point start = Clock::now();
  const core::CantileverMeasurement measured = core::runCantilever(scene, kCantileverMaxFrames);
  const double elapsed_ms = msSince(start);
  // ASTM D1388 reads the bending length off the overhang at the 41.5 degree incline as c = l / 2 (Peirce's
  // approximation of the elastica): from the angle the strip's chord actually makes, Peirce's own formula
  // c = l (cos(theta / 2) / (8 tan theta))^(1/3), and G = w c^3 beside the B set.
  const double angle = std::atan2(measured.tip_drop_m, measured.tip_reach_m);
  const double standard_c = overhang_m / 2.0;
  const double peirce_c = overhang_m * std::cbrt(std::cos(angle / 2.0) / (8.0 * std::tan(angle)));
  out << ", \"drop_m\": " << number(measured.tip_drop_m) << ", \"reach_m\": " << number(measured.tip_reach_m)
      << ", \"drop_error\": " << number(measured.tip_drop_m / exact.tip_drop_m - 1.0)
      << ", \"chord_angle_deg\": " << number(angle * kRadToDeg) << ", \"standard_rigidity_N_m\": "
      << number(weight_N_per_m2 * standard_c * standard_c * standard_c) << ", \"peirce_rigidity_N_m\": "
      << number(weight_N_per_m2 * peirce_c * peirce_c * peirce_c)
      << ", \"set_rigidity_N_m\": " << number(material.bending_rigidity_N_m) << ", \"frames\": " << measured.frames
      << ", \"settled\": " << (measured.settled ? "true" : "false") << ", \"ms\": " << number(elapsed_ms)
      << ", \"exact_profile\": [";
  for (std::size_t i = 0; i < exact.profile_m.size(); i += exact.profile_m.size() / 50) {
    out << (i == 0 ? "" : ", ") << "[" << number(exact.profile_m[i].x()) << ", " << number(exact.profile_m[i].y())
        << "]";
  }
  out << "], \"profile\": [";
  for (std::size_t i = 0; i < measured.profile_m.size(); ++i) {
    out << (i == 0 ? "" : ", ") << "[" << number(measured.profile_m[i].x()) << ", " << number(measured.profile_m[i].y())
        << "]";
  }
  out << "]}";
  std::cout << out.str() << std::endl;
  return measured.settled ? kExitOk : kExitRunFailed;
}

/// The particles' positions as a JSON member (for pictures).
void printPositions(const Eigen::Matrix3Xd& positions_m, std::ostringstream& out) {
  out << ", \"positions\": [";
  for (Eigen::Index p = 0; p < positions_m.cols(); ++p) {
    out << (p == 0 ? "" : ", ") << "[" << number(positions_m(0, p)) << ", " << number(positions_m(1, p)) << ", "
        << number(positions_m(2, p)) << "]";
  }
  out << "]";
}

/// The drape: sag of the top edge's middle below the hooks, and the depth of the folds (the cloth's span
/// across the hooks' line, y), after `seconds`.
int drape(const ValidateOptions& options) {
  core::SceneOptions scene;
  std::vector<std::string> errors;
  std::vector<SceneOverride> overrides{{"--material", "material", options.material},
                                       {"--bend-model", "bend_model", core::bendModelName(options.bend_model)},
                                       {"--compression-model", "compression_model",
                                        core::compressionModelName(options.compression_model)},
                                       {"--side", "rows", std::to_string(options.side)},
                                       {"--side", "cols", std::to_string(options.side)}};
  overrides.insert(overrides.end(), options.settings.begin(), options.settings.end());
  if (loadSceneWithOverrides("drape", options.scenes_dir, overrides, &scene, &errors) && validateInto(scene, &errors) &&
      scene.pin_positions_m.empty()) {
    // The sag is measured from the first hook's height.
    errors.push_back("--set: the drape needs its hooks (pin_positions)");
  }
  if (!errors.empty()) {
    for (const std::string& e : errors) std::cerr << "cloth_bench: " << e << "\n";
    return kExitUsage;
  }
  core::Simulation simulation(scene);
  const int frames = static_cast<int>(std::lround(options.seconds * scene.frame_rate_hz));
  const Clock::time_point start = Clock::now();
  Eigen::Matrix3Xd second_before = simulation.state().positions_m;
  int unstable = 0;
  for (int frame = 0; frame < frames; ++frame) {
    if (frame == frames - static_cast<int>(scene.frame_rate_hz)) second_before = simulation.state().positions_m;
    if (!simulation.advanceFrame().stable) ++unstable;
  }
  const double elapsed_ms = msSince(start);
  const Eigen::Matrix3Xd& end = simulation.state().positions_m;
  const core::ClothGrid& grid = simulation.grid();
  const double hook_z = scene.pin_positions_m.front().z();
  // The top edge's middle: the middle particle, or the mean of the two middle ones of an even side.
  const double top_middle_z =
      0.5 * (end(2, grid.index(0, (grid.cols - 1) / 2)) + end(2, grid.index(0, grid.cols / 2)));
  std::ostringstream out;
  out << "{\"test\": \"drape\", \"material\": \"" << options.material << "\", \"bend_model\": \""
      << core::bendModelName(options.bend_model) << "\", \"compression_model\": \""
      << core::compressionModelName(options.compression_model) << "\", \"side\": " << options.side
      << ", \"seconds\": " << number(options.seconds) << ", \"settings\": {";
  // The --set keys as typed (in order; a key set twice shows twice, the last one counted), so that a line
  // says which run it is.
  for (std::size_t k = 0; k < options.settings.size(); ++k) {
    out << (k == 0 ? "" : ", ") << jsonQuoted(options.settings[k].key) << ": " << jsonQuoted(options.settings[k].value);
  }
  out << "}, \"sag_m\": " << number(hook_z - top_middle_z)
      << ", \"fold_depth_m\": " << number(end.row(1).maxCoeff() - end.row(1).minCoeff())
      << ", \"lowest_m\": " << number(hook_z - end.row(2).minCoeff())
      << ", \"last_second_motion_m\": " << number((end - second_before).colwise().norm().maxCoeff())
      << ", \"unstable_frames\": " << unstable << ", \"ms_per_frame\": " << number(elapsed_ms / frames);
  if (options.positions) printPositions(end, out);
  out << "}";
  std::cout << out.str() << std::endl;
  return kExitOk;
}

/// A 1 m square hung by its top edge: the strain of the top row's vertical springs at the middle against
/// statics, rho g H / E (the weight of the sheet below per width, over its stretch modulus).
int hanging(const ValidateOptions& options, const core::MaterialOptions& material) {
  core::SceneOptions scene;
  scene.name = "hanging sheet";
  scene.rows = options.side;
  scene.cols = options.side;
  scene.pins = {"top_edge"};
  scene.has_material = true;
  scene.material = material;
  scene.bend_model = options.bend_model;
  scene.frame_rate_hz = core::OptionLimits::kMinFrameRateHz;
  scene.sleep_speed_m_per_s = 0.0;  // the statics are the physics' rest, not where the sheet stopped being computed
  std::vector<std::string> errors;
  if (!validateInto(scene, &errors)) {
    for (const std::string& e : errors) std::cerr << "cloth_bench: " << e << "\n";
    return kExitUsage;
  }
  core::Simulation simulation(scene);
  for (int frame = 0; frame < kHangingFrames; ++frame) simulation.advanceFrame();
  const core::ClothGrid& grid = simulation.grid();
  const int middle = grid.cols / 2;
  const double spacing_m = scene.height_m / (grid.rows - 1);
  const double strain = (simulation.state().positions_m.col(grid.index(1, middle)) -
                         simulation.state().positions_m.col(grid.index(0, middle)))
                            .norm() / spacing_m - 1.0;
  const double expected = material.areal_density_kg_per_m2 * 9.81 * scene.height_m / material.stretch_modulus_N_per_m;
  std::cout << "{\"test\": \"hanging\", \"material\": \"" << material.preset << "\", \"side\": " << options.side
            << ", \"top_strain\": " << number(strain) << ", \"expected\": " << number(expected)
            << ", \"error\": " << number(strain / expected - 1.0) << "}" << std::endl;
  return kExitOk;
}

/// The Cusick drape test: drape coefficient and folds (BS 5058).
int cusick(const ValidateOptions& options, const core::MaterialOptions& material) {
  const core::SceneOptions scene = core::cusickScene(material, options.bend_model, options.side);
  std::vector<std::string> errors;
  if (!validateInto(scene, &errors)) {
    for (const std::string& e : errors) std::cerr << "cloth_bench: " << e << "\n";
    return kExitUsage;
  }
  const Clock::time_point start = Clock::now();
  const core::CusickMeasurement measured = core::runCusick(scene, options.seconds);
  const double elapsed_ms = msSince(start);
  std::ostringstream out;
  out << "{\"test\": \"cusick\", \"material\": \"" << material.preset << "\", \"bend_model\": \""
      << core::bendModelName(options.bend_model) << "\", \"side\": " << options.side
      << ", \"seconds\": " << number(options.seconds) << ", \"drape_coefficient\": " << number(measured.drape_coefficient)
      << ", \"folds\": " << measured.folds << ", \"bending_length_m\": "
      << number(std::cbrt(material.bending_rigidity_N_m / (material.areal_density_kg_per_m2 * 9.81)))
      << ", \"projected_area_m2\": " << number(measured.projected_area_m2)
      << ", \"last_second_motion_m\": " << number(measured.last_second_motion_m)
      << ", \"ms_per_frame\": " << number(elapsed_ms / measured.frames);
  if (options.positions) {
    printPositions(measured.positions_m, out);
    out << ", \"triangles\": [";
    for (std::size_t t = 0; t < measured.triangles.size(); ++t) out << (t == 0 ? "" : ", ") << measured.triangles[t];
    out << "]";
  }
  out << "}";
  std::cout << out.str() << std::endl;
  return kExitOk;
}

void parse(int argc, char** argv, ValidateOptions* options, std::vector<std::string>* errors) {
  for (int i = 1; i < argc; ++i) {
    const std::string flag = argv[i];
    const auto value = [&]() -> std::string {
      if (i + 1 >= argc) {
        errors->push_back(flag + ": needs a value");
        return "";
      }
      return argv[++i];
    };
    if (flag == kValidateFlag) {
      // The test's name, unless an option follows at once (`--validate --help`).
      if (i + 1 < argc && std::string(argv[i + 1]).rfind("--", 0) != 0) options->test = argv[++i];
    } else if (flag == "--material") {
      options->material = value();
    } else if (flag == "--bend-model") {
      const std::string name = value();
      if (!core::parseBendModelName(name, &options->bend_model)) errors->push_back("--bend-model " + name + ": springs or curvature");
    } else if (flag == "--compression-model") {
      const std::string name = value();
      if (!core::parseCompressionModelName(name, &options->compression_model)) {
        errors->push_back("--compression-model " + name + ": linear or buckling");
      }
    } else if (flag == "--cols" || flag == "--side") {
      const std::string text = value();
      const std::optional<int> n = parseInt(text);
      if (!n || *n < core::OptionLimits::kMinGridSide + 1 || *n > core::OptionLimits::kMaxGridSide - 1) {
        errors->push_back(flag + " " + text + ": an integer in [3, 511]");
      } else {
        (flag == "--cols" ? options->cols : options->side) = *n;
      }
    } else if (flag == "--seconds") {
      const std::string text = value();
      const std::optional<double> s = parseDouble(text);
      if (!s || !(*s > 0.0) || *s > kMaxSpan_s) {
        errors->push_back("--seconds " + text + ": a number of seconds in (0, " + number(kMaxSpan_s) + "]");
      } else {
        options->seconds = *s;
      }
    } else if (flag == "--set") {
      parseSceneSetting(value(), &options->settings, errors);
    } else if (flag == "--positions") {
      options->positions = true;
    } else if (flag == "--scenes-dir") {
      options->scenes_dir = value();
    } else if (flag == "--help") {
      options->help = true;
    } else {
      errors->push_back("unknown flag " + flag);
    }
  }
  if (!options->settings.empty() && !options->test.empty() && options->test != "drape") {
    errors->push_back("--set: only the drape is a scene file (" + options->test + " builds its own)");
  }
  // The JSON line reports these from the named options: set through --set it would name another run.
  for (const SceneOverride& setting : options->settings) {
    for (const auto& [key, flag] : {std::pair<const char*, const char*>{"material", "--material"},
                                    {"bend_model", "--bend-model"},
                                    {"compression_model", "--compression-model"},
                                    {"rows", "--side"},
                                    {"cols", "--side"}}) {
      if (setting.key == key) errors->push_back("--set " + setting.key + ": give it as " + flag);
    }
  }
  if (!options->help && options->test != "cantilever" && options->test != "drape" && options->test != "hanging" &&
      options->test != "cusick") {
    errors->push_back(options->test.empty() ? "--validate needs a test: cantilever, drape, hanging or cusick"
                                            : "--validate " + options->test + ": cantilever, drape, hanging or cusick");
  }
}

}  // namespace

bool isValidateCommand(int argc, char** argv) {
  for (int i = 1; i < argc; ++i) {
    if (std::string(argv[i]) == kValidateFlag) return true;
  }
  return false;
}

int runValidate(int argc, char** argv, const std::string& scenes_dir) {
  ValidateOptions options;
  options.scenes_dir = scenes_dir;
  std::vector<std::string> errors;
  parse(argc, argv, &options, &errors);
  if (options.help) {
    std::cout << kUsage;
    return errors.empty() ? kExitOk : kExitUsage;
  }
  core::MaterialOptions material;
  if (errors.empty() && !core::findMaterialPreset(options.material, &material)) {
    errors.push_back("--material " + options.material + ": one of " + core::materialPresetNames());
  }
  if (!errors.empty()) {
    for (const std::string& e : errors) std::cerr << "cloth_bench: " << e << "\n";
    return kExitUsage;
  }
  try {
    if (options.test == "cantilever") return cantilever(options, material);
    if (options.test == "drape") return drape(options);
    if (options.test == "cusick") return cusick(options, material);
    return hanging(options, material);
  } catch (const std::exception& e) {
    std::cerr << "cloth_bench: run failed: " << e.what() << "\n";
    return kExitRunFailed;
  }
}

}  // namespace cloth_sim::bench
