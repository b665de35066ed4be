// stend_paper_table2 [table2.csv] — prints the reproduction of the paper's Table 2 fit
// (docs/paper-reproduction.md). Optional --json FILE writes the h = 0 normal-gravity fit as
// stend.fit/1.
#include <cstring>
#include <exception>
#include <iostream>
#include <string>

#include "stend/batch_lsq/paper_table2.hpp"

int main(int argc, char** argv) {
  using namespace stend::batch_lsq;
  std::filesystem::path csv = paper::default_table2_csv();
  std::string json_out;
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--json") == 0 && i + 1 < argc) {
      json_out = argv[++i];
    } else if (std::strcmp(argv[i], "-h") == 0 || std::strcmp(argv[i], "--help") == 0) {
      std::cout << "usage: stend_paper_table2 [table2.csv] [--json FILE]\n"
                << "default table: " << csv.string() << "\n";
      return 0;
    } else {
      csv = argv[i];
    }
  }
  try {
    const auto rows = paper::load_table2_csv(csv);
    const auto rep = paper::reproduce_table2(rows);
    std::cout << "table: " << csv.string() << "\n";
    paper::print_table2_report(std::cout, rep);
    if (!json_out.empty()) write_json(json_out, rep.cases.at(0).fit);
    return rep.cases.at(0).fit.ok() ? 0 : 1;
  } catch (const std::exception& e) {
    std::cerr << "stend_paper_table2: " << e.what() << "\n";
    return 2;
  }
}
