#include "util/json_input.h"

#include <cmath>
#include <fstream>

#include "util/errors.h"

namespace rayfold::core {

nlohmann::json read_json_object(const std::string& path, const char* what) {
  std::ifstream f(path);
  if (!f) throw InputError(path, std::string("cannot open the ") + what);
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(f);
  } catch (const nlohmann::json::parse_error& e) {
    // The parser's own words say where: "parse error at line 3, column 5:
    // syntax error while parsing object - unexpected '}'; ...", after an id.
    std::string why = e.what();
    const size_t id_end = why.find("] ");
    if (why.rfind("[json.exception.", 0) == 0 && id_end != std::string::npos) why.erase(0, id_end + 2);
    throw InputError(path, "is not valid JSON: " + why);
  }
  if (!j.is_object())
    throw InputError(path, std::string("holds a JSON ") + j.type_name() + ", not the object {...} of a " + what);
  return j;
}

double json_number(const nlohmann::json& j, const std::string& where, const std::string& path) {
  if (!j.is_number()) throw InputError(path, where + " must be a number");
  const double v = j.get<double>();
  if (!std::isfinite(v)) throw InputError(path, where + " must be finite");
  return v;
}

}  // namespace rayfold::core
