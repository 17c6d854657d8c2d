// Video: a numbered frame sequence encoded to MP4 (H.264) by Debian's `ffmpeg` program, run as a child
// process (no shell). The video is written to a temporary file and renamed when ffmpeg succeeds.
#pragma once

#include <filesystem>
#include <string>

namespace strata {

struct VideoOptions {
    std::string frames;               // pattern of the frames: "out/f%05d.png" (see FramePattern)
    std::filesystem::path output;     // the .mp4 to write
    double fps = 30;
    int first_frame = 0;              // the number of the first frame in the pattern
    int quality = 18;                 // x264's CRF: 0 lossless … 51 worst; 18 looks lossless
    std::string ffmpeg = "ffmpeg";    // the program, looked up on PATH
};

// A frame-name pattern as ffmpeg's image2 reader takes it: one %d or %0Nd (N from 1 to 9) for the
// number, %% for a percent sign, nothing else (the pattern may come from a script: it never reaches
// printf). The constructor throws std::invalid_argument naming the pattern.
class FramePattern {
public:
    explicit FramePattern(const std::string& pattern);
    std::string name(int number) const;

private:
    std::string before_, after_;  // %% already read as %
    int width_ = 0;               // at least this many digits, zero-padded
};

// Throws std::runtime_error naming the output and the problem: ffmpeg missing ("install Debian's
// ffmpeg package"), no frames, or ffmpeg's own last words.
void encode_video(const VideoOptions& options);

}  // namespace strata
