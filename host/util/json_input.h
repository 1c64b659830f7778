// JSON input files (camera lists, NeRF transforms) read with the file named
// in every error.
#pragma once

#include <string>

#include <nlohmann/json.hpp>

namespace rayfold::core {

// The file's top-level JSON object. InputError(path, ...) when it cannot be
// opened (naming it as `what`), is not valid JSON (the parser's line,
// column and reason) or holds another JSON type.
nlohmann::json read_json_object(const std::string& path, const char* what);

// j as a finite number; InputError(path, "<where> must be ...") otherwise.
double json_number(const nlohmann::json& j, const std::string& where, const std::string& path);

}  // namespace rayfold::core
