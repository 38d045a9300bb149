// Writes a libFuzzer dictionary of the scene keys (sceneKeys(), so it never falls behind the parser) and
// the words their values take, one entry a line, to stdout.
#include "cloth_sim/core/integrators.h"
#include "cloth_sim/io/scene_file.h"

#include <cstdio>
#include <string>
#include <vector>

int main() {
  int entry = 0;
  const auto print = [&entry](const std::string& word) { std::printf("word_%d=\"%s\"\n", entry++, word.c_str()); };
  for (const std::string& key : cloth_sim::core::sceneKeys()) print(key + ": ");
  for (cloth_sim::core::IntegratorKind kind : cloth_sim::core::allIntegratorKinds()) {
    print(cloth_sim::core::integratorName(kind));
  }
  const std::vector<std::string> values = {"true", "false", "paper", "aerodynamic", "top_left", "top_right",
                                           "bottom_left", "bottom_right", "top_edge", "bottom_edge", "left_edge",
                                           "right_edge", "normal", "offset", "center", "radius", "velocity",
                                           "amplitude", "period", "min", "max", ".nan", ".inf", "-.inf", "1e308"};
  for (const std::string& value : values) print(value);
  return 0;
}
