// Steps a 32 x 32 hanging cloth for one simulated second with cloth_sim's core and prints where it hangs.
#include <cloth_sim/core/simulation.h>

#include <cstdio>

int main() {
  cloth_sim::core::SceneOptions options;  // the hanging scene: 1 m square, 0.5 kg, two top corners pinned
  options.rows = 32;
  options.cols = 32;
  cloth_sim::core::Simulation simulation(options);
  for (int frame = 0; frame < 50; ++frame) simulation.advanceFrame();  // 50 frames of 0.02 s
  const Eigen::Vector3d centre = simulation.state().positions_m.rowwise().mean();
  std::printf("after %.2f s the cloth's centre is at z = %.3f m (max strain %.3f)\n", simulation.state().time_s,
              centre.z(), simulation.maxStructuralStrain());
  return centre.allFinite() ? 0 : 1;
}
