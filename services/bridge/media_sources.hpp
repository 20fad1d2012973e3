#pragma once
// The files and v4l2 sources are a module of their own (libthermovis_bridge_media.so, next to the
// executables), loaded by make_source() only when one of them is asked for: OpenCV's image
// codecs and video I/O pull in some 240 shared libraries whose loading delayed every start of
// the bridge, and a restarted bridge is an outage of the whole pipeline.
#include "frame_source.hpp"

namespace thermovis::bridge {

inline constexpr const char* kMediaModule = "libthermovis_bridge_media.so";
inline constexpr const char* kMediaSourceFactorySymbol = "thermovis_bridge_media_source";
// A new source for options.kind "files" or "v4l2"; throws std::runtime_error as make_source().
using MediaSourceFactory = FrameSource* (*)(const SourceOptions&, const camera::Rig&);

}  // namespace thermovis::bridge

extern "C" thermovis::bridge::FrameSource* thermovis_bridge_media_source(
    const thermovis::bridge::SourceOptions& options, const thermovis::camera::Rig& rig);
