// cloth_bench --terms: the cost per frame of a scene with each of its force and collider terms switched off in
// turn, and how much that changes the cloth (a term whose removal changes nothing is carried but unused).
#include "accuracy_modes.h"

#include <algorithm>
#include <functional>
#include <iomanip>
#include <iostream>
#include <sstream>

namespace cloth_sim::bench {

namespace {

/// Switching a term off changes positions by less than this (m, at any particle in any frame): it is unused.
constexpr double kUnusedTermChange_m = 1e-9;

struct Term {
  std::string name;
  std::function<void(core::SceneOptions*)> switch_off;
};

/// A material scene's own terms: its springs and bending come from the material's moduli for the grid
/// (core::resolveMaterial), which would give them back if a spring kind were switched off, so these switch
/// off the moduli that may be zero (the stretch modulus may not: without it there is no cloth).
void addMaterialTerms(const core::SceneOptions& scene, std::vector<Term>* terms) {
  const core::MaterialOptions& material = scene.material;
  if (material.shear_modulus_N_per_m > 0.0) {
    terms->push_back({"shear (material)", [](core::SceneOptions* s) { s->material.shear_modulus_N_per_m = 0.0; }});
  }
  if (material.bending_rigidity_N_m > 0.0) {
    terms->push_back({std::string("bending (material, ") + core::bendModelName(scene.bend_model) + ")",
                      [](core::SceneOptions* s) { s->material.bending_rigidity_N_m = 0.0; }});
  }
  if (material.damping_s > 0.0) {
    terms->push_back({"damping (material)", [](core::SceneOptions* s) { s->material.damping_s = 0.0; }});
  }
}

/// The force and collider terms the scene has switched on.
std::vector<Term> termsOf(const core::SceneOptions& scene) {
  std::vector<Term> terms;
  if (scene.has_material) addMaterialTerms(scene, &terms);
  for (int k = 0; k < core::kSpringKindCount && !scene.has_material; ++k) {
    const core::SpringOptions& spring = scene.springs[k];
    if (!spring.enabled || (spring.stiffness_N_per_m == 0.0 && spring.damping_N_s_per_m == 0.0)) continue;
    const std::string kind = core::springKindName(static_cast<core::SpringKind>(k));
    terms.push_back({kind + " springs", [k](core::SceneOptions* s) { s->springs[k].enabled = false; }});
    if (spring.damping_N_s_per_m > 0.0) {
      terms.push_back({kind + " damping", [k](core::SceneOptions* s) { s->springs[k].damping_N_s_per_m = 0.0; }});
    }
  }
  if (!scene.gravity_m_per_s2.isZero()) {
    terms.push_back({"gravity", [](core::SceneOptions* s) { s->gravity_m_per_s2.setZero(); }});
  }
  if (scene.air_damping_N_s_per_m > 0.0) {
    terms.push_back({"air damping", [](core::SceneOptions* s) { s->air_damping_N_s_per_m = 0.0; }});
  }
  if (scene.wind_enabled) terms.push_back({"wind", [](core::SceneOptions* s) { s->wind_enabled = false; }});
  if (scene.self_collision.enabled) {
    terms.push_back({"self-collision", [](core::SceneOptions* s) { s->self_collision.enabled = false; }});
  }
  for (std::size_t i = 0; i < scene.colliders.planes.size(); ++i) {
    terms.push_back({"plane " + std::to_string(i), [i](core::SceneOptions* s) {
                       s->colliders.planes.erase(s->colliders.planes.begin() + static_cast<long>(i));
                     }});
  }
  for (std::size_t i = 0; i < scene.colliders.spheres.size(); ++i) {
    terms.push_back({"sphere " + std::to_string(i), [i](core::SceneOptions* s) {
                       s->colliders.spheres.erase(s->colliders.spheres.begin() + static_cast<long>(i));
                     }});
  }
  for (std::size_t i = 0; i < scene.colliders.boxes.size(); ++i) {
    terms.push_back({"box " + std::to_string(i), [i](core::SceneOptions* s) {
                       s->colliders.boxes.erase(s->colliders.boxes.begin() + static_cast<long>(i));
                     }});
  }
  return terms;
}

/// CPU ms per frame, best of a few runs.
double msPerFrame(const core::SceneOptions& scene, int frames, double min_timing_s, SpanRun* first) {
  *first = simulateSpan(scene, frames, true, false);
  double best_s = first->cpu_s, total_s = first->cpu_s;
  for (int runs = 1; runs < kMaxTimingRuns && total_s < min_timing_s; ++runs) {
    const double cpu_s = simulateSpan(scene, frames, false, false).cpu_s;
    best_s = std::min(best_s, cpu_s);
    total_s += cpu_s;
  }
  return best_s * kMillisecondsPerSecond / std::max(1, first->frames_run);
}

}  // namespace

int runTerms(const ToolOptions& options, const core::SceneOptions& scene) {
  const int frames = frameCount(scene, options.seconds);
  SpanRun baseline;
  const double baseline_ms = msPerFrame(scene, frames, options.min_timing_s, &baseline);
  std::cout << "terms: scene " << scene.name << " " << gridText(scene.rows, scene.cols) << ", "
            << core::integratorName(scene.integrator) << " x " << substepsText(scene) << ", " << frames
            << " frames: " << formatNumber(baseline_ms) << " ms CPU per frame with every term\n";
  std::cout << std::left << std::setw(20) << "switched off" << std::right << std::setw(12) << "ms/frame" << std::setw(12)
            << "saves ms" << std::setw(16) << "max change m" << "  used\n";
  std::ostringstream csv;
  csv << std::setprecision(6)
      << "scene,term,ms_per_frame_all,ms_per_frame_without,max_change_m,rms_change_m,used,frames_run,stopped\n";
  if (baseline.diverged) {
    std::cout << "note: the scene as shipped stopped at " << baseline.stopped << "\n";
  }
  for (const Term& term : termsOf(scene)) {
    core::SceneOptions without = scene;
    term.switch_off(&without);
    SpanRun run;
    const double ms = msPerFrame(without, frames, options.min_timing_s, &run);
    const TrajectoryError change = compareTrajectories(run.trajectory, baseline.trajectory);
    // A run that stopped early (the cloth fell away without gravity's counterpart, say) changed things.
    const bool used = !(change.max_m < kUnusedTermChange_m) || run.frames_run != baseline.frames_run;
    std::cout << std::left << std::setw(20) << term.name << std::right << std::setw(12) << formatNumber(ms)
              << std::setw(12) << formatNumber(baseline_ms - ms) << std::setw(16) << formatNumber(change.max_m)
              << "  " << (used ? "yes" : "NO: switching it off changes nothing")
              << (run.diverged ? " (without it: " + run.stopped + ")" : "") << "\n";
    csv << csvField(scene.name) << "," << csvField(term.name) << "," << baseline_ms << "," << ms << "," << change.max_m << ","
        << change.rms_m << "," << (used ? 1 : 0) << "," << run.frames_run << "," << csvField(run.stopped) << "\n";
  }
  if (!writeCsvText(options, csv.str())) return kExitRunFailed;
  return kExitOk;
}

}  // namespace cloth_sim::bench
