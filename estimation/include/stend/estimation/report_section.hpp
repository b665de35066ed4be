// A section of the run report as data, no HTML: a heading, the results file it came from, and
// blocks in order — paragraphs, sub-headings, tables of plain-text cells and figures (a plot
// described as data, figure.hpp, with its caption). Each estimator writes the section of its own
// results (the registry entry's `report`, registry.hpp); reporting lays the sections out on the
// page and draws them (HTML, inline SVG). Nothing in a section is markup: every text is plain and
// is escaped where it is drawn.
//
//   FitResult ──entry.report──► ReportSection ──reporting──► <h2>, <p>, <table>, <figure><svg>
#pragma once

#include <stend/estimation/figure.hpp>

#include <iosfwd>
#include <string>
#include <variant>
#include <vector>

namespace stend::estimation {

// How a paragraph or a cell is stressed: as it is, a warning (the reader should check something),
// or a failure (there is no result).
enum class Emphasis { kNormal, kWarning, kFailure };
const char* to_string(Emphasis e);  // "normal" | "warning" | "failure"

// A run of text within a paragraph.
struct Span {
  enum class Kind {
    kPlain,
    kStrong,  // a label the reader's eye should find ("Unexplained:")
    kCode,    // something to type ("stend export RUN --to kalibr")
  };
  std::string text;
  Kind kind = Kind::kPlain;
  bool operator==(const Span&) const = default;
};

struct Paragraph {
  std::vector<Span> spans;
  Emphasis emphasis = Emphasis::kNormal;

  std::string text() const;  // the spans' text, joined
  bool operator==(const Paragraph&) const = default;
};

// A heading within the section (e.g. one axis of a per-axis fit).
struct Subheading {
  std::string text;
  bool operator==(const Subheading&) const = default;
};

struct Cell {
  std::string text;
  int columns = 1;  // how many columns it spans
  Emphasis emphasis = Emphasis::kNormal;

  Cell(std::string t = {}, int columns_spanned = 1, Emphasis e = Emphasis::kNormal)
      : text(std::move(t)), columns(columns_spanned), emphasis(e) {}
  Cell(const char* t) : text(t) {}
  bool operator==(const Cell&) const = default;
};

struct Row {
  enum class Mark {
    kNone,
    kNotIdentified,  // a parameter the data did not identify: its row is marked as such
  };
  std::vector<Cell> cells;
  Mark mark = Mark::kNone;
  bool operator==(const Row&) const = default;
};

struct Table {
  enum class Kind {
    kPlain,
    kParameters,  // the parameter table of a fit (fit_report.hpp: parameter_table)
  };
  Kind kind = Kind::kPlain;
  std::vector<std::string> header;
  std::vector<Row> rows;
  bool operator==(const Table&) const = default;
};

// A figure: the plot and its caption.
struct Figure {
  figure::Plot plot;
  std::string caption;
  bool equals(const Figure& other) const { return caption == other.caption && plot.equals(other.plot); }
};

using Block = std::variant<Paragraph, Subheading, Table, Figure>;

struct ReportSection {
  // What the section reports, which also orders the page: error models first, then temperature
  // models, then noise (each in the registry's order).
  enum class Topic { kErrorModel, kTemperatureModel, kNoise };

  std::string heading;  // "Error-model fit — batch_lsq 0.1.0"
  std::string file;     // where it came from, shown beside the heading: "fit.json", "run samples"
  Topic topic = Topic::kErrorModel;
  std::vector<Block> blocks;

  // Builders, each appending one block.
  void add_text(std::string text, Emphasis emphasis = Emphasis::kNormal);
  void add(Paragraph p) { blocks.emplace_back(std::move(p)); }
  void add(Subheading h) { blocks.emplace_back(std::move(h)); }
  void add(Table t) { blocks.emplace_back(std::move(t)); }
  void add(Figure f) { blocks.emplace_back(std::move(f)); }
  void add(figure::Plot plot, std::string caption) { add(Figure{std::move(plot), std::move(caption)}); }
  void append(const std::vector<Paragraph>& paragraphs);
  void append(const std::vector<Figure>& figures);

  // As plain text: the heading, each paragraph, each table row by row (cells separated by " | "),
  // each figure's title and caption.
  void print(std::ostream& os) const;
  bool equals(const ReportSection& other) const;
};
std::ostream& operator<<(std::ostream& os, const ReportSection& s);  // = print

// A number in a report's text and tables: %.<significant>g, "—" when not finite.
std::string report_number(double v, int significant = 6);

// The unit a value is shown in (the one table of display units: the run report, the comparison,
// the fits' and the gap's text): m/s² as mg, rad/s as deg/s, a dimensionless factor (scale,
// cross-axis) as ppm, g-sensitivity rad/s/(m/s²) as (deg/s)/g, a temperature coefficient as its
// base unit's display per degC^k, any other unit as it is stored (SI inside, readable out; JSON
// stays SI with its unit string).
struct DisplayUnit {
  double scale = 1.0;  // display value = stored value × scale
  std::string unit;
};
DisplayUnit display_unit(const std::string& unit);

}  // namespace stend::estimation
