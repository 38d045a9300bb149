// cloth_bench's measuring modes: --accuracy (cost against error of every integrator and substep count on a scene,
// with a recommendation), --spatial (a grid against a finer grid of the same cloth), --stability-map (largest
// stable step against stiffness and mass, beside theory), --terms (what each force and collider term costs and
// changes) and --solver-sweep (implicit Euler's CG tolerance and cap against a converged solve). One file per mode
// (mode_*.cpp, sharing accuracy_modes.h); doc/ACCURACY.md shows what they print; scripts/accuracy.py runs them for
// `make accuracy`.
#pragma once

#include <string>

namespace cloth_sim::bench {

/// True when the command line asks for one of these modes.
bool isAccuracyToolCommand(int argc, char** argv);

/// Runs the mode the command line asks for; returns the process exit code.
int runAccuracyTool(int argc, char** argv, const std::string& default_scenes_dir);

}  // namespace cloth_sim::bench
