// stend_temp_poly_fit RUN_DIR [OPTIONS.yaml] [--json FILE]
// Fits bias and scale versus temperature on a recording and prints the report (exit 1 when the
// fit was refused or failed, 2 on usage or input errors).
#include <exception>
#include <fstream>
#include <iostream>
#include <string>

#include "stend/temp_poly/temp_poly.hpp"

int main(int argc, char** argv) {
  std::string run, options, json;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--json" && i + 1 < argc) json = argv[++i];
    else if (run.empty()) run = a;
    else if (options.empty()) options = a;
    else {
      std::cerr << "usage: stend_temp_poly_fit RUN_DIR [OPTIONS.yaml] [--json FILE]\n";
      return 2;
    }
  }
  if (run.empty()) {
    std::cerr << "usage: stend_temp_poly_fit RUN_DIR [OPTIONS.yaml] [--json FILE]\n";
    return 2;
  }
  try {
    const stend::temp_poly::TempPolyOptions o =
        options.empty() ? stend::temp_poly::TempPolyOptions{} : stend::temp_poly::load_options(options);
    const stend::Recording rec = stend::Recording::open(run);
    const auto r = stend::temp_poly::fit_temperature_model(rec, o);
    std::cout << r;
    if (!json.empty()) std::ofstream(json) << stend::temp_poly::to_json(r) << "\n";
    return r.ok() ? 0 : 1;
  } catch (const std::exception& e) {
    std::cerr << "stend_temp_poly_fit: " << e.what() << "\n";
    return 2;
  }
}
