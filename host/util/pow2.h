// Scaling floats by a power of two, exact while the result is a normal
// float: a product with 2^e where 2^e is itself a normal float (it rounds
// as ldexp does and costs a tenth of its call), else ldexp.
#pragma once

#include <cmath>

namespace rayfold::core {

class Pow2Scale {
 public:
  explicit Pow2Scale(int e) : e_(e), by_product_(e > -126 && e < 126), factor_(std::ldexp(1.0f, by_product_ ? e : 0)) {}
  float operator()(float x) const { return by_product_ ? x * factor_ : std::ldexp(x, e_); }

 private:
  int e_;
  bool by_product_;
  float factor_;
};

}  // namespace rayfold::core
