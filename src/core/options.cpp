#include "cloth_sim/core/options.h"

#include "cloth_sim/core/kinematics.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iomanip>
#include <limits>
#include <set>
#include <sstream>
#include <string>
#include <type_traits>

namespace cloth_sim::core {

namespace {

/// The same outline: the fields of its shape (a retune compares them, not the masks they give, which
/// would be rebuilt for every reconfigure).
bool sameOutline(const OutlineOptions& a, const OutlineOptions& b) {
  if (a.shape != b.shape) return false;
  if (a.shape == OutlineOptions::Shape::kCircle) return a.center_m == b.center_m && a.radius_m == b.radius_m;
  return a.shape == OutlineOptions::Shape::kNone || a.vertices_m == b.vertices_m;
}

/// How far from unit length an axis or normal may be, and how far from orthogonal two axes may be.
constexpr double kUnitTolerance = 1e-6;
/// Significant digits of a refused vector's length: enough to show how far from 1 it is.
constexpr int kLengthDigits = 10;
/// Most characters of a pin selector quoted in an error (it may come from any file given to ~load_scene).
constexpr std::size_t kMaxQuotedSelectorChars = 32;

/// A refused value as written: exact, so that a value just past a limit never prints as the limit
/// itself (1000001 is not "1e+06"), with as few digits as a stream prints unasked where they suffice.
template <typename T>
std::string valueText(T value) {
  constexpr int kStreamDigits = 6;
  if constexpr (std::is_floating_point_v<T>) {
    return exactNumberText(static_cast<double>(value), kStreamDigits);
  } else {
    return std::to_string(value);
  }
}

class Problems {
 public:
  template <typename T>
  void inRange(const std::string& field, T value, T low, T high) {
    if (std::isfinite(static_cast<double>(value)) && value >= low && value <= high) return;
    std::ostringstream out;
    out << field << " = " << valueText(value) << ": must be in [" << low << ", " << high << "]";
    list_.push_back(out.str());
  }

  void positive(const std::string& field, double value, double high) {
    if (std::isfinite(value) && value > 0.0 && value <= high) return;
    std::ostringstream out;
    out << field << " = " << valueText(value) << ": must be in (0, " << high << "]";
    list_.push_back(out.str());
  }

  void finiteVector(const std::string& field, const Eigen::Vector3d& value, double bound) {
    if (value.allFinite() && value.cwiseAbs().maxCoeff() <= bound) return;
    std::ostringstream out;
    out << field << " = " << vectorText(value) << ": each component must be finite and within +-" << bound;
    list_.push_back(out.str());
  }

  void unitVector(const std::string& field, const Eigen::Vector3d& value) {
    if (value.allFinite() && std::abs(value.norm() - 1.0) <= kUnitTolerance) return;
    std::ostringstream out;
    // The length and the tolerance are named: [0, 0.7071, 0.7071] is 0.99999 long, and that is refused.
    out << field << " = " << vectorText(value) << ": must be a unit vector (its length is "
        << std::setprecision(kLengthDigits) << value.norm() << "; 1 within " << kUnitTolerance
        << ": give more digits)";
    list_.push_back(out.str());
  }

  /// A peak speed (m/s) computed from several fields, named together.
  void speedAtMost(const std::string& fields, double speed_m_per_s, double high) {
    if (std::isfinite(speed_m_per_s) && speed_m_per_s <= high) return;
    std::ostringstream out;
    out << fields << ": peak speed " << speed_m_per_s << " m/s: must be at most " << high << " m/s";
    list_.push_back(out.str());
  }

  void fail(const std::string& message) { list_.push_back(message); }
  std::size_t size() const { return list_.size(); }
  std::vector<std::string> take() { return std::move(list_); }

 private:
  std::vector<std::string> list_;
};

std::string indexed(const std::string& list, std::size_t index, const std::string& field) {
  return list + "[" + std::to_string(index) + "]." + field;
}

/// One frame collider's problems, each field named `prefix` + its key ("frame_colliders[2]." in a scene,
/// nothing for a collider on its own).
void checkFrameCollider(const FrameCollider& c, const std::string& prefix, Problems& problems) {
  using L = OptionLimits;
  if (c.frame.empty() || c.frame[0] == '/' || c.frame.size() > L::kMaxTextChars) {
    problems.fail(prefix + "frame = '" + c.frame.substr(0, kMaxQuotedSelectorChars) +
                  "': must be a tf frame name without a leading '/', at most " + std::to_string(L::kMaxTextChars) +
                  " characters");
  }
  // Every field is checked whatever the shape: one the shape does not use is still a mistake when it is
  // out of range (a box given radius -1), and the defaults it keeps otherwise are in range.
  problems.positive(prefix + "radius", c.radius_m, L::kMaxClothSide_m);
  problems.inRange(prefix + "length", c.length_m, 0.0, L::kMaxClothSide_m);
  for (int axis = 0; axis < 3; ++axis) {
    problems.positive(prefix + "size[" + std::to_string(axis) + "]", c.size_m[axis], L::kMaxClothSide_m);
  }
  problems.finiteVector(prefix + "offset", c.offset_m, L::kMaxCoordinate_m);
  problems.finiteVector(prefix + "rpy", c.rpy_rad, L::kMaxAngle_rad);
}

/// Peak speed of the pins' travel to pin_positions, m/s: the longest trip at the smoothstep's peak rate
/// (ScriptedMotion::peakSpeed_m_per_s, before the pins' hooks exist).
double pinTravelSpeed_m_per_s(const SceneOptions& o, const std::vector<int>& pinned) {
  if (o.pin_travel_time_s <= 0.0 || o.pin_positions_m.size() != pinned.size()) return 0.0;
  const double du_m = o.width_m / (o.cols - 1);
  const double dv_m = o.height_m / (o.rows - 1);
  double longest_m = 0.0;
  for (std::size_t p = 0; p < pinned.size(); ++p) {
    const int row = pinned[p] / o.cols;
    const int col = pinned[p] % o.cols;
    const Eigen::Vector3d start_m = o.origin_m + col * du_m * o.u_axis + row * dv_m * o.v_axis;
    longest_m = std::max(longest_m, (o.pin_positions_m[p] - start_m).norm());
  }
  return kSmoothstepPeakRate * longest_m / o.pin_travel_time_s;
}

/// A camera's name becomes a topic namespace (~<name>/depth/...): a letter, then letters, digits or '_'.
bool isTopicName(const std::string& name) {
  if (name.empty() || !std::isalpha(static_cast<unsigned char>(name[0]))) return false;
  return std::all_of(name.begin(), name.end(),
                     [](char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; });
}

/// The cameras' fields, each problem naming cameras[i].field, its value and the range.
void validateCameras(const std::vector<CameraOptions>& cameras, Problems& problems) {
  using C = CameraLimits;
  if (cameras.size() > static_cast<std::size_t>(C::kMaxCameras)) {
    problems.fail("cameras: " + std::to_string(cameras.size()) + " cameras: at most " +
                  std::to_string(C::kMaxCameras));
  }
  std::set<std::string> names;
  for (std::size_t i = 0; i < cameras.size(); ++i) {
    const CameraOptions& c = cameras[i];
    const std::string shown_name = c.name.substr(0, kMaxQuotedSelectorChars);
    // Names and frames are bounded as every string a scene sets is (OptionLimits::kMaxTextChars): a name
    // becomes five topic names, and both are written to state files, which refuse longer strings.
    if (!isTopicName(c.name) || c.name.size() > OptionLimits::kMaxTextChars) {
      problems.fail(indexed("cameras", i, "name") + " = '" + shown_name +
                    "': must be a letter followed by letters, digits or '_' (it names the camera's topics), at most " +
                    std::to_string(OptionLimits::kMaxTextChars) + " characters");
    } else if (!names.insert(c.name).second) {
      problems.fail(indexed("cameras", i, "name") + " = '" + shown_name + "': another camera has this name");
    }
    if (c.frame.empty() || c.frame[0] == '/' || c.frame.size() > OptionLimits::kMaxTextChars) {
      problems.fail(indexed("cameras", i, "frame") + " = '" + c.frame.substr(0, kMaxQuotedSelectorChars) +
                    "': must be a non-empty tf frame name without a leading '/', at most " +
                    std::to_string(OptionLimits::kMaxTextChars) + " characters");
    }
    problems.inRange(indexed("cameras", i, "width"), c.width, 1, C::kMaxImageSide);
    problems.inRange(indexed("cameras", i, "height"), c.height, 1, C::kMaxImageSide);
    problems.positive(indexed("cameras", i, "fx"), c.fx_px, C::kMaxFocalLength_px);
    problems.positive(indexed("cameras", i, "fy"), c.fy_px, C::kMaxFocalLength_px);
    // The principal point may lie off the image (a crop), but not absurdly far.
    problems.inRange(indexed("cameras", i, "cx"), c.cx_px, -static_cast<double>(C::kMaxImageSide),
                     2.0 * C::kMaxImageSide);
    problems.inRange(indexed("cameras", i, "cy"), c.cy_px, -static_cast<double>(C::kMaxImageSide),
                     2.0 * C::kMaxImageSide);
    problems.positive(indexed("cameras", i, "rate"), c.rate_hz, C::kMaxRateHz);
    problems.positive(indexed("cameras", i, "min_range"), c.min_range_m, C::kMaxRange_m);
    problems.positive(indexed("cameras", i, "max_range"), c.max_range_m, C::kMaxRange_m);
    if (c.min_range_m >= c.max_range_m) {
      std::ostringstream out;
      out << indexed("cameras", i, "min_range") << " = " << c.min_range_m << " m: must be below max_range = "
          << c.max_range_m << " m";
      problems.fail(out.str());
    }
  }
}

/// Whether rows and cols are within OptionLimits: only then may rows x cols be formed and allocated.
bool gridSidesInRange(int rows, int cols) {
  using L = OptionLimits;
  return rows >= L::kMinGridSide && rows <= L::kMaxGridSide && cols >= L::kMinGridSide && cols <= L::kMaxGridSide;
}

/// Most corners an outline polygon may have.
constexpr std::size_t kMaxOutlineVertices = 4096;

/// The outline's own problems, each naming its field: its shape, and that it keeps at least one triangle
/// of the grid (when width and height are valid). *kept: outlineMask when neither has a problem, else
/// empty (and empty without an outline).
std::vector<std::string> outlineProblems(const SceneOptions& o, std::vector<std::uint8_t>* kept) {
  using L = OptionLimits;
  kept->clear();
  const OutlineOptions& outline = o.outline;
  if (outline.shape == OutlineOptions::Shape::kNone) return {};
  Problems problems;
  if (outline.shape == OutlineOptions::Shape::kCircle) {
    problems.positive("outline.circle.radius", outline.radius_m, L::kMaxClothSide_m);
    if (!outline.center_m.allFinite() || outline.center_m.cwiseAbs().maxCoeff() > L::kMaxCoordinate_m) {
      problems.fail("outline.circle.center: must be finite and within +-" + valueText(L::kMaxCoordinate_m) + " m");
    }
  } else {
    if (outline.vertices_m.size() < 3 || outline.vertices_m.size() > kMaxOutlineVertices) {
      problems.fail("outline.polygon: " + std::to_string(outline.vertices_m.size()) + " corners: must be 3 to " +
                    std::to_string(kMaxOutlineVertices));
    }
    for (const Eigen::Vector2d& corner : outline.vertices_m) {
      if (corner.allFinite() && corner.cwiseAbs().maxCoeff() <= L::kMaxCoordinate_m) continue;
      problems.fail("outline.polygon: every corner must be finite and within +-" + valueText(L::kMaxCoordinate_m) +
                    " m");
      break;
    }
  }
  const bool sides_valid =
      std::isfinite(o.width_m) && o.width_m > 0.0 && std::isfinite(o.height_m) && o.height_m > 0.0;
  if (problems.size() != 0 || !sides_valid) return problems.take();
  std::vector<std::uint8_t> mask = outlineMask(o);
  // outlineMask keeps only corners of the triangles it keeps: one particle kept is one triangle kept.
  if (std::find(mask.begin(), mask.end(), 1) == mask.end()) {
    problems.fail("outline: keeps no triangle of the " + std::to_string(o.rows) + " x " + std::to_string(o.cols) +
                  " grid (it is in the cloth's own (u, v) metres, from particle (0, 0))");
    return problems.take();
  }
  *kept = std::move(mask);
  return {};
}

/// No pin on a particle the outline removes (`kept`: outlineMask; empty: nothing to check).
void validatePinsKept(const std::vector<std::uint8_t>& kept, const std::vector<int>& pinned, Problems& problems) {
  for (const int pin : pinned) {
    if (pin < static_cast<int>(kept.size()) && kept[static_cast<std::size_t>(pin)] == 0) {
      problems.fail("pins: particle " + std::to_string(pin) +
                    " is outside the outline (or in none of the triangles it keeps)");
      break;
    }
  }
}

}  // namespace

std::string windVelocityProblem(const Eigen::Vector3d& wind_m_per_s) {
  const double magnitude = wind_m_per_s.norm();
  if (wind_m_per_s.allFinite() && magnitude <= OptionLimits::kMaxWindSpeed_m_per_s) return "";
  std::ostringstream out;
  out << "magnitude " << magnitude << " m/s: must be finite and at most " << OptionLimits::kMaxWindSpeed_m_per_s
      << " m/s";
  return out.str();
}

std::string textLengthProblem(const std::string& field, const std::string& value) {
  if (value.size() <= OptionLimits::kMaxTextChars) return "";
  return field + ": " + std::to_string(value.size()) + " characters: at most " +
         std::to_string(OptionLimits::kMaxTextChars);
}

std::string exactNumberText(double value, int fewest_digits) {
  constexpr int kRoundTripDigits = 17;  // std::numeric_limits<double>::max_digits10: always enough
  char text[32];
  for (int digits = std::clamp(fewest_digits, 1, kRoundTripDigits); digits <= kRoundTripDigits; ++digits) {
    std::snprintf(text, sizeof(text), "%.*g", digits, value);
    const double read = std::strtod(text, nullptr);
    if (read == value && std::signbit(read) == std::signbit(value)) break;
  }
  return text;
}

std::vector<std::string> validateFrameCollider(const FrameCollider& collider) {
  Problems problems;
  checkFrameCollider(collider, "", problems);
  return problems.take();
}

std::vector<std::string> validateSceneOptions(const SceneOptions& o) {
  using L = OptionLimits;
  Problems problems;
  if (o.name.empty()) problems.fail("name is empty: a scene needs a name");
  // A too-long string is reported by its length (later checks quote at most a cut excerpt of it).
  const auto checkText = [&](const std::string& field, const std::string& value) {
    const std::string problem = textLengthProblem(field, value);
    if (!problem.empty()) problems.fail(problem);
  };
  checkText("name", o.name);
  checkText("texture", o.texture);
  if (o.pins.size() > L::kMaxPinSelectors) {
    problems.fail("pins: " + std::to_string(o.pins.size()) + " selectors: at most " +
                  std::to_string(L::kMaxPinSelectors));
    return problems.take();
  }
  for (std::size_t i = 0; i < o.pins.size(); ++i) checkText("pins[" + std::to_string(i) + "]", o.pins[i]);
  problems.inRange("rows", o.rows, L::kMinGridSide, L::kMaxGridSide);
  problems.inRange("cols", o.cols, L::kMinGridSide, L::kMaxGridSide);
  // Every check from here on may form rows x cols: the pins' indices, the outline's mask, a material's
  // kept area. Past the limits that product overflows an int (100000 x 100000) or allocates gigabytes
  // (an edge of 2e9 pins: bad_alloc out of validation, std::terminate at the node's start-up), so a grid
  // outside them is reported with nothing that depends on it.
  if (!gridSidesInRange(o.rows, o.cols)) return problems.take();
  problems.positive("width", o.width_m, L::kMaxClothSide_m);
  problems.positive("height", o.height_m, L::kMaxClothSide_m);
  problems.finiteVector("origin", o.origin_m, L::kMaxCoordinate_m);
  problems.unitVector("u_axis", o.u_axis);
  problems.unitVector("v_axis", o.v_axis);
  if (o.u_axis.allFinite() && o.v_axis.allFinite() && std::abs(o.u_axis.dot(o.v_axis)) > kUnitTolerance) {
    problems.fail("u_axis and v_axis: must be orthogonal");
  }
  problems.finiteVector("gravity", o.gravity_m_per_s2, L::kMaxAcceleration_m_per_s2);
  if (o.compression_model == CompressionModel::kBuckling && !o.has_material) {
    problems.fail("compression_model = buckling: needs a material (its bending_rigidity): give `material`, or "
                  "use compression_model = linear");
  }
  if (o.bend_model == BendModel::kCurvature && !o.has_material) {
    problems.fail("bend_model = curvature: needs a material (its bending_rigidity): give `material`, or use "
                  "bend_model = springs");
  }
  // The outline is checked before a material derives its mass from the area the outline keeps: a bad
  // outline keeps none, and its reason, not a mass of 0, is what to report.
  std::vector<std::uint8_t> kept;
  const std::vector<std::string> outline_problems = outlineProblems(o, &kept);
  // With a material, mass and springs are derived for this grid: their limits are checked on what it
  // gives, and named as its.
  bool constants_known = true;
  std::string derived_prefix;
  SceneOptions resolved;
  if (o.has_material) {
    const std::vector<std::string> material_problems = validateMaterial(o.material);
    for (const std::string& problem : material_problems) problems.fail(problem);
    const bool grid_valid = std::isfinite(o.width_m) && o.width_m > 0.0 && std::isfinite(o.height_m) &&
                            o.height_m > 0.0 && o.gravity_m_per_s2.allFinite();
    constants_known = material_problems.empty() && grid_valid && outline_problems.empty();
    if (constants_known) resolved = resolveMaterial(o);
    derived_prefix = "material gives ";
  }
  const SceneOptions& constants = o.has_material ? resolved : o;
  const double structural_N_per_m = constants.springs[static_cast<int>(SpringKind::kStructural)].stiffness_N_per_m;
  if (o.has_material && constants_known && o.bend_model == BendModel::kSprings && structural_N_per_m < 0.0) {
    // The bend springs that give B at this spacing grow as 1 / h^4 and carry tension too (4 k_b): on a
    // fine enough grid they alone are stiffer in tension than the fabric.
    std::ostringstream out;
    out << "bend_model = springs: at this spacing the bend springs that give material.bending_rigidity would "
           "carry more tension than material.stretch_modulus (structural springs of "
        << structural_N_per_m << " N/m); use bend_model = curvature, or fewer particles";
    problems.fail(out.str());
    constants_known = false;
  }
  if (constants_known) {
    problems.inRange(derived_prefix + "mass", constants.mass_kg, L::kMinMass_kg, L::kMaxMass_kg);
    for (int k = 0; k < kSpringKindCount; ++k) {
      const std::string kind = derived_prefix + springKindName(static_cast<SpringKind>(k));
      problems.inRange(kind + "_stiffness", constants.springs[k].stiffness_N_per_m, 0.0, L::kMaxStiffnessN_per_m);
      problems.inRange(kind + "_damping", constants.springs[k].damping_N_s_per_m, 0.0, L::kMaxDampingN_s_per_m);
    }
  }
  problems.inRange("air_damping", o.air_damping_N_s_per_m, 0.0, L::kMaxDampingN_s_per_m);
  problems.finiteVector("wind", o.wind.velocity_m_per_s, L::kMaxWindSpeed_m_per_s);
  if (o.wind.velocity_m_per_s.allFinite() && !windVelocityProblem(o.wind.velocity_m_per_s).empty()) {
    std::ostringstream out;
    out << "wind = " << vectorText(o.wind.velocity_m_per_s) << ": " << windVelocityProblem(o.wind.velocity_m_per_s);
    problems.fail(out.str());
  }
  problems.inRange("wind_coefficient", o.wind.paper_coefficient_N_s_per_m, 0.0, L::kMaxWindCoefficient);
  problems.inRange("air_density", o.wind.air_density_kg_per_m3, 0.0, L::kMaxAirDensity_kg_per_m3);
  problems.inRange("drag_coefficient", o.wind.drag_coefficient, 0.0, L::kMaxWindCoefficient);
  problems.inRange("wind_gust_amplitude", o.wind.gust_amplitude, 0.0, L::kMaxGustAmplitude);
  problems.positive("wind_gust_period", o.wind.gust_period_s, L::kMaxPeriod_s);

  std::string pin_error;
  const std::vector<int> pinned = resolvePins(o.pins, o.rows, o.cols, &pin_error);
  if (!pin_error.empty()) problems.fail(pin_error);
  for (const std::string& problem : outline_problems) problems.fail(problem);
  validatePinsKept(kept, pinned, problems);
  problems.finiteVector("pin_motion_amplitude", o.pin_motion_amplitude_m, L::kMaxCoordinate_m);
  if (!o.pin_positions_m.empty() && pin_error.empty() && o.pin_positions_m.size() != pinned.size()) {
    problems.fail("pin_positions: " + std::to_string(o.pin_positions_m.size()) + " positions for " +
                  std::to_string(pinned.size()) + " pinned particles (one each, in increasing particle index)");
  }
  problems.inRange("pin_travel_time", o.pin_travel_time_s, 0.0, L::kMaxPeriod_s);
  for (std::size_t i = 0; i < o.pin_positions_m.size(); ++i) {
    problems.finiteVector("pin_positions[" + std::to_string(i) + "]", o.pin_positions_m[i], L::kMaxCoordinate_m);
  }
  problems.positive("pin_motion_period", o.pin_motion_period_s, L::kMaxPeriod_s);
  if (std::isfinite(o.pin_motion_period_s) && o.pin_motion_period_s > 0.0 && o.pin_motion_amplitude_m.allFinite()) {
    problems.speedAtMost("pin_motion_amplitude and pin_motion_period (|A| 2 pi / T)",
                         swingPeakSpeed_m_per_s(o.pin_motion_amplitude_m, o.pin_motion_period_s), L::kMaxPinSpeed_m_per_s);
  }
  const bool grid_valid = std::isfinite(o.width_m) && std::isfinite(o.height_m) && o.origin_m.allFinite() &&
                          o.u_axis.allFinite() && o.v_axis.allFinite();
  if (grid_valid && pin_error.empty() && std::isfinite(o.pin_travel_time_s) && o.pin_travel_time_s > 0.0) {
    std::ostringstream fields;
    fields << "pin_positions and pin_travel_time (" << kSmoothstepPeakRate << " x longest trip / time)";
    problems.speedAtMost(fields.str(),
                         pinTravelSpeed_m_per_s(o, pinned), L::kMaxPinSpeed_m_per_s);
  }

  for (std::size_t i = 0; i < o.colliders.planes.size(); ++i) {
    problems.unitVector(indexed("planes", i, "normal"), o.colliders.planes[i].normal);
    problems.inRange(indexed("planes", i, "offset"), o.colliders.planes[i].offset_m, -L::kMaxCoordinate_m,
                     L::kMaxCoordinate_m);
  }
  for (std::size_t i = 0; i < o.colliders.spheres.size(); ++i) {
    const SphereCollider& s = o.colliders.spheres[i];
    problems.finiteVector(indexed("spheres", i, "center"), s.center_m, L::kMaxCoordinate_m);
    problems.positive(indexed("spheres", i, "radius"), s.radius_m, L::kMaxClothSide_m);
    problems.finiteVector(indexed("spheres", i, "velocity"), s.velocity_m_per_s, L::kMaxColliderSpeed_m_per_s);
    problems.finiteVector(indexed("spheres", i, "amplitude"), s.oscillation_amplitude_m, L::kMaxCoordinate_m);
    problems.positive(indexed("spheres", i, "period"), s.oscillation_period_s, L::kMaxPeriod_s);
    if (std::isfinite(s.oscillation_period_s) && s.oscillation_period_s > 0.0 && s.oscillation_amplitude_m.allFinite() &&
        s.velocity_m_per_s.allFinite()) {
      problems.speedAtMost(indexed("spheres", i, "velocity, amplitude and period (|v| + |A| 2 pi / T)"),
                           s.velocity_m_per_s.norm() + swingPeakSpeed_m_per_s(s.oscillation_amplitude_m, s.oscillation_period_s),
                           L::kMaxColliderSpeed_m_per_s);
    }
  }
  for (std::size_t i = 0; i < o.colliders.boxes.size(); ++i) {
    const BoxCollider& b = o.colliders.boxes[i];
    problems.finiteVector(indexed("boxes", i, "min"), b.min_m, L::kMaxCoordinate_m);
    problems.finiteVector(indexed("boxes", i, "max"), b.max_m, L::kMaxCoordinate_m);
    if ((b.max_m - b.min_m).minCoeff() <= 0.0) problems.fail(indexed("boxes", i, "max") + ": must exceed min on every axis");
  }
  if (o.colliders.frames.size() > L::kMaxFrameColliders) {
    problems.fail("frame_colliders: " + std::to_string(o.colliders.frames.size()) + " colliders: at most " +
                  std::to_string(L::kMaxFrameColliders));
  }
  for (std::size_t i = 0; i < o.colliders.frames.size(); ++i) {
    checkFrameCollider(o.colliders.frames[i], "frame_colliders[" + std::to_string(i) + "].", problems);
  }
  problems.inRange("contact_depth", o.contact.depth_m, 0.0, L::kMaxContactDepth_m);
  problems.inRange("restitution", o.contact.restitution, 0.0, 1.0);
  problems.inRange("friction", o.contact.friction, 0.0, L::kMaxFriction);
  problems.inRange("self_collision_thickness", o.self_collision.thickness_m, 0.0, L::kMaxSelfCollisionThickness_m);
  problems.inRange("self_collision_friction", o.self_collision.friction, 0.0, L::kMaxFriction);
  problems.inRange("grasp_stiffness", o.grasp_stiffness_N_per_m, 0.0, L::kMaxStiffnessN_per_m);
  problems.inRange("grasp_damping", o.grasp_damping_N_s_per_m, 0.0, L::kMaxDampingN_s_per_m);
  problems.inRange("sleep_speed", o.sleep_speed_m_per_s, 0.0, L::kMaxSleepSpeed_m_per_s);
  if (!o.autoSubsteps() && (o.substeps < 1 || o.substeps > L::kMaxSubsteps)) {
    problems.fail("substeps = " + std::to_string(o.substeps) + ": must be " +
                  std::to_string(SceneOptions::kAutoSubsteps) + " (" + kAutoSubstepsName + ") or in [1, " +
                  std::to_string(L::kMaxSubsteps) + "]");
  }
  problems.inRange("solver_tolerance", o.solver.tolerance, L::kMinSolverTolerance, L::kMaxSolverTolerance);
  problems.inRange("solver_max_iterations", o.solver.max_iterations, 1, L::kMaxSolverIterations);
  problems.inRange("threads", o.threads, 1, L::kMaxThreads);
  problems.inRange("frame_rate", o.frame_rate_hz, L::kMinFrameRateHz, L::kMaxFrameRateHz);
  validateCameras(o.cameras, problems);
  return problems.take();
}

SceneOptions resolveMaterial(const SceneOptions& options) {
  // retune and restore resolve before they compare the grid: a grid outside the limits would have its
  // outline's mask allocated (rows x cols bytes) before it was refused.
  if (!options.has_material || !gridSidesInRange(options.rows, options.cols)) return options;
  SceneOptions resolved = options;
  const MaterialConstants constants =
      materialConstants(options.material, options.bend_model, options.rows, options.cols, options.width_m,
                        options.height_m, options.gravity_m_per_s2.norm());
  resolved.mass_kg = constants.mass_kg;
  if (options.outline.shape != OutlineOptions::Shape::kNone) {  // the area the outline keeps
    resolved.mass_kg = options.material.areal_density_kg_per_m2 *
                       keptArea(options.rows, options.cols, options.width_m / (options.cols - 1),
                                options.height_m / (options.rows - 1), outlineMask(options))
                           .sum();
  }
  resolved.springs = constants.springs;
  if (options.compression_model == CompressionModel::kBuckling) {
    resolved.springs[static_cast<int>(SpringKind::kStructural)].buckling_N_m3 = constants.structural_buckling_N_m3;
    resolved.springs[static_cast<int>(SpringKind::kShear)].buckling_N_m3 = constants.shear_buckling_N_m3;
  }
  return resolved;
}

void buildCurvatureBending(const SceneOptions& o, CurvatureBending* curvature, const std::vector<std::uint8_t>& active) {
  if (!o.has_material || o.bend_model != BendModel::kCurvature) {
    curvature->clear();
    return;
  }
  curvature->build(o.rows, o.cols, o.width_m / (o.cols - 1), o.height_m / (o.rows - 1),
                   o.material.bending_rigidity_N_m, o.material.damping_s, active);
}

namespace {

/// The polygon's edges (by their first corner i; the edge runs from corner i to the corner before it) whose
/// v range, widened by `tolerance`, holds `v`, in corner order: the only edges that can cross the line of
/// particles at v or pass within `tolerance` of one, so insidePolygon over them decides as over all edges.
/// Per grid row, this takes a polygon of thousands of corners from seconds to milliseconds at 256 x 256.
std::vector<std::size_t> edgesNearRow(const std::vector<Eigen::Vector2d>& polygon, double v, double tolerance) {
  std::vector<std::size_t> edges;
  for (std::size_t i = 0, j = polygon.size() - 1; i < polygon.size(); j = i++) {
    const double low = std::min(polygon[i].y(), polygon[j].y()) - tolerance;
    const double high = std::max(polygon[i].y(), polygon[j].y()) + tolerance;
    if (v >= low && v <= high) edges.push_back(i);
  }
  return edges;
}

/// Even-odd rule over `edges` (edgesNearRow of the point's row); a point within `tolerance` of an edge
/// counts as inside.
bool insidePolygon(const std::vector<Eigen::Vector2d>& polygon, const std::vector<std::size_t>& edges,
                   const Eigen::Vector2d& point, double tolerance) {
  bool inside = false;
  for (const std::size_t i : edges) {
    const std::size_t j = i == 0 ? polygon.size() - 1 : i - 1;
    const Eigen::Vector2d& a = polygon[i];
    const Eigen::Vector2d& b = polygon[j];
    const Eigen::Vector2d edge = b - a;
    // A zero-length edge (a repeated corner, which validation refuses) divides by the smallest normal
    // double instead of zero: its nearest point is then its one point.
    const double t = std::clamp(
        (point - a).dot(edge) / std::max(edge.squaredNorm(), std::numeric_limits<double>::min()), 0.0, 1.0);
    if ((a + t * edge - point).norm() <= tolerance) return true;
    if ((a.y() > point.y()) != (b.y() > point.y()) &&
        point.x() < (b.x() - a.x()) * (point.y() - a.y()) / (b.y() - a.y()) + a.x()) {
      inside = !inside;
    }
  }
  return inside;
}

}  // namespace

std::vector<std::uint8_t> outlineMask(const SceneOptions& o) {
  if (o.outline.shape == OutlineOptions::Shape::kNone) return {};
  constexpr double kOnTheLine = 1e-9;  // of the spacing: a particle on the outline is inside
  const double du_m = o.width_m / (o.cols - 1);
  const double dv_m = o.height_m / (o.rows - 1);
  const double tolerance_m = kOnTheLine * std::min(du_m, dv_m);
  std::vector<std::uint8_t> inside(static_cast<std::size_t>(o.rows) * o.cols, 0);
  const bool circle = o.outline.shape == OutlineOptions::Shape::kCircle;
  for (int r = 0; r < o.rows; ++r) {
    const std::vector<std::size_t> edges = circle ? std::vector<std::size_t>()
                                                  : edgesNearRow(o.outline.vertices_m, r * dv_m, tolerance_m);
    for (int c = 0; c < o.cols; ++c) {
      const Eigen::Vector2d uv(c * du_m, r * dv_m);
      const bool in = circle ? (uv - o.outline.center_m).norm() <= o.outline.radius_m + tolerance_m
                             : insidePolygon(o.outline.vertices_m, edges, uv, tolerance_m);
      inside[static_cast<std::size_t>(r) * o.cols + c] = in ? 1 : 0;
    }
  }
  // A triangle is kept when its three corners are inside; a particle inside that is a corner of none (the
  // tip of a polygon's sharp corner between two grid lines) would be cloth without area: a material gives
  // it no mass, and the guard's k / m for it was infinite (the scene rolled back and reset for good). It is
  // removed as the particles outside are, so the particles, springs and triangles kept are one set.
  const Eigen::VectorXd area_m2 = keptArea(o.rows, o.cols, du_m, dv_m, inside);
  std::vector<std::uint8_t> mask(inside.size(), 0);
  for (std::size_t p = 0; p < mask.size(); ++p) mask[p] = area_m2[static_cast<Eigen::Index>(p)] > 0.0 ? 1 : 0;
  return mask;
}

double airDampingPerParticle_N_s_per_m(const SceneOptions& o) {
  if (!o.has_material) return o.air_damping_N_s_per_m;
  const double particle_area_m2 = o.width_m * o.height_m / (static_cast<double>(o.rows) * o.cols);
  return o.air_damping_N_s_per_m * particle_area_m2 / kPaperParticleArea_m2;
}

double paperWindCoefficientPerTriangle_N_s_per_m(const SceneOptions& o) {
  if (!o.has_material) return o.wind.paper_coefficient_N_s_per_m;
  const double triangle_area_m2 = o.width_m * o.height_m / (2.0 * (o.rows - 1) * (o.cols - 1));
  return o.wind.paper_coefficient_N_s_per_m * triangle_area_m2 / kPaperTriangleArea_m2;
}

std::vector<int> resolvePins(const std::vector<std::string>& selectors, int rows, int cols, std::string* error) {
  // Indices are formed in 64 bits and the sides checked first: an int holds every index of a grid within
  // the limits (512 x 512), and an edge of a larger one would allocate its length in indices.
  if (!gridSidesInRange(rows, cols)) {
    *error = "pins: cannot be resolved on a " + std::to_string(rows) + " x " + std::to_string(cols) +
             " grid (rows and cols must be in [" + std::to_string(OptionLimits::kMinGridSide) + ", " +
             std::to_string(OptionLimits::kMaxGridSide) + "])";
    return {};
  }
  const std::int64_t count = static_cast<std::int64_t>(rows) * cols;
  const auto index = [cols](std::int64_t row, std::int64_t col) { return static_cast<int>(row * cols + col); };
  std::vector<int> pins;
  const auto edge = [&](int first_row, int last_row, int first_col, int last_col) {
    for (int r = first_row; r <= last_row; ++r)
      for (int c = first_col; c <= last_col; ++c) pins.push_back(index(r, c));
  };
  for (const std::string& selector : selectors) {
    if (selector == "top_left") {
      pins.push_back(0);
    } else if (selector == "top_right") {
      pins.push_back(cols - 1);
    } else if (selector == "bottom_left") {
      pins.push_back(index(rows - 1, 0));
    } else if (selector == "bottom_right") {
      pins.push_back(index(rows - 1, cols - 1));
    } else if (selector == "top_edge") {
      edge(0, 0, 0, cols - 1);
    } else if (selector == "bottom_edge") {
      edge(rows - 1, rows - 1, 0, cols - 1);
    } else if (selector == "left_edge") {
      edge(0, rows - 1, 0, 0);
    } else if (selector == "right_edge") {
      edge(0, rows - 1, cols - 1, cols - 1);
    } else {
      std::size_t used = 0;
      long long particle = -1;
      try {
        particle = std::stoll(selector, &used);
      } catch (const std::exception&) {
        used = 0;
      }
      if (used != selector.size() || selector.empty() || particle < 0 || particle >= count) {
        const std::string shown = selector.size() > kMaxQuotedSelectorChars
                                      ? selector.substr(0, kMaxQuotedSelectorChars) + "..."
                                      : selector;
        *error = "pins: '" + shown +
                 "' is neither a corner/edge name (top_left, top_right, bottom_left, bottom_right, top_edge, "
                 "bottom_edge, left_edge, right_edge) nor a particle index in [0, " +
                 std::to_string(count - 1) + "]";
        return {};
      }
      pins.push_back(static_cast<int>(particle));
    }
  }
  std::sort(pins.begin(), pins.end());
  pins.erase(std::unique(pins.begin(), pins.end()), pins.end());
  return pins;
}

std::string clothGridDifference(const SceneOptions& a, const SceneOptions& b) {
  if (a.rows != b.rows || a.cols != b.cols) return "rows, cols";
  if (a.width_m != b.width_m || a.height_m != b.height_m) return "width, height";
  if (a.origin_m != b.origin_m || a.u_axis != b.u_axis || a.v_axis != b.v_axis) return "origin, u_axis, v_axis";
  if (a.pins != b.pins) return "pins";
  if (a.pin_positions_m != b.pin_positions_m || a.pin_travel_time_s != b.pin_travel_time_s) {
    return "pin_positions, pin_travel_time";
  }
  if (a.mass_kg != b.mass_kg || a.has_material != b.has_material) return "mass, material";
  if (!sameOutline(a.outline, b.outline)) return "outline";
  return "";
}

bool sameClothGrid(const SceneOptions& a, const SceneOptions& b) { return clothGridDifference(a, b).empty(); }

}  // namespace cloth_sim::core
