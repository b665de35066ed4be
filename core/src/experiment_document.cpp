// The experiment file as a document: its text, its single YAML document (walked with the event
// parser first, see document_starts), and the plugin_paths a host reads before anything else.
#include "experiment_parse.hpp"

#include <yaml-cpp/eventhandler.h>

#include <algorithm>
#include <cerrno>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <system_error>

namespace stend::detail {

namespace fs = std::filesystem;

void fail(const SourceLocation& where, const std::string& path, const std::string& message,
          const std::string& hint) {
  throw ExperimentError(where, path, message, hint);
}

namespace {

[[noreturn]] void syntax_error(const YAML::Mark& mark, const std::string& msg,
                               const std::string& file) {
  SourceLocation loc{file, 0, 0};
  if (mark.line >= 0 && mark.column >= 0) {
    loc.line = mark.line + 1;
    loc.column = mark.column + 1;
  }
  fail(loc, "", "YAML syntax error: " + msg,
       "check indentation (spaces, not tabs), brackets and quotes on this line and the one "
       "before");
}

// Where each YAML document of a text starts (its first node) and whether it is only a null,
// from yaml-cpp's event parser.
class DocumentStarts final : public YAML::EventHandler {
 public:
  struct Start {
    YAML::Mark mark;
    bool null;
  };
  std::vector<Start> starts;

  void OnDocumentStart(const YAML::Mark&) override { first_ = true; }
  void OnDocumentEnd() override {}
  void OnNull(const YAML::Mark& m, YAML::anchor_t) override { node(m, true); }
  void OnAlias(const YAML::Mark& m, YAML::anchor_t) override { node(m, false); }
  void OnScalar(const YAML::Mark& m, const std::string&, YAML::anchor_t, const std::string&) override { node(m, false); }
  void OnSequenceStart(const YAML::Mark& m, const std::string&, YAML::anchor_t, YAML::EmitterStyle::value) override {
    node(m, false);
  }
  void OnSequenceEnd() override {}
  void OnMapStart(const YAML::Mark& m, const std::string&, YAML::anchor_t, YAML::EmitterStyle::value) override {
    node(m, false);
  }
  void OnMapEnd() override {}

 private:
  void node(const YAML::Mark& m, bool null) {
    if (first_) starts.push_back({m, null});
    first_ = false;
  }
  bool first_ = false;
};

// The documents of an experiment file, walked with the event parser rather than YAML::LoadAll:
// yaml-cpp 0.7 (Debian 12) loops for ever there, allocating a null document per turn, when a
// document starts with a token no node starts with, e.g. a stray ',' (jbeder/yaml-cpp#1319). Two
// null documents in a row at the same place are the parser stuck on such a token: a syntax error
// there. The walk stops at the second document that holds something (an experiment is one).
std::vector<DocumentStarts::Start> document_starts(const std::string& text, const std::string& file) {
  std::istringstream in(text);
  YAML::Parser parser(in);
  DocumentStarts docs;
  try {
    while (parser.HandleNextDocument(docs)) {
      const auto& s = docs.starts;
      const std::size_t n = s.size();
      if (n >= 2 && s[n - 1].null && s[n - 2].null && s[n - 1].mark.pos == s[n - 2].mark.pos) {
        const auto pos = static_cast<std::size_t>(std::max(0, s[n - 1].mark.pos));
        syntax_error(s[n - 1].mark,
                     pos < text.size() ? "unexpected '" + text.substr(pos, 1) + "': no YAML node starts with it"
                                       : "unexpected end of the text",
                     file);
      }
      if (std::count_if(s.begin(), s.end(), [](const auto& d) { return !d.null; }) >= 2) break;
    }
  } catch (const YAML::Exception& e) {
    syntax_error(e.mark, e.msg, file);
  }
  return docs.starts;
}

}  // namespace

std::string read_text_file(const std::string& path) {
  std::error_code ec;
  if (!fs::exists(path, ec))
    fail({path, 0, 0}, "", "experiment file '" + path + "' does not exist",
         "check the path (relative paths are taken from the current folder)");
  if (fs::is_directory(path, ec))
    fail({path, 0, 0}, "", "'" + path + "' is a folder, not an experiment file",
         "give the path of the experiment's .yaml file");
  std::ifstream in(path, std::ios::binary);
  if (!in)
    fail({path, 0, 0}, "",
         "cannot open experiment file '" + path + "': " + std::generic_category().message(errno));
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

YAML::Node load_root(const std::string& text, const std::string& file) {
  std::vector<DocumentStarts::Start> docs = document_starts(text, file);
  while (docs.size() > 1 && docs.back().null) docs.pop_back();
  if (docs.empty() || docs[0].null)
    fail({file, 1, 1}, "", "the experiment file is empty",
         "an experiment has 'experiment:', 'bench:' and 'procedure:' sections; see "
         "docs/experiment-format.md");
  if (docs.size() > 1)
    fail({file, docs[1].mark.line + 1, docs[1].mark.column + 1}, "",
         "a second YAML document starts here; an experiment is a single document",
         "remove the '---' separator and merge the documents");
  YAML::Node root;
  try {
    root = YAML::Load(text);  // the first document
  } catch (const YAML::Exception& e) {
    syntax_error(e.mark, e.msg, file);
  }
  if (!root.IsMap())
    fail(yaml::location_of(root, file), "",
         "expected the experiment as a mapping with 'experiment:', 'bench:' and 'procedure:' "
         "sections, got " + yaml::describe(root));
  return root;
}

std::vector<std::string> resolve_plugin_paths(const YAML::Node& node, const std::string& file,
                                              const std::string& path) {
  std::vector<std::string> out;
  if (!node.IsDefined() || node.IsNull()) return out;
  if (!node.IsSequence())
    fail(yaml::location_of(node, file), path,
         "expected a list of folders for 'plugin_paths', got " + yaml::describe(node),
         "write plugin_paths: [./my_plugins]");
  const fs::path base = fs::path(file).parent_path();
  for (std::size_t i = 0; i < node.size(); ++i) {
    const std::string epath = path + "[" + std::to_string(i) + "]";
    const std::string s = yaml::as_string(node[i], file, epath);
    if (s.empty())
      fail(yaml::location_of(node[i], file), epath, "a plugin path must not be empty");
    fs::path p(s);
    if (p.is_relative()) p = base / p;
    std::error_code ec;
    fs::path abs = fs::absolute(p, ec);
    if (ec) abs = p;
    abs = abs.lexically_normal();
    if (abs.has_relative_path() && abs.filename().empty()) abs = abs.parent_path();
    if (!fs::is_directory(abs, ec))
      fail(yaml::location_of(node[i], file), epath,
           "plugin path '" + s + "' (" + abs.string() + ") " + (fs::exists(abs, ec) ? "is not a folder" : "does not exist"),
           "plugin_paths lists folders holding stend_<name>.so files, relative to the experiment file's folder");
    out.push_back(abs.string());
  }
  return out;
}

}  // namespace stend::detail

namespace stend {

std::vector<std::string> experiment_plugin_paths(const std::string& path) {
  const YAML::Node root = detail::load_root(detail::read_text_file(path), path);
  const YAML::Node section = root["experiment"];
  if (!section.IsDefined() || !section.IsMap()) return {};
  for (auto it = section.begin(); it != section.end(); ++it)
    if (it->first.IsScalar() && it->first.Scalar() == "plugin_paths")
      return detail::resolve_plugin_paths(it->second, path, "experiment.plugin_paths");
  return {};
}

}  // namespace stend
