// How long work reports progress and learns it was cancelled. Preprocessing never prints: it calls
// the callback, and the caller (a terminal bar, a Lua on_progress, nothing) decides what to show.
#pragma once

#include <atomic>
#include <functional>
#include <stdexcept>
#include <string_view>

namespace strata {

// Thrown out of long work when the cancel flag is raised; the work leaves no output behind.
class Cancelled : public std::runtime_error {
public:
    Cancelled() : std::runtime_error("cancelled") {}
};

struct Progress {
    // stage: what is running ("read", "simplify level 5", ...); done/total in the stage's own unit
    // (unit names it: "B", "tri"). Called from one thread at a time, often; keep it cheap.
    std::function<void(std::string_view stage, double done, double total, std::string_view unit)> report;
    const std::atomic<bool>* cancel = nullptr;

    void operator()(std::string_view stage, double done, double total, std::string_view unit) const {
        if (report) report(stage, done, total, unit);
    }
    bool cancelled() const { return cancel && cancel->load(std::memory_order_relaxed); }
    void check() const {
        if (cancelled()) throw Cancelled();
    }
};

}  // namespace strata
