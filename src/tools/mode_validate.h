// cloth_bench --validate: the textile tests of doc/VALIDATION.md (issue 17), one measurement per run, one
// JSON line on stdout; scripts/validate.py runs them for `make validate` and writes the page and pictures.
//
//   cloth_bench --validate cantilever --material denim --bend-model curvature --cols 21
//   cloth_bench --validate drape --material cotton --bend-model curvature --side 40 [--seconds 8] [--positions]
//   cloth_bench --validate hanging --material wool --side 20
#pragma once

#include <string>

namespace cloth_sim::bench {

/// True when the command line asks for --validate.
bool isValidateCommand(int argc, char** argv);

/// Runs the validation the command line asks for; returns the process exit code.
int runValidate(int argc, char** argv, const std::string& scenes_dir);

}  // namespace cloth_sim::bench
