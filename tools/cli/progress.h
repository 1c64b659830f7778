// Progress on stderr for long work, as a line rewritten in place: the stage,
// a percentage when the total is known, and the elapsed time. Shown only
// when stderr is a terminal and the user did not ask for quiet; otherwise
// every call does nothing, so logs and pipes stay clean.
#pragma once

#include <cstdio>
#include <string>

#include "util/timer.h"

namespace rayfold::core {

class Progress {
 public:
  // Enabled when `show` and stderr is a terminal.
  explicit Progress(bool show);
  ~Progress();  // clears the line

  // Starts a stage; `total` 0 when its amount of work is unknown.
  void stage(const std::string& name, size_t total = 0);
  // `done` of the stage's total; redraws at most ten times a second.
  void update(size_t done);
  // Clears the line (before printing results); the stage ends.
  void clear();
  // Prints text (whole lines) to `out` with the progress line cleared
  // first and redrawn after, so that the two never share a line.
  void print(std::FILE* out, const std::string& text);

 private:
  void draw(size_t done);
  bool enabled_ = false;
  bool drawn_ = false;
  bool active_ = false;  // a stage is under way (stage() to clear())
  size_t done_ = 0;
  std::string stage_;
  size_t total_ = 0;
  Clock::time_point start_, last_;
};

}  // namespace rayfold::core
