#include "cli/cli_args.h"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <new>

#include "util/errors.h"
#include "util/output_transaction.h"

namespace rayfold::core::cli {

Args::Args(int argc, char** argv, int first) {
  for (int i = first; i < argc; ++i) args_.emplace_back(argv[i]);
}

std::string Args::value(const std::string& option) {
  if (done()) throw UsageError(option + " needs a value");
  return next();
}

int guarded_main(const std::function<int()>& body) {
  install_interrupt_cleanup();
  // Every output of the run lands together, and only when it succeeded.
  OutputTransaction outputs;
  try {
    const int code = body();
    if (code == 0) outputs.commit();
    return code;
  } catch (const InputError& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 2;
  } catch (const UsageError& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 2;
  } catch (const std::bad_alloc&) {
    std::fprintf(stderr, "error: out of host memory\n");
    return 3;
  } catch (const std::exception& e) {  // RuntimeFailure and anything else
    std::fprintf(stderr, "error: %s\n", e.what());
    return 3;
  }
}

int parse_int(const std::string& option, const std::string& text, int lo, int hi) {
  char* end = nullptr;
  errno = 0;
  const long v = std::strtol(text.c_str(), &end, 10);
  if (text.empty() || *end != '\0' || errno == ERANGE) throw UsageError(option + ": '" + text + "' is not an integer");
  if (v < lo || v > hi)
    throw UsageError(option + ": " + text + " is out of range (" + std::to_string(lo) + ".." + std::to_string(hi) +
                     ")");
  return static_cast<int>(v);
}

double parse_double(const std::string& option, const std::string& text) {
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (text.empty() || *end != '\0' || !std::isfinite(v))
    throw UsageError(option + ": '" + text + "' is not a finite number");
  return v;
}

glm::dvec3 parse_vec3(const std::string& option, const std::string& text) {
  glm::dvec3 v;
  size_t start = 0;
  for (int k = 0; k < 3; ++k) {
    const size_t comma = text.find(',', start);
    if ((k < 2) != (comma != std::string::npos)) throw UsageError(option + ": '" + text + "' is not X,Y,Z");
    v[k] = parse_double(option, text.substr(start, k < 2 ? comma - start : std::string::npos));
    start = comma + 1;
  }
  return v;
}

std::vector<std::string> split_list(const std::string& option, const std::string& text) {
  std::vector<std::string> items;
  size_t start = 0;
  for (;;) {
    const size_t comma = text.find(',', start);
    items.push_back(text.substr(start, comma == std::string::npos ? std::string::npos : comma - start));
    if (items.back().empty()) throw UsageError(option + ": '" + text + "' has an empty item");
    if (comma == std::string::npos) return items;
    start = comma + 1;
  }
}

Fold parse_fold(const std::string& option, const std::string& text) {
  if (text == "none") return Fold::none;
  if (text == "y") return Fold::y;
  if (text == "x") return Fold::x;
  if (text == "xy" || text == "yx") return Fold::xy;
  throw UsageError(option + ": '" + text + "' is not none, y, x or xy");
}

void parse_size(const std::string& option, const std::string& text, int* width, int* height) {
  const size_t x = text.find('x');
  if (x == std::string::npos) throw UsageError(option + ": '" + text + "' is not WIDTHxHEIGHT");
  *width = parse_int(option, text.substr(0, x), 1, 32767);
  *height = parse_int(option, text.substr(x + 1), 1, 32767);
}

}  // namespace rayfold::core::cli
