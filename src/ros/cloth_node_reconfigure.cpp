// cloth_node's dynamic_reconfigure: every value checked as it arrives (the .cfg gives no ranges), mapped
// onto the scene's options and applied through Simulation::retune, and the ranges and current values
// published back. Declared in cloth_node.h.
#include "cloth_sim/ros/cloth_node.h"

#include <dynamic_reconfigure/Config.h>

#include <cmath>
#include <cstddef>
#include <iterator>
#include <sstream>
#include <string>

namespace cloth_sim {

namespace {

/// Each spring kind's two sliders: the one place the .cfg's field names meet SceneOptions::springs.
struct SpringSliders {
  core::SpringKind kind;
  double cloth_sim::ClothConfig::*stiffness_N_per_m;
  double cloth_sim::ClothConfig::*damping_N_s_per_m;
};
constexpr SpringSliders kSpringSliders[] = {
    {core::SpringKind::kStructural, &cloth_sim::ClothConfig::structural_stiffness,
     &cloth_sim::ClothConfig::structural_damping},
    {core::SpringKind::kShear, &cloth_sim::ClothConfig::shear_stiffness, &cloth_sim::ClothConfig::shear_damping},
    {core::SpringKind::kBend, &cloth_sim::ClothConfig::bend_stiffness, &cloth_sim::ClothConfig::bend_damping}};
static_assert(std::size(kSpringSliders) == core::kSpringKindCount, "a pair of sliders for every spring kind");

}  // namespace

void ClothNode::onReconfigure(cloth_sim::ClothConfig& config, std::uint32_t) {
  // The .cfg gives no ranges, so dynamic_reconfigure's server clamps nothing (it clamped -5 to 0 and inf
  // to 1e4 silently, and let NaN through): every value arrives as sent and is checked here, and a
  // refused change keeps the whole previous configuration.
  const std::string invalid = invalidReconfigureValue(config);
  if (!invalid.empty()) {
    ROS_WARN("cloth_node: reconfigure refused: %s; the previous values stay", invalid.c_str());
    fillConfig(&config);
    reconfigure_wind_ = Eigen::Vector3d(config.wind_x, config.wind_y, config.wind_z);
    return;
  }
  core::SceneOptions options = simulation_->options();
  for (const SpringSliders& sliders : kSpringSliders) {
    core::SpringOptions& spring = options.springs[static_cast<std::size_t>(sliders.kind)];
    spring.stiffness_N_per_m = config.*sliders.stiffness_N_per_m;
    spring.damping_N_s_per_m = config.*sliders.damping_N_s_per_m;
  }
  options.air_damping_N_s_per_m = config.air_damping;
  // The wind sliders count when they moved: the sliders do not follow a ~wind (they would have to be set on
  // the parameter server from the frame thread, which roscpp blocks for good while the master is down), so
  // comparing them with the wind in force would undo a ~wind at the next reconfigure of anything. They
  // count too when the request changes no slider at all: a client set a slider to the value it shows
  // (`dynparam set ... wind_y 0` while a ~wind blows and the slider reads 0), and means that value.
  const Eigen::Vector3d wind(config.wind_x, config.wind_y, config.wind_z);
  const bool wind_moved =
      wind != reconfigure_wind_ || (wind != simulation_->inputs().wind_m_per_s && changesNoSlider(config));
  std::string error;
  if (!core::parseIntegratorName(config.integrator, &options.integrator)) {
    error = "integrator '" + config.integrator + "' is unknown";
  }
  options.substeps = config.substeps;
  options.self_collision.enabled = config.self_collision;
  options.self_collision.thickness_m = config.self_collision_thickness;
  options.self_collision.friction = config.self_collision_friction;
  options.solver.tolerance = config.solver_tolerance;
  options.solver.max_iterations = config.solver_max_iterations;
  if (error.empty() && !core::parsePreconditionerName(config.solver_preconditioner, &options.solver.preconditioner)) {
    error = "solver_preconditioner = '" + config.solver_preconditioner + "': must be one of " +
            core::preconditionerNameList();
  }
  if (!error.empty() || !simulation_->retune(options, &error)) {
    ROS_WARN("cloth_node: reconfigure refused: %s; the previous values stay", error.c_str());
  } else if (wind_moved) {
    simulation_->setWindVelocity(wind);  // the wind is an input, not an option: retune leaves it alone
  }
  // Answer and publish what is in force (a refused change is not; a ~wind is), so the sliders follow.
  fillConfig(&config);
  reconfigure_wind_ = Eigen::Vector3d(config.wind_x, config.wind_y, config.wind_z);
}

std::string ClothNode::invalidReconfigureValue(const cloth_sim::ClothConfig& config) const {
  const std::pair<const char*, double> numbers[] = {
      {"structural_stiffness", config.structural_stiffness}, {"structural_damping", config.structural_damping},
      {"shear_stiffness", config.shear_stiffness},           {"shear_damping", config.shear_damping},
      {"bend_stiffness", config.bend_stiffness},             {"bend_damping", config.bend_damping},
      {"air_damping", config.air_damping},                   {"wind_x", config.wind_x},
      {"wind_y", config.wind_y},                             {"wind_z", config.wind_z},
      {"solver_tolerance", config.solver_tolerance},         {"self_collision_thickness", config.self_collision_thickness},
      {"self_collision_friction", config.self_collision_friction}};
  for (const auto& [field, value] : numbers) {
    if (!std::isfinite(value)) return std::string(field) + " = " + std::to_string(value) + ": must be finite";
  }
  // The sliders are the wind's components; its magnitude is what ~wind and the scene files bound.
  const Eigen::Vector3d wind(config.wind_x, config.wind_y, config.wind_z);
  const std::string problem = core::windVelocityProblem(wind);
  if (wind != reconfigure_wind_ && !problem.empty()) {
    std::ostringstream out;
    out << "wind_x, wind_y, wind_z = (" << wind.x() << ", " << wind.y() << ", " << wind.z() << "): " << problem;
    return out.str();
  }
  return "";
}

void ClothNode::publishReconfigureRanges() {
  // The server clamps to the .cfg's ranges, which are left open; the ranges shown to rqt_reconfigure and
  // the clients (parameter_descriptions) are set here from OptionLimits, the ones validation enforces.
  using L = core::OptionLimits;
  cloth_sim::ClothConfig low = cloth_sim::ClothConfig::__getMin__();
  cloth_sim::ClothConfig high = cloth_sim::ClothConfig::__getMax__();
  for (double* field : {&low.structural_stiffness, &low.shear_stiffness, &low.bend_stiffness, &low.structural_damping,
                        &low.shear_damping, &low.bend_damping, &low.air_damping}) {
    *field = 0.0;
  }
  high.structural_stiffness = high.shear_stiffness = high.bend_stiffness = L::kMaxStiffnessN_per_m;
  high.structural_damping = high.shear_damping = high.bend_damping = high.air_damping = L::kMaxDampingN_s_per_m;
  low.wind_x = low.wind_y = low.wind_z = -L::kMaxWindSpeed_m_per_s;
  high.wind_x = high.wind_y = high.wind_z = L::kMaxWindSpeed_m_per_s;
  low.substeps = core::SceneOptions::kAutoSubsteps;  // 0: auto, as the scenes use it
  high.substeps = L::kMaxSubsteps;
  low.solver_tolerance = L::kMinSolverTolerance;
  high.solver_tolerance = L::kMaxSolverTolerance;
  low.self_collision_thickness = 0.0;
  high.self_collision_thickness = L::kMaxSelfCollisionThickness_m;
  low.self_collision_friction = 0.0;
  high.self_collision_friction = L::kMaxFriction;
  low.solver_max_iterations = 1;
  high.solver_max_iterations = L::kMaxSolverIterations;
  reconfigure_->setConfigMin(low);
  reconfigure_->setConfigMax(high);
}

void ClothNode::fillConfig(cloth_sim::ClothConfig* config) const {
  const core::SceneOptions& o = simulation_->options();
  cloth_sim::ClothConfig& c = *config;
  for (const SpringSliders& sliders : kSpringSliders) {
    const core::SpringOptions& spring = o.springs[static_cast<std::size_t>(sliders.kind)];
    c.*sliders.stiffness_N_per_m = spring.stiffness_N_per_m;
    c.*sliders.damping_N_s_per_m = spring.damping_N_s_per_m;
  }
  c.air_damping = o.air_damping_N_s_per_m;
  const Eigen::Vector3d& wind = simulation_->inputs().wind_m_per_s;
  c.wind_x = wind.x();
  c.wind_y = wind.y();
  c.wind_z = wind.z();
  c.integrator = core::integratorName(o.integrator);
  c.substeps = o.substeps;
  c.solver_tolerance = o.solver.tolerance;
  c.solver_max_iterations = o.solver.max_iterations;
  c.solver_preconditioner = core::preconditionerName(o.solver.preconditioner);
  c.self_collision = o.self_collision.enabled;
  c.self_collision_thickness = o.self_collision.thickness_m;
  c.self_collision_friction = o.self_collision.friction;
}

void ClothNode::pushConfig() {
  if (!reconfigure_) return;
  // From the generated defaults, not default-constructed: the generated class leaves its group's copy of
  // each field uninitialised, and updateConfig copies it (UBSan: a bool loaded as 19, under make sanitize).
  cloth_sim::ClothConfig config = cloth_sim::ClothConfig::__getDefault__();
  fillConfig(&config);
  reconfigure_wind_ = Eigen::Vector3d(config.wind_x, config.wind_y, config.wind_z);
  reconfigure_->updateConfig(config);
}

bool ClothNode::changesNoSlider(const cloth_sim::ClothConfig& config) const {
  cloth_sim::ClothConfig shown = cloth_sim::ClothConfig::__getDefault__();  // see pushConfig
  fillConfig(&shown);
  shown.wind_x = reconfigure_wind_.x();
  shown.wind_y = reconfigure_wind_.y();
  shown.wind_z = reconfigure_wind_.z();
  dynamic_reconfigure::Config requested, shown_message;
  config.__toMessage__(requested);
  shown.__toMessage__(shown_message);
  // The sliders' values only, not the groups' bookkeeping.
  return requested.bools == shown_message.bools && requested.ints == shown_message.ints &&
         requested.strs == shown_message.strs && requested.doubles == shown_message.doubles;
}

}  // namespace cloth_sim
