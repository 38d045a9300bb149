#include "cloth_sim/io/scene_file.h"

#include "cloth_sim/io/bounded_file.h"
#include "cloth_sim/io/texture.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <set>
#include <sstream>

namespace cloth_sim::core {

namespace {

namespace fs = std::filesystem;

/// Thrown by the readers below with what was expected; turned into an error naming the key.
struct WrongType {
  std::string expected;
};

/// The tag YAML gives a quoted scalar (yaml-cpp's Node::Tag()); a plain one's is "?".
constexpr const char* kNonSpecificTag = "!";
/// Most characters of a file's own text that an error message quotes: enough to recognise a typo, too few
/// to leak a file that was never a scene (any ROS peer can name any file to ~load_scene).
constexpr std::size_t kMaxQuotedChars = 32;
/// Most characters of a YAML parser message quoted (the parser's own words, cut all the same).
constexpr std::size_t kMaxParserMessageChars = 80;

/// Text from a file, quoted for an error message: at most kMaxQuotedChars characters, control characters
/// and non-ASCII bytes shown as '?', and "..." when cut.
std::string quoted(const std::string& text) {
  std::string shown;
  for (std::size_t i = 0; i < text.size() && i < kMaxQuotedChars; ++i) {
    const unsigned char c = static_cast<unsigned char>(text[i]);
    shown += std::isprint(c) ? static_cast<char>(c) : '?';
  }
  return "'" + shown + (text.size() > kMaxQuotedChars ? "...'" : "'");
}

/// The YAML core-schema type of an explicitly tagged node ("int", "float", "bool", "str", ...), or "" when
/// it carries no such tag (a scene file's plain scalar). A quoted scalar ("true", '0.5') carries YAML's
/// non-specific tag "!", which the core schema resolves to a string: it is one, as the parameter server
/// (rosparam load) also takes it, not the number or bool it spells.
std::string coreTagType(const YAML::Node& node) {
  const std::string& tag = node.Tag();
  if (tag == kNonSpecificTag) return "str";
  const std::size_t prefix = std::char_traits<char>::length(kCoreTagPrefix);
  return tag.compare(0, prefix, kCoreTagPrefix) == 0 ? tag.substr(prefix) : std::string();
}

std::string describe(const YAML::Node& node) {
  if (node.IsScalar()) {
    // A parameter carries its XmlRpc type as a tag (conversions.cpp): say it, since 10.0 reads back as '10'.
    const std::string type = coreTagType(node);
    const char* kind = type == "float" ? " (a floating-point number)" : type == "int" ? " (an integer)"
                       : type == "str" ? " (a string)" : type == "bool" ? " (a bool)" : "";
    return quoted(node.Scalar()) + kind;
  }
  if (node.IsSequence()) return "a list of " + std::to_string(node.size());
  if (node.IsMap()) return "a map";
  return "nothing";
}

/// True unless the node carries an explicit YAML core-schema tag (!!str, !!int, ...; parameters carry the
/// one their XmlRpc type gives them) other than one of `allowed` ("int", "float", "bool", "str").
bool tagAllows(const YAML::Node& node, std::initializer_list<const char*> allowed) {
  const std::string type = coreTagType(node);
  if (type.empty()) return true;
  return std::any_of(allowed.begin(), allowed.end(), [&](const char* name) { return type == name; });
}

template <typename T>
T readScalar(const YAML::Node& node, const char* expected, std::initializer_list<const char*> tags) {
  if (!node.IsScalar() || !tagAllows(node, tags)) throw WrongType{expected};
  try {
    return node.as<T>();
  } catch (const YAML::Exception&) {
    throw WrongType{expected};
  }
}

double readDouble(const YAML::Node& node) {
  try {
    return readScalar<double>(node, "a number", {"float", "int"});
  } catch (const WrongType&) {
    // A number too large for a double (1e400) is still a number: say so rather than "expected a number".
    // (One too small, 1e-400, reads as 0 without an error, as strtod's underflow gives.)
    if (node.IsScalar() && tagAllows(node, {"float", "int"})) {
      const std::string& text = node.Scalar();
      char* end = nullptr;
      errno = 0;
      const double value = std::strtod(text.c_str(), &end);
      if (end != text.c_str() && *end == '\0' && errno == ERANGE && std::isinf(value)) {
        std::ostringstream expected;
        expected << "a number a double holds (at most " << std::numeric_limits<double>::max() << " in size)";
        throw WrongType{expected.str()};
      }
    }
    throw;
  }
}
int readInt(const YAML::Node& node) {
  try {
    return readScalar<int>(node, "an integer", {"int"});
  } catch (const WrongType&) {
    // An integer too large for an int (rows: 3000000000) is still an integer: say so, and leave the
    // field's own range to the field (readCameras' seed) or to validateSceneOptions.
    readScalar<long long>(node, "an integer", {"int"});
    throw WrongType{"an integer no larger in size than " + std::to_string(std::numeric_limits<int>::max())};
  }
}
bool readBool(const YAML::Node& node) { return readScalar<bool>(node, "true or false", {"bool"}); }
std::string readString(const YAML::Node& node) { return readScalar<std::string>(node, "a string", {"str"}); }

Eigen::Vector3d readVector(const YAML::Node& node) {
  const std::string expected = "a list of 3 numbers [x, y, z]";
  if (!node.IsSequence() || node.size() != 3) throw WrongType{expected};
  Eigen::Vector3d vector;
  for (int i = 0; i < 3; ++i) {
    try {
      vector[i] = readDouble(node[i]);
    } catch (const WrongType& wrong) {
      // Which of the three, and what it should be.
      throw WrongType{expected + " (its [" + std::to_string(i) + "] = " + describe(node[i]) + " is not " +
                      wrong.expected + ")"};
    }
  }
  return vector;
}

std::vector<std::string> readPins(const YAML::Node& node) {
  if (!node.IsSequence()) throw WrongType{"a list of corner/edge names or particle indices"};
  std::vector<std::string> pins;
  // A particle index may come as an integer (a parameter list [0, 19]) or as text.
  for (const YAML::Node& item : node) {
    pins.push_back(readScalar<std::string>(item, "a corner/edge name or a particle index", {"str", "int"}));
  }
  return pins;
}

/// What is wrong with a map's keys, if anything: the first key that is not a name, not one of those
/// allowed, or given twice (yaml-cpp keeps a key given twice as two entries).
struct KeyProblem {
  enum class Kind { kNone, kNotAName, kUnknown, kTwice } kind = Kind::kNone;
  std::string key;
};

/// Checks a map's keys against `allowed`; on success *keys (if given) holds the keys as written.
KeyProblem checkKeys(const YAML::Node& map, const std::vector<std::string>& allowed,
                     std::set<std::string>* keys = nullptr) {
  std::set<std::string> seen;
  for (const auto& field : map) {
    if (!field.first.IsScalar()) return {KeyProblem::Kind::kNotAName, std::string()};
    const std::string name = field.first.Scalar();
    if (std::find(allowed.begin(), allowed.end(), name) == allowed.end()) return {KeyProblem::Kind::kUnknown, name};
    if (!seen.insert(name).second) return {KeyProblem::Kind::kTwice, name};
  }
  if (keys != nullptr) *keys = std::move(seen);
  return {};
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
    const KeyProblem problem = checkKeys(entry, fields);
    if (problem.kind == KeyProblem::Kind::kNotAName) throw WrongType{"maps whose keys are names"};
    if (problem.kind == KeyProblem::Kind::kUnknown) {
      std::string known;
      for (const std::string& f : fields) known += (known.empty() ? "" : ", ") + f;
      throw WrongType{"maps with the keys " + known + " (got " + quoted(problem.key) + ")"};
    }
    if (problem.kind == KeyProblem::Kind::kTwice) throw WrongType{"maps with each key once ('" + problem.key + "' twice)"};
    for (const auto& field : entry) {
      const std::string name = field.first.Scalar();
      try {
        apply(name, field.second, item);
      } catch (const WrongType& wrong) {
        // Name the entry and the field: "a list of 1: expected an integer" left the user guessing which.
        throw WrongType{"maps whose " + name + " is " + wrong.expected + " ([" + std::to_string(items.size()) + "]." +
                        name + " = " + describe(field.second) + ")"};
      }
    }
    items.push_back(item);
  }
  return items;
}

/// Every field of a material block, in the order a state file writes them.
const std::vector<std::string>& materialFields() {
  static const std::vector<std::string> fields{"preset", "areal_density", "stretch_modulus", "shear_modulus",
                                               "bending_rigidity", "damping"};
  return fields;
}

/// `material`: a preset's name, or a block of MaterialOptions' fields; a block with `preset` starts from
/// that preset (its other fields override it), one without gives every field but `damping`.
MaterialOptions readMaterial(const YAML::Node& node) {
  const std::string presets = "a preset name (" + materialPresetNames() + ") or a map of " +
                              "areal_density, stretch_modulus, shear_modulus, bending_rigidity and damping";
  MaterialOptions material;
  if (node.IsScalar()) {
    const std::string name = readScalar<std::string>(node, presets.c_str(), {"str"});
    if (!findMaterialPreset(name, &material)) throw WrongType{presets + " (got " + quoted(name) + ")"};
    return material;
  }
  if (!node.IsMap()) throw WrongType{presets};
  const KeyProblem problem = checkKeys(node, materialFields());
  if (problem.kind == KeyProblem::Kind::kNotAName) throw WrongType{"a map whose keys are names"};
  if (problem.kind == KeyProblem::Kind::kUnknown) throw WrongType{presets + " (got the key " + quoted(problem.key) + ")"};
  if (problem.kind == KeyProblem::Kind::kTwice) throw WrongType{"a map with each key once ('" + problem.key + "' twice)"};
  material.damping_s = kDefaultMaterialDamping_s;
  // preset "" is a block written by hand (a state file saves it so).
  const std::string base = node["preset"] ? readScalar<std::string>(node["preset"], "a preset name", {"str"}) : "";
  if (!base.empty()) {
    const std::string& name = base;
    if (!findMaterialPreset(name, &material)) {
      throw WrongType{"a map whose preset is one of " + materialPresetNames() + " (got " + quoted(name) + ")"};
    }
  }
  const std::pair<const char*, double MaterialOptions::*> numbers[] = {
      {"areal_density", &MaterialOptions::areal_density_kg_per_m2},
      {"stretch_modulus", &MaterialOptions::stretch_modulus_N_per_m},
      {"shear_modulus", &MaterialOptions::shear_modulus_N_per_m},
      {"bending_rigidity", &MaterialOptions::bending_rigidity_N_m},
      {"damping", &MaterialOptions::damping_s}};
  std::string missing;
  for (const auto& [name, member] : numbers) {
    if (node[name]) {
      try {
        material.*member = readDouble(node[name]);
      } catch (const WrongType& wrong) {
        throw WrongType{"a map whose " + std::string(name) + " is " + wrong.expected + " (" + name + " = " +
                        describe(node[name]) + ")"};
      }
    } else if (base.empty() && std::string(name) != "damping") {
      missing += (missing.empty() ? "" : ", ") + std::string(name);
    }
  }
  if (!missing.empty()) throw WrongType{"a map with every field, or a preset to start from (missing " + missing + ")"};
  return material;
}

/// A point of the cloth's own (u, v) plane: [u, v].
Eigen::Vector2d readPoint2(const YAML::Node& node, const char* expected) {
  if (!node.IsSequence() || node.size() != 2) throw WrongType{expected};
  return Eigen::Vector2d(readDouble(node[0]), readDouble(node[1]));
}

/// `outline`: none, {circle: {center: [u, v], radius: r}} or {polygon: [[u, v], ...]}. Each mistake is
/// named (an extra or missing key, a key twice, a corner of three numbers), not only the form expected.
OutlineOptions readOutline(const YAML::Node& node) {
  const std::string expected =
      "none, {circle: {center: [u, v], radius: r}} or {polygon: [[u, v], [u, v], [u, v], ...]}";
  const auto wrong = [&](const std::string& why) { return WrongType{expected + " (" + why + ")"}; };
  OutlineOptions outline;
  if (node.IsScalar()) {
    if (readScalar<std::string>(node, expected.c_str(), {"str"}) != "none") throw wrong("got " + describe(node));
    return outline;
  }
  if (!node.IsMap()) throw wrong("got " + describe(node));
  const auto keysOf = [&](const YAML::Node& map, const std::vector<std::string>& allowed) {
    std::set<std::string> keys;
    const KeyProblem problem = checkKeys(map, allowed, &keys);
    if (problem.kind == KeyProblem::Kind::kTwice) throw wrong("'" + problem.key + "' twice");
    if (problem.kind != KeyProblem::Kind::kNone) throw wrong("the key " + quoted(problem.key) + " is not one of them");
    return keys;
  };
  const std::set<std::string> shapes = keysOf(node, {"circle", "polygon"});
  if (shapes.empty()) throw wrong("an empty map: give circle or polygon");
  if (shapes.size() != 1) throw wrong("one of circle or polygon, not both");
  if (shapes.count("circle") != 0) {
    const YAML::Node circle = node["circle"];
    if (!circle.IsMap()) throw wrong("circle is " + describe(circle));
    const std::set<std::string> keys = keysOf(circle, {"center", "radius"});
    for (const char* key : {"center", "radius"}) {
      if (keys.count(key) == 0) throw wrong("the circle has no " + std::string(key));
    }
    outline.shape = OutlineOptions::Shape::kCircle;
    try {
      outline.center_m = readPoint2(circle["center"], "[u, v]");
    } catch (const WrongType&) {
      throw wrong("the circle's center is " + describe(circle["center"]) + ", not [u, v] (two numbers)");
    }
    try {
      outline.radius_m = readDouble(circle["radius"]);
    } catch (const WrongType& bad) {
      throw wrong("the circle's radius is " + describe(circle["radius"]) + ", not " + bad.expected);
    }
  } else {
    const YAML::Node polygon = node["polygon"];
    if (!polygon.IsSequence()) throw wrong("polygon is " + describe(polygon));
    outline.shape = OutlineOptions::Shape::kPolygon;
    for (std::size_t i = 0; i < polygon.size(); ++i) {
      const YAML::Node corner = polygon[i];
      try {
        outline.vertices_m.push_back(readPoint2(corner, "[u, v]"));
      } catch (const WrongType&) {
        throw wrong("corner [" + std::to_string(i) + "] is " + describe(corner) + ", not [u, v] (two numbers)");
      }
    }
  }
  return outline;
}

/// The keys a material sets (mass and each spring kind's constants): a scene gives them or a material.
bool isMaterialConstantKey(const std::string& key) {
  if (key == "mass") return true;
  for (int k = 0; k < kSpringKindCount; ++k) {
    const std::string kind = springKindName(static_cast<SpringKind>(k));
    if (key == kind + "_enabled" || key == kind + "_stiffness" || key == kind + "_damping") return true;
  }
  return false;
}

/// The `cameras` list: each entry a map of CameraOptions' keys; one without cx / cy gets the centre of
/// its image.
std::vector<CameraOptions> readCameras(const YAML::Node& node) {
  std::vector<CameraOptions> cameras = readList<CameraOptions>(
      node, {"name", "frame", "width", "height", "fx", "fy", "cx", "cy", "rate", "min_range", "max_range", "noise", "seed"},
      [](const std::string& f, const YAML::Node& v, CameraOptions& c) {
        if (f == "name") c.name = readString(v);
        if (f == "frame") c.frame = readString(v);
        if (f == "width") c.width = readInt(v);
        if (f == "height") c.height = readInt(v);
        if (f == "fx") c.fx_px = readDouble(v);
        if (f == "fy") c.fy_px = readDouble(v);
        if (f == "cx") c.cx_px = readDouble(v);
        if (f == "cy") c.cy_px = readDouble(v);
        if (f == "rate") c.rate_hz = readDouble(v);
        if (f == "min_range") c.min_range_m = readDouble(v);
        if (f == "max_range") c.max_range_m = readDouble(v);
        if (f == "noise" && !parseDepthNoiseName(readString(v), &c.noise)) throw WrongType{"none or kinect"};
        if (f == "seed") {
          // Read wide, so that 2^31 is refused with the seed's own range rather than an int's.
          const long long seed = readScalar<long long>(v, "an integer", {"int"});
          if (seed < 0 || seed > std::numeric_limits<int>::max()) {
            throw WrongType{"an integer within [0, " + std::to_string(std::numeric_limits<int>::max()) + "]"};
          }
          c.seed = static_cast<std::uint32_t>(seed);
        }
      });
  for (std::size_t i = 0; i < cameras.size(); ++i) {
    if (!node[i]["cx"]) cameras[i].cx_px = 0.5 * (cameras[i].width - 1);
    if (!node[i]["cy"]) cameras[i].cy_px = 0.5 * (cameras[i].height - 1);
  }
  return cameras;
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
  s["material"] = [](const YAML::Node& n, SceneOptions& o) {
    o.material = readMaterial(n);
    o.has_material = true;
  };
  s["outline"] = [](const YAML::Node& n, SceneOptions& o) { o.outline = readOutline(n); };
  s["bend_model"] = [](const YAML::Node& n, SceneOptions& o) {
    if (!parseBendModelName(readString(n), &o.bend_model)) throw WrongType{"springs or curvature"};
  };
  s["compression_model"] = [](const YAML::Node& n, SceneOptions& o) {
    if (!parseCompressionModelName(readString(n), &o.compression_model)) throw WrongType{"linear or buckling"};
  };
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
  s["self_collision"] = [](const YAML::Node& n, SceneOptions& o) { o.self_collision.enabled = readBool(n); };
  s["self_collision_thickness"] = [](const YAML::Node& n, SceneOptions& o) {
    o.self_collision.thickness_m = readDouble(n);
  };
  s["self_collision_friction"] = [](const YAML::Node& n, SceneOptions& o) { o.self_collision.friction = readDouble(n); };
  s["grasp_stiffness"] = [](const YAML::Node& n, SceneOptions& o) { o.grasp_stiffness_N_per_m = readDouble(n); };
  s["grasp_damping"] = [](const YAML::Node& n, SceneOptions& o) { o.grasp_damping_N_s_per_m = readDouble(n); };
  s["integrator"] = [](const YAML::Node& n, SceneOptions& o) {
    if (!parseIntegratorName(readString(n), &o.integrator)) {
      throw WrongType{"one of " + integratorNameList()};
    }
  };
  s["substeps"] = [](const YAML::Node& n, SceneOptions& o) {
    const std::string expected = std::string("'") + kAutoSubstepsName + "' or an integer in [1, " +
                                 std::to_string(OptionLimits::kMaxSubsteps) + "]";
    if (n.IsScalar() && n.Scalar() == kAutoSubstepsName) {
      o.substeps = SceneOptions::kAutoSubsteps;
      return;
    }
    o.substeps = readScalar<int>(n, expected.c_str(), {"int"});
    // 0 is how `auto` is stored; written as a number it is a mistake, not a request for auto.
    if (o.substeps == SceneOptions::kAutoSubsteps) throw WrongType{expected};
  };
  s["guard_retries"] = [](const YAML::Node& n, SceneOptions& o) { o.guard_retries = readBool(n); };
  s["sleep_speed"] = [](const YAML::Node& n, SceneOptions& o) { o.sleep_speed_m_per_s = readDouble(n); };
  s["solver_tolerance"] = [](const YAML::Node& n, SceneOptions& o) { o.solver.tolerance = readDouble(n); };
  s["threads"] = [](const YAML::Node& n, SceneOptions& o) { o.threads = readInt(n); };
  s["solver_max_iterations"] = [](const YAML::Node& n, SceneOptions& o) { o.solver.max_iterations = readInt(n); };
  s["solver_preconditioner"] = [](const YAML::Node& n, SceneOptions& o) {
    if (!parsePreconditionerName(readString(n), &o.solver.preconditioner)) {
      throw WrongType{"one of " + preconditionerNameList()};
    }
  };
  s["frame_rate"] = [](const YAML::Node& n, SceneOptions& o) { o.frame_rate_hz = readDouble(n); };
  s["texture"] = [](const YAML::Node& n, SceneOptions& o) { o.texture = readString(n); };
  s["cameras"] = [](const YAML::Node& n, SceneOptions& o) { o.cameras = readCameras(n); };
  s["frame_colliders"] = [](const YAML::Node& n, SceneOptions& o) {
    // An entry without `shape` is a sphere: one giving a box's size or a capsule's length most likely forgot
    // its shape (it ran as a 5 cm ball). Refused; an entry that names its shape may carry every field (a
    // state file writes them all).
    for (std::size_t i = 0; n.IsSequence() && i < n.size(); ++i) {
      const YAML::Node entry = n[i];
      if (!entry.IsMap() || entry["shape"]) continue;
      for (const char* field : {"size", "length"}) {
        if (entry[field]) {
          throw WrongType{"maps that name their shape ([" + std::to_string(i) + "] has " + field +
                          " but no shape, so it would be a sphere: give shape: " +
                          (std::string(field) == "size" ? "box" : "capsule") + ")"};
        }
      }
    }
    o.colliders.frames = readList<FrameCollider>(
        n, {"frame", "shape", "radius", "length", "size", "offset", "rpy"},
        [](const std::string& f, const YAML::Node& v, FrameCollider& c) {
          if (f == "frame") c.frame = readString(v);
          if (f == "shape" && !parseShapeName(readString(v), &c.shape)) throw WrongType{"sphere, capsule or box"};
          if (f == "radius") c.radius_m = readDouble(v);
          if (f == "length") c.length_m = readDouble(v);
          if (f == "size") c.size_m = readVector(v);
          if (f == "offset") c.offset_m = readVector(v);
          if (f == "rpy") c.rpy_rad = readVector(v);
        });
  };
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
  // yaml-cpp keeps both entries of a repeated key; the later one would silently win.
  std::set<std::string> seen;
  for (const auto& entry : map) {
    if (!entry.first.IsScalar()) {
      errors->push_back(source + ": a key is " + describe(entry.first) + ": keys must be names");
      continue;
    }
    const std::string key = entry.first.Scalar();
    const auto setter = setters().find(key);
    if (setter == setters().end()) {
      errors->push_back(source + ": unknown key " + quoted(key));
      continue;
    }
    if (!seen.insert(key).second) {
      errors->push_back(source + ": duplicate key '" + key + "': each key may appear once");
      continue;
    }
    try {
      setter->second(entry.second, *options);
    } catch (const WrongType& wrong) {
      errors->push_back(source + ": " + key + " = " + describe(entry.second) + ": expected " + wrong.expected);
    }
  }
  if (options->has_material) {
    // A material sets these for the grid: both at once would leave one of them silently unused.
    std::string given;
    for (const std::string& key : seen) {
      if (isMaterialConstantKey(key)) given += (given.empty() ? "" : ", ") + key;
    }
    if (!given.empty()) {
      errors->push_back(source + ": material and " + given +
                        " given together: a material sets the mass and every spring's constants for the grid; "
                        "give one or the other");
    }
  }
  return errors->size() == errors_before;
}

std::string resolveScenePath(const std::string& name_or_path, const std::string& scenes_dir) {
  if (name_or_path.empty()) return name_or_path;
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

namespace {

bool hasSceneExtension(const fs::path& path) {
  const std::string extension = path.extension().string();
  return extension == ".yaml" || extension == ".yml";
}

}  // namespace

bool loadSceneFile(const std::string& path, SceneOptions* options, std::vector<std::string>* errors) {
  if (path.empty()) {
    errors->push_back("scene name is empty: give a built-in scene's name or a path to a .yaml scene file");
    return false;
  }
  const std::string source = "scene file " + path;
  if (!hasSceneExtension(path)) {
    errors->push_back(source + ": not a scene file (scene files end in .yaml or .yml)");
    return false;
  }
  std::string text;
  std::string read_error;
  if (!readBoundedRegularFile(path, kMaxSceneFileBytes, &text, &read_error)) {
    errors->push_back(source + ": " + read_error);
    return false;
  }
  if (text.find_first_not_of(" \t\r\n") == std::string::npos) {
    errors->push_back(source + ": the file is empty");
    return false;
  }
  YAML::Node root;
  try {
    // Every document is read: YAML::Load takes the first and drops the rest unread, so a second document
    // (a stray `---`) lost its keys and even its syntax errors in silence. Empty documents (a leading or
    // trailing `---`) are no keys; more than one with keys is refused, not merged.
    int documents_with_keys = 0;
    for (const YAML::Node& document : YAML::LoadAll(text)) {
      if (document.IsNull()) continue;
      ++documents_with_keys;
      root = document;
    }
    if (documents_with_keys > 1) {
      errors->push_back(source + ": " + std::to_string(documents_with_keys) +
                        " YAML documents (separated by ---): a scene file is one");
      return false;
    }
  } catch (const YAML::Exception& e) {
    // The parser's message only, cut: e.what() may grow with the text around the error.
    errors->push_back(source + ": not valid YAML at line " + std::to_string(e.mark.line + 1) + ", column " +
                      std::to_string(e.mark.column + 1) + ": " + e.msg.substr(0, kMaxParserMessageChars));
    return false;
  }
  SceneOptions loaded = *options;
  if (!applySceneYaml(root, source, &loaded, errors)) return false;
  const std::string texture_as_written = loaded.texture;
  if (!loaded.texture.empty() && fs::path(loaded.texture).is_relative()) {
    loaded.texture = (fs::path(path).parent_path() / loaded.texture).string();
  }
  if (!loaded.texture.empty()) {
    // The same check every way a texture arrives goes through (the image reader makes it again on the
    // opened file): reported here with the file's own spelling of the path.
    const std::string problem = textureFileProblem(loaded.texture);
    if (!problem.empty()) {
      errors->push_back(source + ": texture " + quoted(texture_as_written) + ": " + problem);
      return false;
    }
  }
  const std::vector<std::string> problems = validateSceneOptions(loaded);
  for (const std::string& problem : problems) errors->push_back(source + ": " + problem);
  if (!problems.empty()) return false;
  *options = loaded;
  return true;
}

namespace {

/// The shortest decimal (15 to 17 significant digits) that reads back to the same bits: 17 always do;
/// fewer keep 0.1 readable as 0.1. YAML spells the non-finite ones.
std::string exactNumber(double value) {
  if (std::isnan(value)) return ".nan";
  if (std::isinf(value)) return value > 0.0 ? ".inf" : "-.inf";
  constexpr int kFewestDigits = 15;
  return exactNumberText(value, kFewestDigits);
}

void emitVector(YAML::Emitter& out, const Eigen::Vector3d& v) {
  out << YAML::Flow << YAML::BeginSeq << exactNumber(v.x()) << exactNumber(v.y()) << exactNumber(v.z())
      << YAML::EndSeq;
}

void emitString(YAML::Emitter& out, const std::string& text) { out << YAML::DoubleQuoted << text; }

}  // namespace

std::string sceneYaml(const SceneOptions& o) {
  YAML::Emitter out;
  out << YAML::BeginMap;
  const auto key = [&out](const std::string& name) -> YAML::Emitter& { return out << YAML::Key << name << YAML::Value; };
  const auto number = [&key](const std::string& name, double value) { key(name) << exactNumber(value); };
  const auto vector = [&key, &out](const std::string& name, const Eigen::Vector3d& value) {
    key(name);
    emitVector(out, value);
  };
  const auto boolean = [&key](const std::string& name, bool value) { key(name) << (value ? "true" : "false"); };
  key("name");
  emitString(out, o.name);
  key("rows") << o.rows;
  key("cols") << o.cols;
  number("width", o.width_m);
  number("height", o.height_m);
  vector("origin", o.origin_m);
  vector("u_axis", o.u_axis);
  vector("v_axis", o.v_axis);
  vector("gravity", o.gravity_m_per_s2);
  if (o.has_material) {
    // The material, not the constants it gives this grid (they are derived again on reading).
    key("material") << YAML::BeginMap;
    out << YAML::Key << "preset" << YAML::Value;
    emitString(out, o.material.preset);
    out << YAML::Key << "areal_density" << YAML::Value << exactNumber(o.material.areal_density_kg_per_m2);
    out << YAML::Key << "stretch_modulus" << YAML::Value << exactNumber(o.material.stretch_modulus_N_per_m);
    out << YAML::Key << "shear_modulus" << YAML::Value << exactNumber(o.material.shear_modulus_N_per_m);
    out << YAML::Key << "bending_rigidity" << YAML::Value << exactNumber(o.material.bending_rigidity_N_m);
    out << YAML::Key << "damping" << YAML::Value << exactNumber(o.material.damping_s) << YAML::EndMap;
  } else {
    number("mass", o.mass_kg);
    for (int k = 0; k < kSpringKindCount; ++k) {
      const std::string kind = springKindName(static_cast<SpringKind>(k));
      boolean(kind + "_enabled", o.springs[k].enabled);
      number(kind + "_stiffness", o.springs[k].stiffness_N_per_m);
      number(kind + "_damping", o.springs[k].damping_N_s_per_m);
    }
  }
  key("bend_model") << bendModelName(o.bend_model);
  key("compression_model") << compressionModelName(o.compression_model);
  key("outline");
  if (o.outline.shape == OutlineOptions::Shape::kNone) {
    out << "none";
  } else if (o.outline.shape == OutlineOptions::Shape::kCircle) {
    out << YAML::BeginMap << YAML::Key << "circle" << YAML::Value << YAML::BeginMap << YAML::Key << "center"
        << YAML::Value << YAML::Flow << YAML::BeginSeq << exactNumber(o.outline.center_m.x())
        << exactNumber(o.outline.center_m.y()) << YAML::EndSeq << YAML::Key << "radius" << YAML::Value
        << exactNumber(o.outline.radius_m) << YAML::EndMap << YAML::EndMap;
  } else {
    out << YAML::BeginMap << YAML::Key << "polygon" << YAML::Value << YAML::BeginSeq;
    for (const Eigen::Vector2d& corner : o.outline.vertices_m) {
      out << YAML::Flow << YAML::BeginSeq << exactNumber(corner.x()) << exactNumber(corner.y()) << YAML::EndSeq;
    }
    out << YAML::EndSeq << YAML::EndMap;
  }
  number("air_damping", o.air_damping_N_s_per_m);
  boolean("wind_enabled", o.wind_enabled);
  vector("wind", o.wind.velocity_m_per_s);
  key("wind_model") << (o.wind.model == WindModel::kPaper ? "paper" : "aerodynamic");
  number("wind_coefficient", o.wind.paper_coefficient_N_s_per_m);
  number("air_density", o.wind.air_density_kg_per_m3);
  number("drag_coefficient", o.wind.drag_coefficient);
  number("wind_gust_amplitude", o.wind.gust_amplitude);
  number("wind_gust_period", o.wind.gust_period_s);
  key("pins") << YAML::Flow << YAML::BeginSeq;
  for (const std::string& pin : o.pins) emitString(out, pin);
  out << YAML::EndSeq;
  key("pin_positions") << YAML::BeginSeq;
  for (const Eigen::Vector3d& position : o.pin_positions_m) emitVector(out, position);
  out << YAML::EndSeq;
  number("pin_travel_time", o.pin_travel_time_s);
  vector("pin_motion_amplitude", o.pin_motion_amplitude_m);
  number("pin_motion_period", o.pin_motion_period_s);
  key("planes") << YAML::BeginSeq;
  for (const PlaneCollider& plane : o.colliders.planes) {
    out << YAML::BeginMap << YAML::Key << "normal" << YAML::Value;
    emitVector(out, plane.normal);
    out << YAML::Key << "offset" << YAML::Value << exactNumber(plane.offset_m) << YAML::EndMap;
  }
  out << YAML::EndSeq;
  key("spheres") << YAML::BeginSeq;
  for (const SphereCollider& sphere : o.colliders.spheres) {
    out << YAML::BeginMap << YAML::Key << "center" << YAML::Value;
    emitVector(out, sphere.center_m);
    out << YAML::Key << "radius" << YAML::Value << exactNumber(sphere.radius_m);
    out << YAML::Key << "velocity" << YAML::Value;
    emitVector(out, sphere.velocity_m_per_s);
    out << YAML::Key << "amplitude" << YAML::Value;
    emitVector(out, sphere.oscillation_amplitude_m);
    out << YAML::Key << "period" << YAML::Value << exactNumber(sphere.oscillation_period_s) << YAML::EndMap;
  }
  out << YAML::EndSeq;
  key("boxes") << YAML::BeginSeq;
  for (const BoxCollider& box : o.colliders.boxes) {
    out << YAML::BeginMap << YAML::Key << "min" << YAML::Value;
    emitVector(out, box.min_m);
    out << YAML::Key << "max" << YAML::Value;
    emitVector(out, box.max_m);
    out << YAML::EndMap;
  }
  out << YAML::EndSeq;
  number("contact_depth", o.contact.depth_m);
  number("restitution", o.contact.restitution);
  number("friction", o.contact.friction);
  boolean("self_collision", o.self_collision.enabled);
  number("self_collision_thickness", o.self_collision.thickness_m);
  number("self_collision_friction", o.self_collision.friction);
  number("grasp_stiffness", o.grasp_stiffness_N_per_m);
  number("grasp_damping", o.grasp_damping_N_s_per_m);
  key("integrator") << integratorName(o.integrator);
  if (o.autoSubsteps()) {
    key("substeps") << kAutoSubstepsName;
  } else {
    key("substeps") << o.substeps;
  }
  boolean("guard_retries", o.guard_retries);
  number("sleep_speed", o.sleep_speed_m_per_s);
  number("solver_tolerance", o.solver.tolerance);
  key("solver_max_iterations") << o.solver.max_iterations;
  key("solver_preconditioner") << preconditionerName(o.solver.preconditioner);
  key("threads") << o.threads;
  number("frame_rate", o.frame_rate_hz);
  key("texture");
  emitString(out, o.texture);
  key("cameras") << YAML::BeginSeq;
  for (const CameraOptions& camera : o.cameras) {
    out << YAML::BeginMap << YAML::Key << "name" << YAML::Value;
    emitString(out, camera.name);
    out << YAML::Key << "frame" << YAML::Value;
    emitString(out, camera.frame);
    out << YAML::Key << "width" << YAML::Value << camera.width;
    out << YAML::Key << "height" << YAML::Value << camera.height;
    out << YAML::Key << "fx" << YAML::Value << exactNumber(camera.fx_px);
    out << YAML::Key << "fy" << YAML::Value << exactNumber(camera.fy_px);
    out << YAML::Key << "cx" << YAML::Value << exactNumber(camera.cx_px);
    out << YAML::Key << "cy" << YAML::Value << exactNumber(camera.cy_px);
    out << YAML::Key << "rate" << YAML::Value << exactNumber(camera.rate_hz);
    out << YAML::Key << "min_range" << YAML::Value << exactNumber(camera.min_range_m);
    out << YAML::Key << "max_range" << YAML::Value << exactNumber(camera.max_range_m);
    out << YAML::Key << "noise" << YAML::Value << depthNoiseName(camera.noise);
    out << YAML::Key << "seed" << YAML::Value << camera.seed << YAML::EndMap;
  }
  out << YAML::EndSeq;
  key("frame_colliders") << YAML::BeginSeq;
  for (const FrameCollider& collider : o.colliders.frames) {
    out << YAML::BeginMap << YAML::Key << "frame" << YAML::Value;
    emitString(out, collider.frame);
    out << YAML::Key << "shape" << YAML::Value << shapeName(collider.shape);
    out << YAML::Key << "radius" << YAML::Value << exactNumber(collider.radius_m);
    out << YAML::Key << "length" << YAML::Value << exactNumber(collider.length_m);
    out << YAML::Key << "size" << YAML::Value;
    emitVector(out, collider.size_m);
    out << YAML::Key << "offset" << YAML::Value;
    emitVector(out, collider.offset_m);
    out << YAML::Key << "rpy" << YAML::Value;
    emitVector(out, collider.rpy_rad);
    out << YAML::EndMap;
  }
  out << YAML::EndSeq;
  out << YAML::EndMap;
  return std::string(out.c_str()) + "\n";
}

}  // namespace cloth_sim::core
