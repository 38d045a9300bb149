#include "cloth_sim/core/forces.h"

#include "cloth_sim/core/constants.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <limits>

namespace cloth_sim::core {

namespace {

/// Below this a spring or triangle has no usable direction, m (or m^2 for doubled areas).
constexpr double kDegenerateLength_m = 1e-6;
constexpr double kOneThird = 1.0 / 3.0;

}  // namespace

double springCompressionCap_N(const SpringOptions& options, double rest_length_m) {
  if (!(options.buckling_N_m3 > 0.0) || !(rest_length_m > 0.0)) return std::numeric_limits<double>::infinity();
  return options.buckling_N_m3 / (rest_length_m * rest_length_m * rest_length_m);
}

void accumulateSpringForces(const SpringSet& springs, const SpringOptions& options,
                            const Eigen::Matrix3Xd& positions_m, const Eigen::Matrix3Xd& velocities_m_per_s,
                            Eigen::Matrix3Xd& forces_N) {
  const double ks = options.stiffness_N_per_m;
  const double kd = options.damping_N_s_per_m;
  const std::size_t count = springs.size();
  for (std::size_t s = 0; s < count; ++s) {
    const int i = springs.first[s];
    const int j = springs.second[s];
    const Eigen::Vector3d d = positions_m.col(j) - positions_m.col(i);
    const double length_m = d.norm();
    if (length_m < kDegenerateLength_m) continue;
    const Eigen::Vector3d direction = d / length_m;
    const double separation_rate = (velocities_m_per_s.col(j) - velocities_m_per_s.col(i)).dot(direction);
    const double cap_N = springCompressionCap_N(options, springs.rest_length_m[s]);
    const double elastic_N = std::max(ks * (length_m - springs.rest_length_m[s]), -cap_N);
    const Eigen::Vector3d force_on_i = (elastic_N + kd * separation_rate) * direction;
    forces_N.col(i) += force_on_i;
    forces_N.col(j) -= force_on_i;
  }
}

void accumulateGravity(const Eigen::VectorXd& mass_kg, const Eigen::Vector3d& gravity_m_per_s2,
                       Eigen::Matrix3Xd& forces_N) {
  forces_N.noalias() += gravity_m_per_s2 * mass_kg.transpose();
}

void accumulateAirDamping(double damping_N_s_per_m, const Eigen::Matrix3Xd& velocities_m_per_s,
                          Eigen::Matrix3Xd& forces_N) {
  forces_N -= damping_N_s_per_m * velocities_m_per_s;
}

Eigen::Vector3d windVelocityAt(const WindOptions& options, double time_s) {
  if (options.gust_amplitude == 0.0) return options.velocity_m_per_s;
  return options.velocity_m_per_s * (1.0 + options.gust_amplitude * periodicSine(time_s, options.gust_period_s));
}

void accumulateWindForces(const std::vector<int>& triangles, const WindOptions& options,
                          const Eigen::Vector3d& wind_velocity_m_per_s, const Eigen::Matrix3Xd& positions_m,
                          const Eigen::Matrix3Xd& velocities_m_per_s, Eigen::Matrix3Xd& forces_N) {
  const std::size_t count = triangles.size() / 3;
  const Eigen::Vector3d paper_force_N = options.paper_coefficient_N_s_per_m * wind_velocity_m_per_s;
  const double drag_factor = 0.5 * options.air_density_kg_per_m3 * options.drag_coefficient;
  for (std::size_t t = 0; t < count; ++t) {
    const int a = triangles[3 * t];
    const int b = triangles[3 * t + 1];
    const int c = triangles[3 * t + 2];
    const Eigen::Vector3d doubled_area_normal =
        (positions_m.col(b) - positions_m.col(a)).cross(positions_m.col(c) - positions_m.col(a));
    const double doubled_area_m2 = doubled_area_normal.norm();
    if (doubled_area_m2 < kDegenerateLength_m * kDegenerateLength_m) continue;
    const Eigen::Vector3d normal = doubled_area_normal / doubled_area_m2;
    Eigen::Vector3d share_N;
    if (options.model == WindModel::kPaper) {
      share_N = kOneThird * paper_force_N.dot(normal) * normal;
    } else {
      const Eigen::Vector3d mean_velocity =
          kOneThird * (velocities_m_per_s.col(a) + velocities_m_per_s.col(b) + velocities_m_per_s.col(c));
      const double normal_speed = (wind_velocity_m_per_s - mean_velocity).dot(normal);
      share_N = kOneThird * drag_factor * 0.5 * doubled_area_m2 * normal_speed * std::abs(normal_speed) * normal;
    }
    forces_N.col(a) += share_N;
    forces_N.col(b) += share_N;
    forces_N.col(c) += share_N;
  }
}

void accumulateGraspForces(const std::vector<Grasp>& grasps, const Eigen::Matrix3Xd& positions_m,
                           const Eigen::Matrix3Xd& velocities_m_per_s, Eigen::Matrix3Xd& forces_N) {
  for (const Grasp& grasp : grasps) {
    const int i = grasp.particle;
    forces_N.col(i) += grasp.stiffness_N_per_m * (grasp.target_m - positions_m.col(i)) -
                       grasp.damping_N_s_per_m * velocities_m_per_s.col(i) + grasp.extra_force_N;
  }
}

double springPotentialEnergy(const SpringSet& springs, const SpringOptions& options,
                             const Eigen::Matrix3Xd& positions_m) {
  double energy_J = 0.0;
  for (std::size_t s = 0; s < springs.size(); ++s) {
    const double stretch_m =
        (positions_m.col(springs.second[s]) - positions_m.col(springs.first[s])).norm() - springs.rest_length_m[s];
    const double ks = options.stiffness_N_per_m;
    const double cap_N = springCompressionCap_N(options, springs.rest_length_m[s]);
    if (ks * stretch_m < -cap_N) {
      // Past the cap the force is constant: the energy grows linearly from where the cap was reached.
      const double capped_m = cap_N / ks;
      energy_J += 0.5 * ks * capped_m * capped_m + cap_N * (-stretch_m - capped_m);
    } else {
      energy_J += 0.5 * ks * stretch_m * stretch_m;
    }
  }
  return energy_J;
}

double maxSpringStrain(const SpringSet& springs, const Eigen::Matrix3Xd& positions_m) {
  double strain = 0.0;
  for (std::size_t s = 0; s < springs.size(); ++s) {
    const double length_m = (positions_m.col(springs.second[s]) - positions_m.col(springs.first[s])).norm();
    strain = std::max(strain, (length_m - springs.rest_length_m[s]) / springs.rest_length_m[s]);
  }
  return strain;
}

}  // namespace cloth_sim::core
