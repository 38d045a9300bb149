#include "cloth_sim/io/scene_file.h"

#include <algorithm>
#include <filesystem>
#include <functional>
#include <map>
#include <sstream>

namespace cloth_sim::core {

namespace {

namespace fs = std::filesystem;

/// Thrown by the readers below with what was expected; turned into an error naming the key.
struct WrongType {
  std::string expected;
};

std::string describe(const YAML::Node& node) {
  if (node.IsScalar()) return "'" + node.Scalar() + "'";
  if (node.IsSequence()) return "a list of " + std::to_string(node.size());
  if (node.IsMap()) return "a map";
  return "nothing";
}

template <typename T>
T readScalar(const YAML::Node& node, const char* expected) {
  if (!node.IsScalar()) throw WrongType{expected};
  try {
    return node.as<T>();
  } catch (const YAML::Exception&) {
    throw WrongType{expected};
  }
}

double readDouble(const YAML::Node& node) { return readScalar<double>(node, "a number"); }
int readInt(const YAML::Node& node) { return readScalar<int>(node, "an integer"); }
bool readBool(const YAML::Node& node) { return readScalar<bool>(node, "true or false"); }
std::string readString(const YAML::Node& node) { return readScalar<std::string>(node, "a string"); }

Eigen::Vector3d readVector(const YAML::Node& node) {
  if (!node.IsSequence() || node.size() != 3) throw WrongType{"a list of 3 numbers [x, y, z]"};
  return Eigen::Vector3d(readDouble(node[0]), readDouble(node[1]), readDouble(node[2]));
}

std::vector<std::string> readPins(const YAML::Node& node) {
  if (!node.IsSequence()) throw WrongType{"a list of corner/edge names or particle indices"};
  std::vector<std::string> pins;
  for (const YAML::Node& item : node) pins.push_back(readString(item));
  return pins;
}

/// Reads a list of maps, each with its own known keys; `apply` sets one field.
template <typename T>
std::vector<T> readList(const YAML::Node& node, const std::vector<std::string>& fields,
                        const std::function<void(const std::string&, const YAML::Node&, T&)>& apply) {
  if (!node.IsSequence()) throw WrongType{"a list of maps"};
  std::vector<T> items;
  for (const YAML::Node& entry : node) {
    if (!entry.IsMap()) throw WrongType{"a list of maps"};
    T item;
    for (const auto& field : entry) {
      if (!field.first.IsScalar()) throw WrongType{"maps whose keys are names"};
      const std::string name = field.first.Scalar();
      if (std::find(fields.begin(), fields.end(), name) == fields.end()) {
        std::string known;
        for (const std::string& f : fields) known += (known.empty() ? "" : ", ") + f;
        throw WrongType{"maps with the keys " + known + " (got '" + name + "')"};
      }
      apply(name, field.second, item);
    }
    items.push_back(item);
  }
  return items;
}

using Setter = std::function<void(const YAML::Node&, SceneOptions&)>;

std::map<std::string, Setter> makeSetters() {
  std::map<std::string, Setter> s;
  s["name"] = [](const YAML::Node& n, SceneOptions& o) { o.name = readString(n); };
  s["rows"] = [](const YAML::Node& n, SceneOptions& o) { o.rows = readInt(n); };
  s["cols"] = [](const YAML::Node& n, SceneOptions& o) { o.cols = readInt(n); };
  s["width"] = [](const YAML::Node& n, SceneOptions& o) { o.width_m = readDouble(n); };
  s["height"] = [](const YAML::Node& n, SceneOptions& o) { o.height_m = readDouble(n); };
  s["origin"] = [](const YAML::Node& n, SceneOptions& o) { o.origin_m = readVector(n); };
  s["u_axis"] = [](const YAML::Node& n, SceneOptions& o) { o.u_axis = readVector(n); };
  s["v_axis"] = [](const YAML::Node& n, SceneOptions& o) { o.v_axis = readVector(n); };
  s["mass"] = [](const YAML::Node& n, SceneOptions& o) { o.mass_kg = readDouble(n); };
  s["gravity"] = [](const YAML::Node& n, SceneOptions& o) { o.gravity_m_per_s2 = readVector(n); };
  for (int k = 0; k < kSpringKindCount; ++k) {
    const std::string kind = springKindName(static_cast<SpringKind>(k));
    s[kind + "_enabled"] = [k](const YAML::Node& n, SceneOptions& o) { o.springs[k].enabled = readBool(n); };
    s[kind + "_stiffness"] = [k](const YAML::Node& n, SceneOptions& o) {
      o.springs[k].stiffness_N_per_m = readDouble(n);
    };
    s[kind + "_damping"] = [k](const YAML::Node& n, SceneOptions& o) {
      o.springs[k].damping_N_s_per_m = readDouble(n);
    };
  }
  s["air_damping"] = [](const YAML::Node& n, SceneOptions& o) { o.air_damping_N_s_per_m = readDouble(n); };
  s["wind_enabled"] = [](const YAML::Node& n, SceneOptions& o) { o.wind_enabled = readBool(n); };
  s["wind"] = [](const YAML::Node& n, SceneOptions& o) { o.wind.velocity_m_per_s = readVector(n); };
  s["wind_model"] = [](const YAML::Node& n, SceneOptions& o) {
    const std::string model = readString(n);
    if (model == "paper") {
      o.wind.model = WindModel::kPaper;
    } else if (model == "aerodynamic") {
      o.wind.model = WindModel::kAerodynamic;
    } else {
      throw WrongType{"paper or aerodynamic"};
    }
  };
  s["wind_coefficient"] = [](const YAML::Node& n, SceneOptions& o) {
    o.wind.paper_coefficient_N_s_per_m = readDouble(n);
  };
  s["air_density"] = [](const YAML::Node& n, SceneOptions& o) { o.wind.air_density_kg_per_m3 = readDouble(n); };
  s["drag_coefficient"] = [](const YAML::Node& n, SceneOptions& o) { o.wind.drag_coefficient = readDouble(n); };
  s["wind_gust_amplitude"] = [](const YAML::Node& n, SceneOptions& o) { o.wind.gust_amplitude = readDouble(n); };
  s["wind_gust_period"] = [](const YAML::Node& n, SceneOptions& o) { o.wind.gust_period_s = readDouble(n); };
  s["pins"] = [](const YAML::Node& n, SceneOptions& o) { o.pins = readPins(n); };
  s["pin_positions"] = [](const YAML::Node& n, SceneOptions& o) {
    if (!n.IsSequence()) throw WrongType{"a list of [x, y, z] positions, one per pinned particle"};
    o.pin_positions_m.clear();
    for (const YAML::Node& item : n) o.pin_positions_m.push_back(readVector(item));
  };
  s["pin_travel_time"] = [](const YAML::Node& n, SceneOptions& o) { o.pin_travel_time_s = readDouble(n); };
  s["pin_motion_amplitude"] = [](const YAML::Node& n, SceneOptions& o) { o.pin_motion_amplitude_m = readVector(n); };
  s["pin_motion_period"] = [](const YAML::Node& n, SceneOptions& o) { o.pin_motion_period_s = readDouble(n); };
  s["planes"] = [](const YAML::Node& n, SceneOptions& o) {
    o.colliders.planes = readList<PlaneCollider>(
        n, {"normal", "offset"}, [](const std::string& f, const YAML::Node& v, PlaneCollider& p) {
          if (f == "normal") p.normal = readVector(v);
          if (f == "offset") p.offset_m = readDouble(v);
        });
  };
  s["spheres"] = [](const YAML::Node& n, SceneOptions& o) {
    o.colliders.spheres = readList<SphereCollider>(
        n, {"center", "radius", "velocity", "amplitude", "period"},
        [](const std::string& f, const YAML::Node& v, SphereCollider& c) {
          if (f == "center") c.center_m = readVector(v);
          if (f == "radius") c.radius_m = readDouble(v);
          if (f == "velocity") c.velocity_m_per_s = readVector(v);
          if (f == "amplitude") c.oscillation_amplitude_m = readVector(v);
          if (f == "period") c.oscillation_period_s = readDouble(v);
        });
  };
  s["boxes"] = [](const YAML::Node& n, SceneOptions& o) {
    o.colliders.boxes = readList<BoxCollider>(n, {"min", "max"},
                                              [](const std::string& f, const YAML::Node& v, BoxCollider& b) {
                                                if (f == "min") b.min_m = readVector(v);
                                                if (f == "max") b.max_m = readVector(v);
                                              });
  };
  s["contact_depth"] = [](const YAML::Node& n, SceneOptions& o) { o.contact.depth_m = readDouble(n); };
  s["restitution"] = [](const YAML::Node& n, SceneOptions& o) { o.contact.restitution = readDouble(n); };
  s["friction"] = [](const YAML::Node& n, SceneOptions& o) { o.contact.friction = readDouble(n); };
  s["grasp_stiffness"] = [](const YAML::Node& n, SceneOptions& o) { o.grasp_stiffness_N_per_m = readDouble(n); };
  s["grasp_damping"] = [](const YAML::Node& n, SceneOptions& o) { o.grasp_damping_N_s_per_m = readDouble(n); };
  s["integrator"] = [](const YAML::Node& n, SceneOptions& o) {
    if (!parseIntegratorName(readString(n), &o.integrator)) {
      throw WrongType{"one of " + integratorNameList()};
    }
  };
  s["substeps"] = [](const YAML::Node& n, SceneOptions& o) {
    if (n.IsScalar() && n.Scalar() == kAutoSubstepsName) {
      o.substeps = SceneOptions::kAutoSubsteps;
      return;
    }
    o.substeps = readInt(n);
    // 0 is how `auto` is stored; written as a number it is a mistake, not a request for auto.
    if (o.substeps == SceneOptions::kAutoSubsteps) throw WrongType{std::string("'") + kAutoSubstepsName + "' or an integer in [1, " +
                                                               std::to_string(OptionLimits::kMaxSubsteps) + "]"};
  };
  s["guard_retries"] = [](const YAML::Node& n, SceneOptions& o) { o.guard_retries = readBool(n); };
  s["solver_tolerance"] = [](const YAML::Node& n, SceneOptions& o) { o.solver.tolerance = readDouble(n); };
  s["threads"] = [](const YAML::Node& n, SceneOptions& o) { o.threads = readInt(n); };
  s["solver_max_iterations"] = [](const YAML::Node& n, SceneOptions& o) { o.solver.max_iterations = readInt(n); };
  s["frame_rate"] = [](const YAML::Node& n, SceneOptions& o) { o.frame_rate_hz = readDouble(n); };
  s["texture"] = [](const YAML::Node& n, SceneOptions& o) { o.texture = readString(n); };
  return s;
}

const std::map<std::string, Setter>& setters() {
  static const std::map<std::string, Setter> table = makeSetters();
  return table;
}

}  // namespace

const std::vector<std::string>& sceneKeys() {
  static const std::vector<std::string> keys = [] {
    std::vector<std::string> names;
    for (const auto& entry : setters()) names.push_back(entry.first);
    return names;
  }();
  return keys;
}

bool applySceneYaml(const YAML::Node& map, const std::string& source, SceneOptions* options,
                    std::vector<std::string>* errors) {
  const std::size_t errors_before = errors->size();
  if (!map.IsMap()) {
    errors->push_back(source + ": expected a map of scene keys, got " + describe(map));
    return false;
  }
  for (const auto& entry : map) {
    if (!entry.first.IsScalar()) {
      errors->push_back(source + ": a key is " + describe(entry.first) + ": keys must be names");
      continue;
    }
    const std::string key = entry.first.Scalar();
    const auto setter = setters().find(key);
    if (setter == setters().end()) {
      errors->push_back(source + ": unknown key '" + key + "'");
      continue;
    }
    try {
      setter->second(entry.second, *options);
    } catch (const WrongType& wrong) {
      errors->push_back(source + ": " + key + " = " + describe(entry.second) + ": expected " + wrong.expected);
    }
  }
  return errors->size() == errors_before;
}

std::string resolveScenePath(const std::string& name_or_path, const std::string& scenes_dir) {
  const fs::path given(name_or_path);
  const std::string extension = given.extension().string();
  if (name_or_path.find('/') != std::string::npos || extension == ".yaml" || extension == ".yml") {
    return name_or_path;
  }
  return (fs::path(scenes_dir) / (name_or_path + ".yaml")).string();
}

std::vector<std::string> builtinSceneNames(const std::string& scenes_dir) {
  std::vector<std::string> names;
  std::error_code ignored;
  for (const auto& entry : fs::directory_iterator(scenes_dir, ignored)) {
    if (entry.path().extension() == ".yaml") names.push_back(entry.path().stem().string());
  }
  std::sort(names.begin(), names.end());
  return names;
}

bool loadSceneFile(const std::string& path, SceneOptions* options, std::vector<std::string>* errors) {
  const std::string source = "scene file " + path;
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) {
    errors->push_back(source + ": no such file");
    return false;
  }
  YAML::Node root;
  try {
    root = YAML::LoadFile(path);
  } catch (const YAML::Exception& e) {
    errors->push_back(source + ": not valid YAML: " + e.what());
    return false;
  }
  SceneOptions loaded = *options;
  if (!applySceneYaml(root, source, &loaded, errors)) return false;
  if (!loaded.texture.empty() && fs::path(loaded.texture).is_relative()) {
    loaded.texture = (fs::path(path).parent_path() / loaded.texture).string();
  }
  const std::vector<std::string> problems = validateSceneOptions(loaded);
  for (const std::string& problem : problems) errors->push_back(source + ": " + problem);
  if (!problems.empty()) return false;
  *options = loaded;
  return true;
}

}  // namespace cloth_sim::core
