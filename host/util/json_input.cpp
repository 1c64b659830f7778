#include "util/json_input.h"

#include <cmath>
#include <fstream>

#include "util/errors.h"

namespace rayfold::core {

nlohmann::json read_json_object(const std::string& path, const char* what) {
  std::ifstream f(path);
  if (!f) throw InputError(path, std::string("cannot open the ") + what);
  nlohmann::json j = nlohmann::json::parse(f, nullptr, false);
  if (j.is_discarded() || !j.is_object()) throw InputError(path, "is not a JSON object");
  return j;
}

double json_number(const nlohmann::json& j, const std::string& where, const std::string& path) {
  if (!j.is_number()) throw InputError(path, where + " must be a number");
  const double v = j.get<double>();
  if (!std::isfinite(v)) throw InputError(path, where + " must be finite");
  return v;
}

}  // namespace rayfold::core
