// A one-line progress bar on stderr (stage, bar, rate, ETA), drawn only when stderr is a terminal.
#pragma once

#include "preprocess/progress.h"

#include <atomic>
#include <chrono>
#include <string>

namespace strata {

class ProgressBar {
public:
    // enabled = false keeps it silent (stderr is not a terminal, or --quiet).
    explicit ProgressBar(bool enabled);
    ~ProgressBar();
    // A Progress that draws on this bar and reads `cancel`.
    Progress progress(const std::atomic<bool>* cancel);
    void finish();  // clears the line

private:
    void update(std::string_view stage, double done, double total, std::string_view unit);
    bool enabled_;
    std::string stage_;
    std::chrono::steady_clock::time_point stage_start_, last_draw_;
    bool drawn_ = false;
};

// "40 s", "12 min", "2.5 h": a duration for messages, to two figures at most.
std::string describe_duration(double seconds);

// Ctrl-C raises the returned flag instead of killing the process, so long work can stop cleanly and
// remove its partial output. A second Ctrl-C kills as usual.
const std::atomic<bool>* install_interrupt_flag();

}  // namespace strata
