#pragma once
// Manifest YAML (deploy/pipeline.yaml documents the format):
//   name: default
//   services:
//     - name: bridge
//       command: ["${bin}/thermovis-bridge", "--config", "${config}/bridge.yaml"]
//       env: {FASTRTPS_DEFAULT_PROFILES_FILE: "${config}/dds/shm.xml"}
//       restart: on-failure        # always | on-failure | never
//       depends_on: []
//       backoff: {initial_s: 0.1, max_s: 5.0, stable_after_s: 10}
//       stop_timeout_s: 3
//       nice: 0                    # -20..19, added to the supervisor's; a display: 10
//       idle: false                # true: SCHED_IDLE, only CPU time nothing else wants
//       realtime: 0                # 1..99: SCHED_FIFO at this priority (the frame path's stages)
#include <filesystem>
#include <string>

#include "thermovis/process/manifest.hpp"

namespace thermovis::process {

// Throws runtime::ConfigError naming the file, line and key.
Manifest parse_manifest(const std::string& yaml_text, const std::string& source_name);
Manifest load_manifest(const std::filesystem::path& path);

}  // namespace thermovis::process
