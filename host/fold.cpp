#include "fold.h"

#include "errors.h"

namespace rayfold {

const char* fold_name(FoldMode m) {
  switch (m) {
    case FoldMode::none: return "none";
    case FoldMode::y: return "y";
    case FoldMode::x: return "x";
    case FoldMode::xy: return "xy";
  }
  return "?";
}

FoldMode parse_fold(const std::string& text) {
  if (text == "none") return FoldMode::none;
  if (text == "y") return FoldMode::y;
  if (text == "x") return FoldMode::x;
  if (text == "xy" || text == "yx") return FoldMode::xy;
  throw UsageError("--fold: '" + text + "' is not none, y, x or xy");
}

}  // namespace rayfold
