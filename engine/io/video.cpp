#include "engine/io/video.h"

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <vector>

extern char** environ;

namespace strata {

namespace {

// Runs `argv` with stderr into `log`; returns the exit status, or -1 with errno set if it cannot start.
int run(const std::vector<std::string>& argv, const std::filesystem::path& log) {
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, STDIN_FILENO, "/dev/null", O_RDONLY, 0);
    posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, "/dev/null", O_WRONLY, 0);
    posix_spawn_file_actions_addopen(&actions, STDERR_FILENO, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
    std::vector<char*> args;
    for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
    args.push_back(nullptr);
    pid_t pid = 0;
    const int error = posix_spawnp(&pid, args[0], &actions, nullptr, args.data(), environ);
    posix_spawn_file_actions_destroy(&actions);
    if (error != 0) {
        errno = error;
        return -1;
    }
    int status = 0;
    while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
    }
    return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

std::string last_lines(const std::filesystem::path& log) {
    std::ifstream in(log);
    std::string line, text;
    std::vector<std::string> lines;
    while (std::getline(in, line))
        if (!line.empty()) lines.push_back(line);
    for (size_t i = lines.size() > 3 ? lines.size() - 3 : 0; i < lines.size(); ++i) text += (text.empty() ? "" : "; ") + lines[i];
    return text.empty() ? "no message" : text;
}

}  // namespace

FramePattern::FramePattern(const std::string& pattern) {
    auto fail = [&](const std::string& why) {
        throw std::invalid_argument("frame pattern '" + pattern + "': " + why +
                                    " (one %d or %0Nd with N from 1 to 9 for the number, %% for a percent sign)");
    };
    bool numbered = false;
    for (size_t i = 0; i < pattern.size(); ++i) {
        std::string& text = numbered ? after_ : before_;
        if (pattern[i] != '%') {
            text += pattern[i];
            continue;
        }
        if (i + 1 < pattern.size() && pattern[i + 1] == '%') {
            text += '%';
            ++i;
            continue;
        }
        size_t end = i + 1;
        if (end + 1 < pattern.size() && pattern[end] == '0' && pattern[end + 1] >= '1' && pattern[end + 1] <= '9') {
            width_ = pattern[end + 1] - '0';
            end += 2;
        }
        if (end >= pattern.size() || pattern[end] != 'd') fail("'%' at offset " + std::to_string(i) + " is not %d, %0Nd or %%");
        if (numbered) fail("more than one number");
        numbered = true;
        i = end;
    }
    if (!numbered) fail("no %d for the frame number");
}

std::string FramePattern::name(int number) const {
    std::string digits = std::to_string(number);
    const bool negative = number < 0;
    if (int(digits.size()) - negative < width_) digits.insert(negative, size_t(width_ - (int(digits.size()) - negative)), '0');
    return before_ + digits + after_;
}

void encode_video(const VideoOptions& o) {
    const std::string target = o.output.string();
    auto fail = [&](const std::string& why) { throw std::runtime_error("cannot write " + target + ": " + why); };
    if (!(o.fps > 0 && std::isfinite(o.fps))) fail("the frame rate must be positive");
    if (o.quality < 0 || o.quality > 51) fail("the quality (x264 CRF) must be 0 to 51");
    std::string first;
    try {
        first = FramePattern(o.frames).name(o.first_frame);
    } catch (const std::invalid_argument& e) {
        fail(e.what());
    }
    if (!std::filesystem::exists(first))
        fail("no frame " + first + " (frames '" + o.frames + "' from " + std::to_string(o.first_frame) + ")");
    std::filesystem::path temp = o.output;
    temp.replace_filename("." + o.output.filename().string() + ".tmp-" + std::to_string(getpid()) + ".mp4");
    const std::filesystem::path log = temp.string() + ".log";
    std::ostringstream fps;
    fps.precision(17);
    fps << o.fps;
    const int status = run({o.ffmpeg, "-nostdin", "-y", "-loglevel", "error", "-framerate", fps.str(), "-start_number",
                            std::to_string(o.first_frame), "-i", o.frames, "-c:v", "libx264", "-pix_fmt", "yuv420p",
                            "-crf", std::to_string(o.quality), "-movflags", "+faststart",
                            // H.264 in 4:2:0 needs even sizes: pad an odd edge by one pixel.
                            "-vf", "pad=ceil(iw/2)*2:ceil(ih/2)*2", temp.string()},
                           log);
    const int spawn_error = errno;
    const std::string message = status == 0 ? "" : last_lines(log);
    std::error_code ignored;
    std::filesystem::remove(log, ignored);
    if (status < 0) {
        std::filesystem::remove(temp, ignored);
        if (spawn_error == ENOENT) fail("'" + o.ffmpeg + "' not found: install Debian's ffmpeg package (scripts/setup.sh does)");
        fail("cannot start " + o.ffmpeg + ": " + std::strerror(spawn_error));
    }
    if (status != 0) {
        std::filesystem::remove(temp, ignored);
        fail(o.ffmpeg + " failed (status " + std::to_string(status) + "): " + message);
    }
    std::filesystem::rename(temp, o.output, ignored);
    if (ignored) {
        std::filesystem::remove(temp, ignored);
        fail("cannot rename the finished video into place");
    }
}

}  // namespace strata
