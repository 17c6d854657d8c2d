// OpenSceneGraph .path files: the text form of osg::AnimationPath that osgViewer's
// RecordCameraPathHandler ('z' in osgviewer) writes and AnimationPathManipulator plays back.
//
// One control point per line: `time px py pz qx qy qz qw`. The position and quaternion are the camera's
// world pose (the recorder stores the inverse view matrix's translation and rotation), and an osg::Quat
// (x, y, z, w) rotates vectors exactly as glm::dquat(w, x, y, z) does: OSG's row-vector matrices
// (v' = v·M) hold the transpose of the column-vector matrix, so the same quaternion names the same
// rotation. OSG's camera also looks down its −Z with +Y up. So a control point is our Pose as it is: no
// axis change (OSG scenes are often Z-up; the poses are kept exactly) and no conjugation.
// Checked against OpenSceneGraph 3.6 (src/osg/AnimationPath.cpp read/write, src/osgViewer/
// ViewerEventHandlers.cpp RecordCameraPathHandler::handle) and with libosg itself: the world matrix of
// lookAt(eye, centre, up) gives a quaternion q with q·(0, 0, −1) along centre − eye.
#pragma once

#include <filesystem>
#include <iosfwd>
#include <optional>
#include <string_view>
#include <vector>

#include "engine/path/camera_path.h"

namespace strata {

// The keys of a .path stream: position and orientation as written, durations the differences of
// successive times (the first time, often not 0, becomes the path's start); fov is Keyframe's default
// (the format has none). Throws std::runtime_error("<source>:<line>: ...") for a line that is not 8
// numbers, a non-finite number, a zero quaternion, times that do not increase, or fewer than 2 points.
std::vector<Keyframe> read_osg_path(std::istream& in, std::string_view source);
// A CameraPath through a .path file's keys.
CameraPath import_osg_path(const std::filesystem::path& file, PathOptions options = {});

// Writes `path` in the .path format with 17 significant digits (a lossless round trip): its keys at
// their key times, or, given `fps`, every frame, which OSG's playback (linear between control points)
// then follows closely. The file is written beside `file` and renamed over it.
void write_osg_path(const CameraPath& path, std::ostream& out, std::optional<double> fps = std::nullopt);
void export_osg_path(const CameraPath& path, const std::filesystem::path& file, std::optional<double> fps = std::nullopt);

}  // namespace strata
