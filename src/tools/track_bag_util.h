// track_bag's terminal helpers: a progress bar, a stopwatch, the capture
// of what libraries print (stderr, console_bridge), so that the tool keeps its
// promise of one error line, the notes printed after a run, and the count of
// dropped messages by cause. Private to src/tools/track_bag.cpp.
#pragma once

#include "log_cause.h"

#include <console_bridge/console.h>

#include <fcntl.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <map>
#include <string>
#include <vector>

namespace imt::track_bag {

// A one-line progress bar on stderr, when it is a terminal.
class Progress {
 public:
  Progress(size_t total, bool enabled) : total_(total), enabled_(enabled) {}
  void update(size_t done) {
    if (!enabled_) return;
    const auto now = Clock::now();
    if (done < total_ && now - last_ < std::chrono::milliseconds(100)) return;
    last_ = now;
    const double elapsed = std::chrono::duration<double>(now - start_).count();
    const int width = 30;
    const int filled = total_ ? static_cast<int>(width * done / total_) : width;
    std::string bar(filled, '#');
    bar.resize(width, '-');
    std::fprintf(stderr, "\r[%s] %3d%% %zu/%zu frames %.1f fps", bar.c_str(),
                 total_ ? static_cast<int>(100 * done / total_) : 100, done, total_,
                 elapsed > 0 ? done / elapsed : 0.0);
    std::fflush(stderr);
    shown_ = true;
  }
  // Ends the bar's line (before any other output on stderr).
  void finish() {
    if (shown_) std::fputs("\r\033[K", stderr);
    shown_ = false;
  }

 private:
  using Clock = std::chrono::steady_clock;
  size_t total_;
  bool enabled_;
  bool shown_ = false;
  Clock::time_point start_ = Clock::now(), last_ = Clock::time_point();
};

class Stopwatch {
 public:
  double lap() {
    const auto now = std::chrono::steady_clock::now();
    const double s = std::chrono::duration<double>(now - t_).count();
    t_ = now;
    return s;
  }

 private:
  std::chrono::steady_clock::time_point t_ = std::chrono::steady_clock::now();
};

// Captures what libraries write to stderr (libpng and libjpeg print their
// warnings and errors there) around a call, so that this tool keeps its
// promise of one error line, and reports the text itself. Single-threaded.
class StderrCapture {
 public:
  StderrCapture() {
    file_ = std::tmpfile();
    saved_ = dup(STDERR_FILENO);
  }
  ~StderrCapture() {
    if (file_) std::fclose(file_);
    if (saved_ >= 0) ::close(saved_);
  }
  void start() {
    if (!file_ || saved_ < 0) return;
    std::fflush(stderr);
    dup2(fileno(file_), STDERR_FILENO);
  }
  // Restores stderr; returns what was written meanwhile, on one line.
  std::string stop() {
    if (!file_ || saved_ < 0) return "";
    std::fflush(stderr);
    dup2(saved_, STDERR_FILENO);
    const int fd = fileno(file_);
    std::string text;
    char buf[512];
    lseek(fd, 0, SEEK_SET);
    ssize_t n;
    while (text.size() < 4096 && (n = ::read(fd, buf, sizeof(buf))) > 0) text.append(buf, n);
    if (ftruncate(fd, 0) != 0) {
    }
    lseek(fd, 0, SEEK_SET);
    while (!text.empty() && (text.back() == '\n' || text.back() == ' ')) text.pop_back();
    for (char& c : text)
      if (c == '\n' || c == '\r') c = ';';
    return text;
  }

 private:
  std::FILE* file_ = nullptr;
  int saved_ = -1;
};

// Collects what the ROS libraries log through console_bridge (rosbag and
// roscpp's header parser print errors there before throwing), instead of
// letting it reach stderr: a failure is then still one line, carrying the
// library's words; on success they are printed as warnings, once each.
class LibraryLog : public console_bridge::OutputHandler {
 public:
  void log(const std::string& text, console_bridge::LogLevel level, const char*, int) override {
    if (level < console_bridge::CONSOLE_BRIDGE_LOG_WARN) return;
    std::string line;
    bool space = false;
    for (char c : text) {  // one line, runs of whitespace collapsed
      const bool ws = c == ' ' || c == '\n' || c == '\r' || c == '\t';
      if (ws) {
        space = !line.empty();
      } else {
        if (space) line += ' ';
        line += c;
        space = false;
      }
    }
    if (line.empty() || messages.size() >= 5) return;
    for (const std::string& m : messages)
      if (m == line) return;
    messages.push_back(line);
  }
  std::vector<std::string> messages;
};

LibraryLog& libraryLog() {
  static LibraryLog log;
  return log;
}

// Messages printed once each after a successful run.
struct Notes {
  std::vector<std::string> lines;
  void warn(const std::string& s) { lines.push_back("warning: " + s); }
  void note(const std::string& s) { lines.push_back("note: " + s); }
};

// Messages dropped for one cause (the reason with its numbers left out):
// how many, and the first one's reason and place.
struct DropInfo {
  int count = 0;
  size_t order = 0;  // causes are reported in the order they first came
  std::string first_reason, first_where;
};
// Drops by cause.
using Drops = std::map<std::string, DropInfo>;

inline void noteDrop(Drops* drops, const std::string& reason, const std::string& where) {
  DropInfo& d = (*drops)[causeOf(reason)];
  if (d.count++ == 0) {
    d.order = drops->size() - 1;
    d.first_reason = reason;
    d.first_where = where;
  }
}
inline int total(const Drops& drops) {
  int n = 0;
  for (const auto& [cause, d] : drops) n += d.count;
  return n;
}
inline std::vector<const DropInfo*> inOrder(const Drops& drops) {
  std::vector<const DropInfo*> v(drops.size());
  for (const auto& [cause, d] : drops) v[d.order] = &d;
  return v;
}

}  // namespace imt::track_bag
