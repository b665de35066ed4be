// The one way io/ notes something about an import in the recording: an event of source "import"
// at the first sample's time.
#pragma once

#include <stend/recording/recording.hpp>

#include <string>
#include <vector>

namespace stend::io {

inline void add_import_event(Recording& rec, const std::string& message, const std::string& level = "info") {
  Event e;
  e.t_s = rec.samples.empty() ? 0.0 : rec.samples.front().t_s;
  e.level = level;
  e.source = "import";
  e.message = message;
  rec.events.push_back(std::move(e));
}

// The import events of a recording whose samples were streamed elsewhere (add_import_event then
// saw none) moved to the first sample's time t_s.
inline void place_import_events(std::vector<Event>& events, double t_s) {
  for (auto& e : events)
    if (e.source == "import") e.t_s = t_s;
}

}  // namespace stend::io
