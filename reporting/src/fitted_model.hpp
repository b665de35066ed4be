// Internal: the exports' reads of a results document's fields, and the error model rebuilt from a
// "stend.fit/1" document — now in estimation (stend/estimation/fitted_model.hpp), where the
// estimators' report sections reach it too.
#pragma once

#include "stend/estimation/fitted_model.hpp"
#include "stend/estimation/json_fields.hpp"

namespace stend::reporting::detail {

inline double jnum(const nlohmann::json& j, const char* key) { return estimation::number_field(j, key); }
inline double jat(const nlohmann::json& a, std::size_t i) { return estimation::number_at(a, i); }
inline std::string jstr(const nlohmann::json& j, const char* key) { return estimation::text_field(j, key); }

using estimation::contribution;
using estimation::fitted_model;
using estimation::FittedModel;

}  // namespace stend::reporting::detail
