#pragma once
#include <map>
#include <string>

namespace keyfleet::station::web {

// The dashboard page's files by URL path ("/dashboard.js"), compiled in from assets/.
const std::map<std::string, std::string>& page_assets();

}  // namespace keyfleet::station::web
