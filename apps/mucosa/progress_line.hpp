#pragma once
// Progress of a long search on stderr (mucosa tune, mucosa look).
#include <chrono>
#include <cstdio>
#include <string>
#include <utility>

#include <unistd.h>

#include <fmt/format.h>

#include "commands.hpp"

namespace mucosa::cli {

// Progress on stderr: a line rewritten in place on a terminal, every tenth
// of the work otherwise (so a log keeps a bounded number of lines).
class ProgressLine {
public:
    ProgressLine(const Global& g, std::string tag)
        : show_(!g.quiet), tty_(isatty(2) != 0), tag_(std::move(tag)), t0_(std::chrono::steady_clock::now()) {}
    void operator()(int done, int total, const std::string& what) {
        if (!show_ || total <= 0) return;
        const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0_).count();
        const double eta = done > 0 ? s / done * (total - done) : 0;
        const std::string line = fmt::format("[{} {:3.0f}%] {} ({}/{}, {} elapsed, ETA {})", tag_, 100.0 * done / total,
                                             what, done, total, formatDuration(s), formatDuration(eta));
        if (tty_) {
            std::fprintf(stderr, "\r%s\x1b[K%s", line.c_str(), done >= total ? "\n" : "");
            open_ = done < total;
        } else if (done == total || done * 10 / total != (done - 1) * 10 / total) {
            std::fprintf(stderr, "%s\n", line.c_str());
        }
        std::fflush(stderr);
    }
    void finish() {
        if (show_ && tty_ && open_) std::fprintf(stderr, "\n");
        open_ = false;
    }

private:
    bool show_, tty_;
    std::string tag_;
    bool open_ = false;  // a line without its newline yet
    std::chrono::steady_clock::time_point t0_;
};

}  // namespace mucosa::cli
