// `stend gap RUN_OR_DATASET --model MODEL.yaml` — sim-to-real gap diagnosis (diagnosis/),
// and `stend gap validate` — the diagnoser checked on withheld effects.
#include <fmt/core.h>

#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <memory>
#include <sstream>

#include "commands.hpp"
#include "progress.hpp"
#include "stend/estimation/model_spec.hpp"
#include "stend/estimators/builtin.hpp"
#include "stend/diagnosis/gap.hpp"
#include "stend/diagnosis/validate.hpp"
#include "stend/errors.hpp"
#include "stend/recording/files.hpp"
#include "stend/reporting/results.hpp"
#include "stend/yaml/reader.hpp"

namespace stend::cli {

namespace {

// The --fold-by values: the keys of diagnosis::kFoldByNames.
std::vector<std::string> family_rule_keys() {
  std::vector<std::string> keys;
  for (const auto& n : diagnosis::kFamilyRuleNames) keys.emplace_back(n.key);
  return keys;
}

std::vector<std::string> fold_by_keys() {
  std::vector<std::string> keys;
  for (const auto& n : diagnosis::kFoldByNames) keys.emplace_back(n.key);
  return keys;
}

// The model file as the linear error model the diagnosis fits and extends, through the estimator
// registry: the estimator the file is written for must have one.
estimation::ModelSpec linear_model(const std::string& model_file) {
  const estimation::Registry registry = estimators::builtin();
  const estimation::EstimatorEntry& e = registry.for_model(yaml::load_file(model_file, "model file"), model_file);
  if (!e.linear_model)
    throw std::runtime_error(model_file + ": a model file for '" + e.name +
                             "', which fits no linear error model; `stend gap` diagnoses one (a batch_lsq "
                             "model file: instrument, axes, terms)");
  return e.linear_model(model_file);
}

// With --db (or $STEND_RESULTS_DB) the run is recorded with its gap.json as a stored result kind
// (a failed diagnosis too: its document says so); not when the results went outside the folder.
void record_gap(const GapArgs& a, const std::filesystem::path& in_run, const std::filesystem::path& written) {
  const char* env = std::getenv("STEND_RESULTS_DB");
  if (a.db.empty() && !(env && *env)) return;
  std::error_code ec;
  if (in_run.empty() || !std::filesystem::equivalent(in_run, written, ec)) {
    fmt::print(stderr, "stend gap: not recorded in the results store: the results were not written into a run "
                       "folder (--out)\n");
    return;
  }
  record_in_store(in_run.parent_path(), a.db);
}

}  // namespace

Outcome run_gap(const GapArgs& a) {
  if (a.data.inputs.empty() || a.model.empty())
    throw Refusal(ExitCode::kUsage, "stend gap: give RUN_OR_DATASET and --model MODEL.yaml (or `stend gap validate`)");
  const RunFolderLock lock = lock_run(a.data.is_run() ? a.data.inputs[0] : std::string());
  const stend::Recording rec = a.data.open();
  const estimation::ModelSpec spec = linear_model(a.model);
  const diagnosis::GapInput in = diagnosis::build_input(rec, spec);
  diagnosis::GapOptions opt;
  opt.fold_by = diagnosis::fold_by_from_key(a.fold_by).value_or(diagnosis::FoldBy::kAuto);
  opt.max_steps = a.max_steps;
  opt.max_folds = a.max_folds;
  opt.alpha = a.alpha;
  opt.family_rule = diagnosis::family_rule_from_key(a.family_rule).value_or(diagnosis::FamilyRule::kBenjaminiYekutieli);
  if (std::string why; !opt.IsValid(&why)) throw InputError("stend gap: " + why);
  const diagnosis::GapReport rep = diagnosis::diagnose(in, opt);
  std::ostringstream text;
  diagnosis::print_report(text, rep);
  human_stream() << text.str();
  std::filesystem::path json = a.json;
  const std::filesystem::path in_run =
      a.data.is_run() ? std::filesystem::path(a.data.inputs[0]) / reporting::kGapResultsFile : std::filesystem::path();
  if (json.empty()) json = in_run;
  const std::string document = diagnosis::to_json(rep);
  write_results(json, document, text.str());
  record_gap(a, in_run, json);
  // docs/schemas/gap.schema.json
  return {rep.ok ? ExitCode::kOk : ExitCode::kFitFailed,
          {{"ok", rep.ok},
           {"results_file", json.empty() ? nlohmann::json(nullptr) : nlohmann::json(json.string())},
           {"document", nlohmann::json::parse(document, nullptr, false)}}};
}

namespace {

ExitCode run_validate(const GapArgs& a) {
  diagnosis::ValidateOptions o;
  o.seeds = a.seeds;
  o.sizes = a.sizes;
  o.null_runs = a.null_runs;
  o.oov_runs = a.oov_runs;
  o.only = a.only;
  o.seed = a.seed;
  o.noise_seeds = a.noise_seeds;
  o.noise_null_runs = a.noise_null_runs;
  o.design_runs = a.design_runs;
  o.gap.alpha = a.alpha;
  o.gap.family_rule = diagnosis::family_rule_from_key(a.family_rule).value_or(diagnosis::FamilyRule::kBenjaminiYekutieli);
  if (a.positions > 0) o.design = diagnosis::many_positions_design(a.positions);
  if (std::string why; !o.IsValid(&why)) throw InputError("stend gap validate: " + why);
  TaskProgress progress("gap validate");
  o.on_progress = [&progress](double done, const std::string& stage) { progress.update(done, stage); };
  const diagnosis::ValidationReport r = diagnosis::run_validation(o);
  progress.clear();
  diagnosis::print_validation(human_stream(), r);
  const std::string document = diagnosis::validation_json(r);
  if (!a.vjson.empty()) {
    write_file_atomic(a.vjson, document + "\n");
    fmt::print(human(), "results:    {}\n", a.vjson);
  }
  const bool pass = diagnosis::targets_met(r);
  fmt::print(human(), "targets:    {}\n", pass ? "met" : "NOT met");
  // docs/schemas/gap-validate.schema.json
  print_json({{"targets_met", pass},
              {"results_file", a.vjson.empty() ? nlohmann::json(nullptr) : nlohmann::json(a.vjson)},
              {"document", nlohmann::json::parse(document, nullptr, false)}});
  return pass ? ExitCode::kOk : ExitCode::kFitFailed;
}

}  // namespace

void add_gap_command(CLI::App& app, std::vector<Command>& out) {
  auto args = std::make_shared<GapArgs>();
  auto* sub = app.add_subcommand("gap", "Sim-to-real gap: where the twin disagrees with a recording, which "
                                        "unmodelled effect explains it, how far it shrinks held out");
  args->data.add_to(sub, false);
  args->data.add_accept_damaged(sub);
  sub->add_option("-m,--model", args->model, "Model YAML of a linear error model (instrument, axes, terms, extraction)");
  sub->add_option("-o,--out", args->json,
                  "Where to write the results (default RUN/gap.json; a dataset file's are written only with --out)");
  add_json_flag(sub, "the diagnosis's outcome and results document");
  sub->add_option("--db", args->db, std::string(kDbOptionHelp) +
                                        "; given (or $STEND_RESULTS_DB), the run is recorded there with its gap.json");
  sub->add_option("--fold-by", args->fold_by,
                  "Held-out folds: auto (the first scheme that fits the design) | orientation | temperature | ramp | "
                  "segment | time")
      ->check(CLI::IsMember(fold_by_keys()));
  sub->add_option("--max-steps", args->max_steps, "Forward-selection steps (default 4)")->check(at_least(1));
  sub->add_option("--max-folds", args->max_folds, "Held-out folds, groups dealt round-robin beyond (default 12; 0 = one per group)")
      ->check(at_least(0));
  sub->add_option("--alpha", args->alpha,
                  "Level of the candidate family (false discovery rate with --family-rule by, family-wise with "
                  "bonferroni; default 0.05)")
      ->check(strictly_within(0, 1));
  sub->add_option("--family-rule", args->family_rule,
                  "Multiple-testing rule over the candidates: by (Benjamini-Yekutieli, default) | bonferroni")
      ->check(CLI::IsMember(family_rule_keys()));

  auto* val = sub->add_subcommand("validate", "Check the diagnoser on planted, null and out-of-vocabulary effects");
  val->add_option("--seeds", args->seeds, "Runs per candidate and size (default 20)")->check(at_least(1));
  val->add_option("--sizes", args->sizes, "Planted sizes, multiples of the noise floor (default 1 2 5 10)")
      ->delimiter(',')
      ->check(above(0));
  val->add_option("--null", args->null_runs, "Null runs (default 40)")->check(at_least(1));
  val->add_option("--oov", args->oov_runs, "Out-of-vocabulary runs (default 20)")->check(at_least(1));
  val->add_option("--only", args->only, "Only these candidates (comma separated)")->delimiter(',');
  val->add_option("--positions", args->positions, "Use an N-position single-temperature design instead of the default")
      ->check(at_least(diagnosis::kMinManyPositions));
  val->add_option("--seed", args->seed, "Master seed");
  val->add_option("-o,--out", args->vjson, "Write the validation figures as JSON to this file");
  add_json_flag(val, "the validation figures");
  val->add_option("--noise-seeds", args->noise_seeds,
                  "Noise-stage experiments (quantization, saturation, coloured noise): runs per size (default 10; 0 = skip)")
      ->check(at_least(0));
  val->add_option("--noise-null", args->noise_null_runs, "Noise-stage null runs (default 40)")->check(at_least(0));
  val->add_option("--design-runs", args->design_runs,
                  "Design cases (folds, aliases, placement): runs per case (default 20; 0 = skip)")
      ->check(at_least(0));

  out.push_back({sub, [args, val] {
                   if (*val) return run_validate(*args);
                   const Outcome o = run_gap(*args);
                   print_json(o.doc);
                   return o.code;
                 }});
}

}  // namespace stend::cli
