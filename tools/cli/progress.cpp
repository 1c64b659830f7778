#include "cli/progress.h"

#include <unistd.h>

#include <cstdio>

namespace rayfold::core {

Progress::Progress(bool show) : enabled_(show && ::isatty(STDERR_FILENO)), start_(Clock::now()), last_(start_) {}

Progress::~Progress() { clear(); }

void Progress::stage(const std::string& name, size_t total) {
  stage_ = name;
  total_ = total;
  active_ = true;
  done_ = 0;
  last_ = Clock::time_point{};
  draw(0);
}

void Progress::update(size_t done) {
  done_ = done;
  if (!enabled_ || ms_since(last_) < 100.0) return;
  draw(done);
}

void Progress::draw(size_t done) {
  if (!enabled_) return;
  last_ = Clock::now();
  const double seconds = ms_since(start_) / 1000.0;
  if (total_ > 0)
    std::fprintf(stderr, "\r\033[K%s  %3.0f%%  %.1f s", stage_.c_str(), 100.0 * done / total_, seconds);
  else
    std::fprintf(stderr, "\r\033[K%s  %.1f s", stage_.c_str(), seconds);
  std::fflush(stderr);
  drawn_ = true;
}

void Progress::clear() {
  active_ = false;
  if (!drawn_) return;
  std::fprintf(stderr, "\r\033[K");
  std::fflush(stderr);
  drawn_ = false;
}

void Progress::print(std::FILE* out, const std::string& text) {
  const bool redraw = active_;
  if (drawn_) {
    std::fprintf(stderr, "\r\033[K");
    std::fflush(stderr);
    drawn_ = false;
  }
  std::fputs(text.c_str(), out);
  std::fflush(out);
  if (redraw) draw(done_);
}

}  // namespace rayfold::core
