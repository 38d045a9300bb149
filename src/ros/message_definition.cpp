#include "cloth_sim/ros/message_definition.h"

#include <sstream>

namespace cloth_sim {

bool definitionStartsWithHeader(const std::string& definition) {
  std::istringstream lines(definition);
  std::string line;
  while (std::getline(lines, line)) {
    const std::string code = line.substr(0, line.find('#'));
    if (code.find('=') != std::string::npos) continue;  // a constant
    std::istringstream words(code);
    std::string type;
    if (!(words >> type)) continue;  // blank, or a comment only
    return type == "Header" || type == "std_msgs/Header";
  }
  return false;
}

}  // namespace cloth_sim
