// Segment groups of the held-out folds, shared by the recording input and the validation
// generator. Internal to stend_diagnosis.
#pragma once

#include <cmath>
#include <map>
#include <string>
#include <vector>

namespace stend::diagnosis {

// Index of the orientation group named `name`, a new group when unseen.
inline int orientation_group(std::map<std::string, int>& groups, const std::string& name) {
  auto it = groups.find(name);
  if (it == groups.end()) it = groups.emplace(name, static_cast<int>(groups.size())).first;
  return it->second;
}

// Index of the temperature level within 2 °C of t_c (the last such), a new level when none.
inline int temperature_group(std::vector<double>& levels_c, double t_c) {
  int k = -1;
  for (std::size_t i = 0; i < levels_c.size(); ++i)
    if (std::abs(levels_c[i] - t_c) <= 2.0) k = static_cast<int>(i);
  if (k < 0) {
    levels_c.push_back(t_c);
    k = static_cast<int>(levels_c.size()) - 1;
  }
  return k;
}

}  // namespace stend::diagnosis
