#include "editor/progress_bar.h"

#include <unistd.h>

#include <csignal>
#include <cstdio>

namespace strata {
namespace {

std::atomic<bool> interrupted{false};

void on_interrupt(int) {
    interrupted.store(true);
    std::signal(SIGINT, SIG_DFL);
}

std::string human(double value) {
    char text[32];
    if (value >= 1e9) std::snprintf(text, sizeof text, "%.2f G", value / 1e9);
    else if (value >= 1e6) std::snprintf(text, sizeof text, "%.2f M", value / 1e6);
    else if (value >= 1e3) std::snprintf(text, sizeof text, "%.1f k", value / 1e3);
    else std::snprintf(text, sizeof text, "%.0f ", value);
    return text;
}

}  // namespace

std::string describe_duration(double seconds) {
    char text[32];
    if (seconds < 90) std::snprintf(text, sizeof text, "%.0f s", seconds);
    else if (seconds < 90 * 60) std::snprintf(text, sizeof text, "%.0f min", seconds / 60);
    else std::snprintf(text, sizeof text, "%.1f h", seconds / 3600);
    return text;
}

const std::atomic<bool>* install_interrupt_flag() {
    std::signal(SIGINT, on_interrupt);
    return &interrupted;
}

ProgressBar::ProgressBar(bool enabled) : enabled_(enabled && ::isatty(STDERR_FILENO)) {}

ProgressBar::~ProgressBar() { finish(); }

Progress ProgressBar::progress(const std::atomic<bool>* cancel) {
    Progress p;
    if (enabled_)
        p.report = [this](std::string_view stage, double done, double total, std::string_view unit) {
            update(stage, done, total, unit);
        };
    p.cancel = cancel;
    return p;
}

void ProgressBar::update(std::string_view stage, double done, double total, std::string_view unit) {
    auto now = std::chrono::steady_clock::now();
    if (stage != stage_) {
        stage_ = stage;
        stage_start_ = now;
    } else if (now - last_draw_ < std::chrono::milliseconds(100) && done < total) {
        return;
    }
    last_draw_ = now;
    double fraction = total > 0 ? std::min(1.0, done / total) : 0;
    double seconds = std::chrono::duration<double>(now - stage_start_).count();
    constexpr int width = 30;
    int filled = int(fraction * width);
    std::string bar(size_t(filled), '#');
    bar.resize(width, '-');
    std::string rate = seconds > 0.05 && !unit.empty() ? human(done / seconds) + std::string(unit) + "/s" : "";
    std::string eta;
    if (fraction > 0.01 && fraction < 1) {
        int left = int(seconds / fraction * (1 - fraction) + 0.5);
        char text[32];
        std::snprintf(text, sizeof text, "ETA %d:%02d", left / 60, left % 60);
        eta = text;
    }
    std::fprintf(stderr, "\r\033[K%-22s [%s] %3d%%  %s  %s", stage_.c_str(), bar.c_str(), int(fraction * 100),
                 rate.c_str(), eta.c_str());
    std::fflush(stderr);
    drawn_ = true;
}

void ProgressBar::finish() {
    if (drawn_) std::fprintf(stderr, "\r\033[K");
    drawn_ = false;
}

}  // namespace strata
